//! One progressive render of the viewer's current settings: the scene loaded once, the lights
//! and parameters of the settings, and the samples so far of the image (and of the split view's
//! second estimator). Any change of settings starts the samples anew.

use crate::camera::OrbitCamera;
use anyhow::{Context, Result};
use engine::estimators::EstimatorSpec;
use engine::lighting::SceneLights;
use engine::render::progressive::Progressive;
use engine::render::Resident;
use engine::render_job::{RenderOptions, Setup};
use engine::scene::camera::make_camera;
use shared::kernels::render::PixelOut;
use shared::params::RenderParams;

/// The settings the viewer changes, on top of the scene it was started with.
#[derive(Clone, Debug)]
pub struct Settings {
    pub options: RenderOptions,
    pub camera: OrbitCamera,
    /// The split view's second estimator (right of the line), if on.
    pub split: Option<&'static EstimatorSpec>,
}

/// A render in progress.
pub struct Session<'a> {
    setup: &'a Setup,
    resident: &'a Resident<'a>,
    pub settings: Settings,
    lights: SceneLights,
    params: RenderParams,
    /// The split view's parameters (the second estimator), if on.
    split_params: Option<RenderParams>,
    image: Progressive,
    split: Progressive,
    /// Window pixels per rendered pixel along each axis while the camera moves (1: the full
    /// size, the render `host render` reproduces).
    preview: u32,
}

impl<'a> Session<'a> {
    /// A render of `settings` with no samples yet.
    pub fn new(setup: &'a Setup, resident: &'a Resident<'a>, settings: Settings) -> Result<Self> {
        let (lights, params, split_params) = prepare(setup, resident, &settings)?;
        Ok(Session {
            setup,
            resident,
            settings,
            lights,
            params,
            split_params,
            image: Progressive::new(),
            split: Progressive::new(),
            preview: 1,
        })
    }

    /// Renders at 1/`factor` of the size along each axis (a preview while the camera moves;
    /// 1: the full size); samples start anew.
    pub fn set_preview(&mut self, factor: u32) {
        self.preview = factor.max(1);
        self.restart();
    }

    /// The preview factor (1: full size).
    pub fn preview(&self) -> u32 {
        self.preview
    }

    /// The size of the image being accumulated (the full size divided by the preview factor,
    /// rounded up).
    pub fn image_size(&self) -> (u32, u32) {
        let o = &self.settings.options;
        (
            o.image.width.div_ceil(self.preview),
            o.image.height.div_ceil(self.preview),
        )
    }

    /// `p` at the size being accumulated: at a preview's size, its camera made for that size.
    fn sized(&self, p: &RenderParams) -> Result<RenderParams> {
        if self.preview == 1 {
            return Ok(*p);
        }
        let (w, h) = self.image_size();
        Ok(RenderParams {
            width: w,
            height: h,
            camera: camera_of(self.setup, &self.settings.camera, w, h)?,
            ..*p
        })
    }

    /// Switches to `settings` (samples start anew); on an error (settings that do not go
    /// together) the current ones stay and the error is returned.
    pub fn change(&mut self, settings: Settings) -> Result<()> {
        let (lights, params, split_params) = prepare(self.setup, self.resident, &settings)?;
        self.settings = settings;
        self.lights = lights;
        self.params = params;
        self.split_params = split_params;
        self.restart();
        Ok(())
    }

    /// Moves the camera only (the lights and the rest of the parameters stay); samples start
    /// anew.
    pub fn set_camera(&mut self, camera: OrbitCamera) -> Result<()> {
        let o = &self.settings.options;
        let c = camera_of(self.setup, &camera, o.image.width, o.image.height)?;
        self.params.camera = c;
        if let Some(p) = &mut self.split_params {
            p.camera = c;
        }
        self.settings.camera = camera;
        self.restart();
        Ok(())
    }

    /// Drops the samples so far.
    pub fn restart(&mut self) {
        self.image = Progressive::new();
        self.split = Progressive::new();
    }

    /// Samples per pixel so far.
    pub fn samples(&self) -> u32 {
        self.image.samples()
    }

    /// Renders the next `count` samples (fewer at a sample block's end) of the image and, in
    /// the split view, of the second estimator; returns how many.
    pub fn advance(&mut self, count: u32) -> Result<u32> {
        let p = self.sized(&self.params)?;
        let n = self.image.advance(self.resident, &p, &self.lights, count)?;
        if let Some(sp) = &self.split_params {
            let sp = self.sized(sp)?;
            self.split.advance(self.resident, &sp, &self.lights, n)?;
        }
        Ok(n)
    }

    /// The image's pixels so far, and the split view's.
    pub fn pixels(&self) -> Result<(Vec<PixelOut>, Option<Vec<PixelOut>>)> {
        let split = match self.split_params {
            Some(_) => Some(self.split.pixels()?),
            None => None,
        };
        Ok((self.image.pixels()?, split))
    }
}

/// The pinhole camera of `camera` for a `w` x `h` image of the loaded scene, as `host render`
/// makes it from `--camera`, `--look-at` and `--fov`.
fn camera_of(
    setup: &Setup,
    camera: &OrbitCamera,
    w: u32,
    h: u32,
) -> Result<shared::camera::Camera> {
    let [lo, hi] = setup.scene.world_bounds;
    let spec = engine::scene::camera::CameraSpec {
        position: Some(camera.eye),
        look_at: Some(camera.target),
        fov_deg: camera.fov_deg,
    };
    make_camera(&spec, (lo, hi), w, h).context("the viewer's camera")
}

/// `options` with the camera of `camera`, for `host render` and its scene file.
pub fn with_camera(options: &RenderOptions, camera: &OrbitCamera) -> RenderOptions {
    let mut o = options.clone();
    o.scene.camera = Some(camera.eye);
    o.scene.look_at = Some(camera.target);
    o.scene.fov = camera.fov_deg;
    o
}

/// The lights and parameters of `settings` on the loaded scene (as `host render` makes them
/// for the same flags, the camera included), and the split view's parameters.
fn prepare(
    setup: &Setup,
    resident: &Resident,
    settings: &Settings,
) -> Result<(SceneLights, RenderParams, Option<RenderParams>)> {
    let options = with_camera(&settings.options, &settings.camera);
    engine::render_job::check_render_flags(&options)?;
    let scene = &setup.scene;
    let mut lights = engine::render_job::render_lights(&options, &scene.volume)?;
    let mut params = engine::render_job::render_params(&options, scene, &lights.points);
    params.camera = camera_of(
        setup,
        &settings.camera,
        options.image.width,
        options.image.height,
    )?;
    engine::render_job::lit_shadows(&options, resident, &params, &mut lights, scene)?;
    let split = settings.split.map(|spec| {
        let mut p = params;
        spec.apply(&mut p);
        p
    });
    Ok((lights, params, split))
}
