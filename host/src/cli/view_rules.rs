//! The command line's rules of a scene, lent to `host view` for the scenes it saves.

use super::{applicable, scene_file};
use anyhow::Result;
use engine::render_job::scene_record::SceneRecord;
use engine::render_job::RenderOptions;
use std::path::Path;

/// The command line's rules of a scene, for the viewer's saved scenes: a key applies where
/// `host render` would take its flag for the render, and a scene is checked as `host render
/// SCENE` checks it.
pub struct CliRules;

impl viewer::SceneRules for CliRules {
    fn applies(&self, key: &str, options: &RenderOptions) -> bool {
        scene_file::flag_id(key).is_some_and(|id| applicable::check(options, &[id]).is_ok())
    }

    fn check(&self, rec: &SceneRecord) -> Result<()> {
        let tokens = scene_file::record_tokens(rec, Path::new("the viewer's scene"))?;
        let args = scene_file::parse_render(tokens)?;
        let options = args.options();
        engine::render_job::check_render_flags(&options)?;
        applicable::check(&options, &args.given)
    }
}
