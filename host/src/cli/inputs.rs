//! Every input file a command line names, recorded before any work so that no output of the
//! process can replace one ([`engine::output::inputs::protect`]): volumes, light probes, scene
//! files, shards, sweep files and eval folders. A study's `--profile` CSV is recorded by the
//! study's own output plan.

use super::{Cli, Command};
use engine::lighting::EnvSource;
use std::path::{Path, PathBuf};

/// The input files of `cli`'s command: (the flag that names it, its path).
pub fn of(cli: &Cli) -> Vec<(&'static str, PathBuf)> {
    let mut out = Vec::new();
    let mut scene = |scene_file: &Option<PathBuf>, volume: &str, env: &Option<EnvSource>| {
        if let Some(s) = scene_file {
            out.push(("--scene", s.clone()));
        }
        out.push(("--volume", PathBuf::from(volume)));
        if let Some(EnvSource::File(e)) = env {
            out.push(("--env", e.clone()));
        }
    };
    match &cli.command {
        None => scene(
            &cli.render.scene_file,
            &cli.render.scene.volume,
            &cli.render.env,
        ),
        Some(Command::Render(a)) => scene(&a.scene_file, &a.scene.volume, &a.env),
        Some(Command::View(a)) => {
            scene(&a.render.scene_file, &a.render.scene.volume, &a.render.env)
        }
        Some(Command::Eval(a)) => {
            scene(&a.scene_file, &a.scene.volume, &a.env);
            out.extend(
                a.reference_from
                    .iter()
                    .map(|s| ("--reference-from", s.clone())),
            );
        }
        Some(Command::Bench(a)) => {
            scene(&a.scene_file, &a.scene.volume, &None);
            out.extend(a.sweep_files.iter().map(|s| ("--sweep-files", s.clone())));
        }
        Some(Command::Report(a)) => {
            if let Some(s) = &a.scene_file {
                out.push(("--scene", s.clone()));
            }
            for v in a.volumes.iter().flat_map(|l| l.split(',')) {
                out.push(("--volumes", PathBuf::from(v)));
            }
            out.extend(a.from_eval.iter().map(|s| ("--from-eval", s.clone())));
        }
        Some(Command::Merge(a)) => {
            out.extend(a.shards.iter().map(|s| ("a shard", s.clone())));
        }
        Some(Command::Probe(_)) | Some(Command::Study(_)) => {}
    }
    out
}

/// Records every input of `cli`'s command as protected (see the module's doc).
pub fn protect(cli: &Cli) {
    for (what, path) in of(cli) {
        engine::output::inputs::protect(what, Path::new(&path));
    }
}
