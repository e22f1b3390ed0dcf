//! `host view`: an interactive, progressive viewer. A winit window shows the render through the
//! Vulkan backend's swapchain while its samples accumulate (on the GPU, or on the CPU where
//! `--backend` says so); the mouse and keys move the camera and switch the estimator, N, the
//! exposure, the light probe's rotation, the sun and a split view of two estimators, and every
//! change starts the samples anew. A screenshot (EXR + PNG) and its scene file are the bytes
//! `host render` gives for that scene file.
//!
//! The viewer renders on the thread of the window's event loop: a frame's samples adapt so that
//! a frame takes about 100 ms, and input is read between frames.

mod app;
pub mod camera;
pub mod hud;
pub mod save;
pub mod session;

use anyhow::{Context, Result};
use engine::backend::gpu::{Display, Gpu};
use engine::backend::{Backend, BackendChoice};
use engine::render::Resident;
use engine::render_job::{RenderOptions, Setup};
use std::path::PathBuf;
use std::sync::Arc;
use winit::dpi::PhysicalSize;
use winit::event_loop::EventLoop;
use winit::platform::run_on_demand::EventLoopExtRunOnDemand;
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};

/// What `host view` shows and where it saves.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    /// The scene, camera and settings to start from (`host render`'s options; `spp` is not
    /// read, the samples accumulate to `max_spp`).
    pub render: RenderOptions,
    /// Samples per pixel at which the accumulation stops.
    pub max_spp: u32,
    /// Samples per frame (None: as many as take about 100 ms, at most 16).
    pub frame_samples: Option<u32>,
    /// Window pixels per render pixel along each axis.
    pub scale: u32,
    /// Where screenshots and scene files go (`view-0001.exr`, `.png`, `.toml`, ...).
    pub save_dir: PathBuf,
    /// Start without the HUD's text.
    pub no_hud: bool,
    /// While the camera moves, render a preview at a lower resolution whose frames take about
    /// this many ms (0: never).
    pub preview_ms: f64,
}

/// The command line's rules of a scene, which the viewer keeps its saved scenes to: which keys
/// apply to which render, and whether `host render` takes a scene (the `host` crate implements
/// them with its flags; the viewer has no flag parser of its own).
pub trait SceneRules {
    /// Whether the scene key `key` (a `host render` flag without its dashes) applies to the
    /// render `options` (its integrator, estimator and shadows read it).
    fn applies(&self, key: &str, options: &RenderOptions) -> bool;
    /// Why `host render` would refuse the scene `rec`, if it would.
    fn check(&self, rec: &engine::render_job::scene_record::SceneRecord) -> Result<()>;
}

/// What a user needs to hear when no window can be opened.
const NO_DISPLAY: &str = "host view needs a display: run it in a desktop session (X11 or \
     Wayland), or under a virtual X server (`xvfb-run -a host view ...`; Debian: `apt-get \
     install xvfb`)";

/// Opens the window, loads the scene and runs the viewer until the window is closed.
pub fn run(options: &ViewOptions, rules: &dyn SceneRules) -> Result<()> {
    let o = &options.render;
    anyhow::ensure!(
        o.layers.is_empty(),
        "--layers: host view shows the image only; render the layers with `host render` of a \
         saved view"
    );
    anyhow::ensure!(o.merge.is_empty(), "host view renders; it merges no shards");
    anyhow::ensure!(options.max_spp >= 1, "--max-spp must be at least 1");
    anyhow::ensure!(options.scale >= 1, "--scale must be at least 1");
    engine::output::OutputPlan::new()
        .dir("--save-dir", &options.save_dir)
        .check()?;
    let mut event_loop = EventLoop::new().map_err(|e| anyhow::anyhow!("{NO_DISPLAY} ({e})"))?;
    let size = PhysicalSize::new(
        o.image.width * options.scale,
        o.image.height * options.scale,
    );
    let attributes = winit::window::Window::default_attributes()
        .with_title("host view")
        .with_inner_size(size);
    // The window is made before the event loop runs (deprecated in winit 0.30, which would
    // have it made inside the loop's callbacks): the Vulkan device, the scene and the render
    // borrow from one another and from the window, so they live in this function, the window
    // longest.
    #[allow(deprecated)]
    let window = event_loop
        .create_window(attributes)
        .map_err(|e| anyhow::anyhow!("{NO_DISPLAY} ({e})"))?;
    let display = Display {
        display: window
            .display_handle()
            .context("the window's display handle")?
            .as_raw(),
        window: window
            .window_handle()
            .context("the window's handle")?
            .as_raw(),
    };
    let gpu = Arc::new(Gpu::with_display(&display).context(
        "host view shows its images through Vulkan; install a Vulkan driver (Mesa's lavapipe: \
         `apt-get install mesa-vulkan-drivers`)",
    )?);
    // The window's own size may differ from the one asked for (a tiling window manager).
    let inner = window.inner_size();
    let mut render = o.clone();
    render.image.width = (inner.width / options.scale).max(1);
    render.image.height = (inner.height / options.scale).max(1);
    let mut presenter = gpu.presenter(inner.width, inner.height)?;
    print_keys();
    let mut carried: Option<session::Settings> = None;
    // One pass per loaded scene: a new lookup packs the volume anew, and the window's event
    // loop runs again on it.
    loop {
        let o = carried
            .as_ref()
            .map_or_else(|| render.clone(), |s| s.options.clone());
        let o = &o;
        let backend = match o.backend {
            BackendChoice::Cpu => Backend::Cpu,
            _ => Backend::Gpu(gpu.clone()),
        };
        // `auto` weighs a job of 64 samples per pixel: the device's pipeline builds against a
        // few seconds of viewing.
        let setup = Setup::with_backend(o, backend, o.backend, 64)?;
        let resident = Resident::new(&setup.backend, &setup.scene.packed)?;
        tracing::info!(
            "host view: rendering on {} ({}), showing on {}",
            setup.backend.kind(),
            setup.backend.device(),
            gpu.description()
        );
        let settings = carried.take().unwrap_or_else(|| session::Settings {
            camera: initial_camera(&render, &setup),
            options: render.clone(),
            split: None,
        });
        let session = session::Session::new(&setup, &resident, settings)?;
        let mut app = app::App::new(&window, &gpu, presenter, session, options, rules);
        event_loop
            .run_app_on_demand(&mut app)
            .context("the window's event loop")?;
        let app::Exit {
            presenter: p,
            reload,
            result,
        } = app.exit();
        result?;
        match reload {
            Some(s) => {
                presenter = p;
                carried = Some(s);
            }
            None => return Ok(()),
        }
    }
}

/// The camera `host render` places for `o`: its eye and target, f32 as a scene file holds
/// them.
fn initial_camera(o: &RenderOptions, setup: &Setup) -> camera::OrbitCamera {
    let [lo, hi] = setup.scene.world_bounds;
    let center = [0, 1, 2].map(|a| (0.5 * (lo[a] + hi[a])) as f32);
    let origin = setup.scene.camera.origin;
    camera::OrbitCamera {
        eye: o.scene.camera.unwrap_or([origin.x, origin.y, origin.z]),
        target: o.scene.look_at.unwrap_or(center),
        fov_deg: o.scene.fov,
    }
}

/// The key map, printed once at the start (the README has it too).
pub const KEYS: &str = "\
mouse: left drag orbit, right drag (or shift + left) pan, wheel dolly; with the split view, drag its line
keys:  W/A/S/D fly forward/left/back/right, R/F up/down
       e / E next / previous estimator, i / I integrator, l lookup (reloads the volume)
       - / = N down / up, [ / ] exposure down / up
       , / . light probe rotation -15 / +15 degrees, arrows: sun azimuth and elevation
       B split view on/off (right: track-length), v / V its next / previous estimator
       P screenshot (EXR + PNG) and its scene file, Space restart, H HUD, Esc or Q quit";

fn print_keys() {
    println!("{KEYS}");
}
