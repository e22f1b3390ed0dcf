//! `host view`: the flags of the interactive viewer (`host render`'s, and its own).

use super::render::RenderArgs;
use clap::Args;
use std::path::PathBuf;

/// `host view [SCENE] [render flags]`: the scene of `host render` in a window, accumulating.
#[derive(Args, Debug)]
pub struct ViewArgs {
    #[command(flatten)]
    pub render: RenderArgs,
    /// Samples per pixel at which the accumulation stops (`--spp` is not read: the viewer keeps
    /// adding samples until this many).
    #[arg(long, default_value_t = 4096, allow_hyphen_values = true, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    pub max_spp: u32,
    /// Samples per pixel in each frame (default: as many as take about 100 ms, at most 16).
    #[arg(long, allow_hyphen_values = true, value_parser = clap::value_parser!(u32).range(1..=256))]
    pub frame_spp: Option<u32>,
    /// Window pixels per rendered pixel along each axis (2: a quarter of the pixels to render;
    /// the window is --width x --height times this).
    #[arg(long, default_value_t = 1, allow_hyphen_values = true, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub scale: u32,
    /// Folder of the screenshots (P): view-0001.exr, .png and the view's scene view-0001.toml.
    #[arg(long, default_value = "out/view")]
    pub save_dir: PathBuf,
    /// Start with the HUD's text hidden (H shows it).
    #[arg(long)]
    pub no_hud: bool,
    /// While the camera moves, render a preview at a lower resolution whose frames take about
    /// this many milliseconds (up to 1/8 of the size along each axis); full size again 0.3 s
    /// after the last move. 0: never.
    #[arg(long, default_value_t = 50.0, allow_hyphen_values = true, value_parser = super::parsers::f32_in(0.0, 10000.0))]
    pub preview_ms: f32,
}

impl ViewArgs {
    /// The viewer's options.
    pub fn options(&self) -> viewer::ViewOptions {
        viewer::ViewOptions {
            render: self.render.options(),
            max_spp: self.max_spp,
            frame_samples: self.frame_spp,
            scale: self.scale,
            save_dir: self.save_dir.clone(),
            no_hud: self.no_hud,
            preview_ms: f64::from(self.preview_ms),
        }
    }
}
