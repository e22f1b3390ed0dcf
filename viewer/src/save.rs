//! Saving what the viewer shows: the view as a scene file that `host render` reproduces, and a
//! screenshot (EXR + PNG, written as `host render` writes its images) of the samples so far.

use crate::session::{with_camera, Settings};
use crate::SceneRules;
use anyhow::Result;
use engine::render_job::scene_record::SceneRecord;
use shared::kernels::render::PixelOut;
use std::path::{Path, PathBuf};

/// `settings`' scene at `spp` samples per pixel: the scene the viewer was started with, its
/// camera, integrator, lookup, estimator, N, exposure, light probe rotation and sun replaced by
/// the current ones, and without the keys that do not apply to the current integrator,
/// estimator and shadows (`rules`: `host render` refuses such keys).
pub fn record(settings: &Settings, spp: u32, rules: &dyn SceneRules) -> SceneRecord {
    let o = with_camera(&settings.options, &settings.camera);
    let mut rec = o.scene_record.clone();
    engine::render_job::saved_view::record_view(&mut rec, &o, spp);
    rec.retain(|key, _| rules.applies(key, &o));
    rec
}

/// The first free `view-NNNN` stem in `dir` (no file of that stem with any extension the
/// viewer writes).
pub fn next_stem(dir: &Path) -> PathBuf {
    (1u32..)
        .map(|k| dir.join(format!("view-{k:04}")))
        .find(|s| {
            ["exr", "png", "toml"]
                .iter()
                .all(|e| !s.with_extension(e).exists())
        })
        .expect("a free name")
}

/// Writes the screenshot of `pixels` (`spp` samples of `settings`) as `stem`.exr and .png,
/// and its scene as `stem`.toml; returns the three paths. The paths are checked first (none an
/// input, all writable).
pub fn screenshot(
    settings: &Settings,
    pixels: &[PixelOut],
    spp: u32,
    stem: &Path,
    rules: &dyn SceneRules,
) -> Result<[PathBuf; 3]> {
    let rec = record(settings, spp, rules);
    rules.check(&rec)?;
    let mut o = with_camera(&settings.options, &settings.camera);
    o.image.spp = spp;
    o.out = stem.with_extension("exr");
    o.json = None;
    let toml = stem.with_extension("toml");
    let png = engine::render_job::plan_render_outputs(&o)?;
    let mut plan = engine::output::OutputPlan::new();
    plan.file("the viewer's scene file", &toml);
    if let Some(scene) = &o.scene_file {
        plan.input("--scene", scene);
    }
    plan.check()?;
    let lit = o.integrator.is_some_and(shared::params::Integrator::is_lit);
    engine::render_job::write_images(&o, &png, pixels, &[], lit)?;
    engine::output::write_text(&toml, &engine::render_job::scene_record::to_toml(&rec))?;
    Ok([o.out.clone(), png, toml])
}
