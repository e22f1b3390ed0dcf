//! The window's event loop: input changes the settings (each change starts the samples
//! anew), and every redraw renders a few more samples and shows them.

use crate::camera::OrbitCamera;
use crate::hud::Frame;
use crate::session::{Session, Settings};
use crate::{SceneRules, ViewOptions};
use engine::backend::gpu::present::{Presenter, Shown};
use engine::backend::gpu::Gpu;
use engine::render_job::preview::Preview;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

/// Milliseconds a frame aims at: the samples per frame adapt to it (at most [`MAX_FRAME`]).
const FRAME_MS: f64 = 100.0;
/// Most samples per pixel in one frame.
const MAX_FRAME: u32 = 16;
/// How long after the last camera move a preview gives way to the full size.
const SETTLE: std::time::Duration = std::time::Duration::from_millis(300);

/// The preview factor (window pixels per rendered pixel along each axis, 1 to 8) that brings a
/// frame of `full_ms` at the full size down to about `target_ms`: the pixels fall with its
/// square.
pub fn preview_factor(full_ms: f64, target_ms: f64) -> u32 {
    if !(target_ms > 0.0) || !(full_ms > target_ms) {
        return 1;
    }
    ((full_ms / target_ms).sqrt().ceil() as u32).clamp(1, 8)
}

/// What the event loop leaves when it ends: the swapchain (kept for the next scene), the
/// settings to load anew (a new lookup), and how it ended.
pub struct Exit {
    pub presenter: Presenter,
    pub reload: Option<Settings>,
    pub result: anyhow::Result<()>,
}

pub struct App<'a> {
    window: &'a Window,
    gpu: &'a Gpu,
    presenter: Presenter,
    session: Session<'a>,
    options: &'a ViewOptions,
    rules: &'a dyn SceneRules,
    /// Settings that need the volume packed anew (the event loop ends, `run` loads them).
    reload: Option<Settings>,
    /// The last camera move (a preview ends [`SETTLE`] after it).
    last_move: Instant,
    /// Render ms per sample of the last full-size frame (what a preview's factor is chosen by).
    full_ms_per_sample: f64,
    /// Samples the next frame renders.
    frame_samples: u32,
    last_frame_ms: f64,
    /// The mouse position in window pixels.
    cursor: (f64, f64),
    left: bool,
    right: bool,
    /// Dragging the split view's line.
    dragging_split: bool,
    /// Column of the split view's line, in render pixels.
    split_x: u32,
    hud: bool,
    /// The last message shown on the HUD (a save, a refused setting).
    message: String,
    /// Whether "reached" was printed for the current samples.
    reported: bool,
    shift: bool,
    /// Since the samples started: frames, their render time and the time to show them (read
    /// back, tone-map, present), in ms.
    frames: u32,
    /// The first frame's render time (it builds the pipelines a device builds on first use).
    first_ms: f64,
    /// The render time of the frames after the first.
    render_ms: f64,
    show_ms: f64,
    result: anyhow::Result<()>,
}

impl<'a> App<'a> {
    pub fn new(
        window: &'a Window,
        gpu: &'a Gpu,
        presenter: Presenter,
        session: Session<'a>,
        options: &'a ViewOptions,
        rules: &'a dyn SceneRules,
    ) -> Self {
        let split_x = session.settings.options.image.width / 2;
        App {
            window,
            gpu,
            presenter,
            session,
            options,
            rules,
            reload: None,
            last_move: Instant::now(),
            full_ms_per_sample: 0.0,
            frame_samples: options.frame_samples.unwrap_or(1),
            last_frame_ms: 0.0,
            cursor: (0.0, 0.0),
            left: false,
            right: false,
            dragging_split: false,
            split_x,
            hud: !options.no_hud,
            message: String::new(),
            reported: false,
            shift: false,
            frames: 0,
            first_ms: 0.0,
            render_ms: 0.0,
            show_ms: 0.0,
            result: Ok(()),
        }
    }

    /// Applies `change` to a copy of the settings; refused settings keep the current ones and
    /// say why on the HUD and stderr.
    fn change(&mut self, what: &str, change: impl FnOnce(&mut Settings)) {
        let mut s = self.session.settings.clone();
        change(&mut s);
        match self.session.change(s) {
            Ok(()) => {
                self.restarted();
                self.message = what.to_owned();
                println!("view: {what}: restarted");
            }
            Err(e) => {
                self.message = format!("refused: {e:#}");
                eprintln!("view: {what} refused: {e:#}");
            }
        }
        self.window.request_redraw();
    }

    /// The swapchain, the settings to reload and the result, once the event loop has ended.
    pub fn exit(self) -> Exit {
        Exit {
            presenter: self.presenter,
            reload: self.reload,
            result: self.result,
        }
    }

    /// Whether the scene key `key` applies to the current render (else says so on the HUD).
    fn applies(&mut self, key: &str, what: &str) -> bool {
        let o = crate::session::with_camera(
            &self.session.settings.options,
            &self.session.settings.camera,
        );
        let yes = self.rules.applies(key, &o);
        if !yes {
            self.note(&format!("{what} does not apply to this render (--{key})"));
        }
        yes
    }

    /// The samples started anew: so do the frame statistics.
    fn restarted(&mut self) {
        self.reported = false;
        self.frames = 0;
        self.first_ms = 0.0;
        self.render_ms = 0.0;
        self.show_ms = 0.0;
    }

    fn camera(&mut self, what: &str, f: impl FnOnce(&mut OrbitCamera)) {
        let mut c = self.session.settings.camera;
        f(&mut c);
        match self.session.set_camera(c) {
            Ok(()) => {
                self.restarted();
                self.message = what.to_owned();
                println!("view: {what}: restarted");
                self.last_move = Instant::now();
                let f = preview_factor(self.full_ms_per_sample, self.options.preview_ms);
                if f != self.session.preview() {
                    self.session.set_preview(f);
                }
            }
            Err(e) => self.note(&format!("{what} refused: {e:#}")),
        }
        self.window.request_redraw();
    }

    /// Renders the next samples and shows the image.
    fn frame(&mut self) -> anyhow::Result<()> {
        let spp = self.session.samples();
        let max = self.options.max_spp;
        if spp < max {
            let t = Instant::now();
            let want = self.frame_samples.min(max - spp);
            let got = self.session.advance(want)?;
            self.last_frame_ms = t.elapsed().as_secs_f64() * 1e3;
            if self.session.preview() == 1 && self.frames > 0 {
                // The first frame builds pipelines; the frames after it are the render's.
                self.full_ms_per_sample = self.last_frame_ms / f64::from(got.max(1));
            }
            if self.frames == 0 {
                self.first_ms = self.last_frame_ms;
            } else {
                self.render_ms += self.last_frame_ms;
            }
            self.frames += 1;
            if self.options.frame_samples.is_none() {
                let per_sample = self.last_frame_ms / f64::from(got.max(1));
                self.frame_samples = ((FRAME_MS / per_sample.max(1e-3)) as u32).clamp(1, MAX_FRAME);
            }
        }
        let spp = self.session.samples();
        let t = Instant::now();
        self.show()?;
        self.show_ms += t.elapsed().as_secs_f64() * 1e3;
        if spp >= max && !self.reported && self.session.preview() == 1 {
            self.reported = true;
            let frames = f64::from(self.frames.max(1));
            let later = f64::from(self.frames.saturating_sub(1).max(1));
            println!(
                "view: reached {spp} spp (--max-spp) in {} frames ({}x{}): the first {:.1} ms, \
                 then {:.1} ms rendering per frame; {:.1} ms showing per frame; idle",
                self.frames,
                self.session.settings.options.image.width,
                self.session.settings.options.image.height,
                self.first_ms,
                self.render_ms / later,
                self.show_ms / frames,
            );
        }
        Ok(())
    }

    /// Shows the samples so far (with the HUD).
    fn show(&mut self) -> anyhow::Result<()> {
        let spp = self.session.samples();
        if spp == 0 {
            return Ok(());
        }
        let o = &self.session.settings.options;
        let (full_w, full_h) = (o.image.width, o.image.height);
        let (w, h) = self.session.image_size();
        let preview = self.session.preview();
        let (pixels, split) = self.session.pixels()?;
        // The split view's right half shows with the left image's gain (one exposure for both).
        let tone = Preview::of(o.integrator, o.exposure.gain, !o.exposure.fixed, &pixels);
        let right = split
            .as_deref()
            .map(|r| (r, (self.split_x / preview).min(w)));
        let mut frame = Frame::of(w, h, &pixels, right, tone).enlarged(full_w, full_h);
        let flags = engine::render::diagnostics::RayFlags::of(&pixels, spp);
        let samples: f64 = pixels.iter().map(|p| f64::from(p.samples)).sum();
        let per_ray = samples / (pixels.len() as f64 * f64::from(spp));
        let mut name = format!("{} N={}", o.estimation.estimator.name, o.estimation.n);
        if let Some(s) = self.session.settings.split {
            name = format!("{name} | {} (right)", s.name);
        }
        if let Some(i) = o.integrator {
            name = format!("{} | {name}", i.unit().name);
        }
        let mut status = format!(
            "{spp} spp  {:.0} ms/frame  {:.2} lookups/ray  capped {}  outside {}",
            self.last_frame_ms, per_ray, flags.capped_rays, flags.jackknife_outside_rays
        );
        if preview > 1 {
            status = format!("preview 1/{preview}  {status}");
        }
        self.window
            .set_title(&format!("host view: {name} | {status}"));
        if self.hud {
            let mut lines = vec![name, status];
            if !self.message.is_empty() {
                lines.push(self.message.clone());
            }
            frame.text(&lines, if full_w >= 1000 { 2 } else { 1 });
        }
        if self
            .presenter
            .present(self.gpu, &frame.rgba, frame.width, frame.height)?
            == Shown::Stale
        {
            let size = self.window.inner_size();
            self.presenter.resize(size.width, size.height)?;
        }
        Ok(())
    }

    fn screenshot(&mut self) {
        if self.session.preview() > 1 {
            self.note("the view is a preview while the camera moves; P saves once it settles");
            return;
        }
        let spp = self.session.samples();
        let stem = crate::save::next_stem(&self.options.save_dir);
        let result = self.session.pixels().and_then(|(pixels, _)| {
            crate::save::screenshot(&self.session.settings, &pixels, spp, &stem, self.rules)
        });
        match result {
            Ok(paths) => {
                let names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
                self.message = format!("saved {} ({spp} spp)", names.join(", "));
                println!(
                    "view: wrote {} ({spp} spp; `host render {}` renders it again)",
                    names.join(", "),
                    paths[2].display()
                );
            }
            Err(e) => {
                self.message = format!("save failed: {e:#}");
                eprintln!("view: save failed: {e:#}");
            }
        }
        self.window.request_redraw();
    }

    fn key(&mut self, key: &Key, event_loop: &ActiveEventLoop) {
        let step = 0.05;
        match key {
            Key::Named(NamedKey::Escape) => event_loop.exit(),
            Key::Named(NamedKey::Space) => {
                self.session.restart();
                self.restarted();
                println!("view: restart: restarted");
                self.window.request_redraw();
            }
            Key::Named(NamedKey::ArrowLeft) => self.sun("sun azimuth", -10.0, 0.0),
            Key::Named(NamedKey::ArrowRight) => self.sun("sun azimuth", 10.0, 0.0),
            Key::Named(NamedKey::ArrowUp) => self.sun("sun elevation", 0.0, 5.0),
            Key::Named(NamedKey::ArrowDown) => self.sun("sun elevation", 0.0, -5.0),
            Key::Character(c) => match c.as_str() {
                "q" | "Q" => event_loop.exit(),
                "w" | "W" => self.camera("fly", |c| c.translate(0.0, 0.0, step)),
                "s" | "S" => self.camera("fly", |c| c.translate(0.0, 0.0, -step)),
                "a" | "A" => self.camera("fly", |c| c.translate(-step, 0.0, 0.0)),
                "d" | "D" => self.camera("fly", |c| c.translate(step, 0.0, 0.0)),
                "r" | "R" => self.camera("fly", |c| c.translate(0.0, step, 0.0)),
                "f" | "F" => self.camera("fly", |c| c.translate(0.0, -step, 0.0)),
                "e" | "E" if !self.applies("estimator", "the estimator") => {}
                "e" => self.estimator(1),
                "E" => self.estimator(-1),
                "i" => self.integrator(1),
                "I" => self.integrator(-1),
                "l" | "L" => self.lookup(event_loop),
                "=" | "+" => self.change("N", |s| {
                    s.options.estimation.n = (s.options.estimation.n + 1).min(4096)
                }),
                "-" => self.change("N", |s| {
                    s.options.estimation.n = s.options.estimation.n.saturating_sub(1).max(1)
                }),
                "]" | "[" if !self.applies("exposure", "the exposure") => {}
                "]" => self.change("exposure", |s| s.options.exposure.gain *= 2f32.sqrt()),
                "[" => self.change("exposure", |s| s.options.exposure.gain /= 2f32.sqrt()),
                "." | "," if !self.applies("env-rotate", "the light probe rotation") => {}
                "." => self.change("light probe rotation", |s| {
                    s.options.lighting.env_rotate =
                        wrap_degrees(s.options.lighting.env_rotate + 15.0)
                }),
                "," => self.change("light probe rotation", |s| {
                    s.options.lighting.env_rotate =
                        wrap_degrees(s.options.lighting.env_rotate - 15.0)
                }),
                "b" | "B" if !self.applies("estimator", "the split view of estimators") => {}
                "b" | "B" => {
                    let next = match self.session.settings.split {
                        Some(_) => None,
                        None => Some(engine::estimators::by_name("track-length").expect("known")),
                    };
                    self.change("split view", |s| s.split = next);
                }
                "v" | "V" => {
                    if let Some(cur) = self.session.settings.split {
                        let next = cycle(cur, if c.as_str() == "v" { 1 } else { -1 });
                        self.change("split estimator", |s| s.split = Some(next));
                    }
                }
                "h" | "H" => {
                    self.hud = !self.hud;
                    self.window.request_redraw();
                }
                "p" | "P" => self.screenshot(),
                _ => {}
            },
            _ => {}
        }
    }

    /// Shows `message` on the HUD and stderr (a key that does not apply).
    fn note(&mut self, message: &str) {
        self.message = message.to_owned();
        eprintln!("view: {message}");
        self.window.request_redraw();
    }

    /// The integrator `by` places after the current one (none: transmittance, then the table's
    /// order), with the lights it reads; the split view ends where the estimator does not
    /// apply.
    fn integrator(&mut self, by: i32) {
        use shared::params::Integrator;
        let count = shared::integrators::unit::UNITS.len() as i32 + 1;
        let cur = self
            .session
            .settings
            .options
            .integrator
            .map_or(0, |i| i as i32);
        let next = (cur + by).rem_euclid(count) as u32;
        let integrator = (next > 0).then(|| Integrator::from_u32(next));
        let mut o = self.session.settings.options.clone();
        o.integrator = integrator;
        let keep_split = self.rules.applies("estimator", &o);
        self.change("integrator", |s| {
            s.options.integrator = integrator;
            if !keep_split {
                s.split = None;
            }
        });
    }

    /// The next lookup (nearest, stochastic, trilinear): the volume is packed anew for it, so
    /// the event loop ends and the viewer loads it.
    fn lookup(&mut self, event_loop: &ActiveEventLoop) {
        use shared::volume::grid::Lookup;
        let mut s = self.session.settings.clone();
        s.options.estimation.lookup = match s.options.estimation.lookup {
            Lookup::Nearest => Lookup::Stochastic,
            Lookup::Stochastic => Lookup::Trilinear,
            Lookup::Trilinear => Lookup::Nearest,
        };
        println!(
            "view: lookup {}: loading the volume anew",
            engine::scene::lookup_name(s.options.estimation.lookup)
        );
        self.reload = Some(s);
        event_loop.exit();
    }

    fn estimator(&mut self, by: i32) {
        let next = cycle(self.session.settings.options.estimation.estimator, by);
        self.change("estimator", |s| s.options.estimation.estimator = next);
    }

    /// Turns the sun (where the scene has one) by `azimuth` and `elevation` degrees.
    fn sun(&mut self, what: &str, azimuth: f32, elevation: f32) {
        if !self.applies("sun", "the sun") {
            return;
        }
        if self.session.settings.options.lighting.sun.is_none() {
            self.note("no sun in this scene (give --sun with --integrator direct, path or restir)");
            return;
        }
        self.change(what, |s| {
            if let Some(sun) = &mut s.options.lighting.sun {
                let [x, y, z] = sun.dir;
                let r = (x * x + y * y + z * z).sqrt();
                let mut az = z.atan2(x).to_degrees() + azimuth;
                let el = ((y / r).asin().to_degrees() + elevation).clamp(-89.0, 89.0);
                az = wrap_degrees(az);
                let (ae, aa) = (el.to_radians(), az.to_radians());
                sun.dir = [ae.cos() * aa.cos(), ae.sin(), ae.cos() * aa.sin()];
            }
        });
    }

    /// Render pixels per window pixel: the render fills the window at 1/scale.
    fn render_size(&self, w: u32, h: u32) -> (u32, u32) {
        let s = self.options.scale.max(1);
        ((w / s).max(1), (h / s).max(1))
    }
}

/// `deg` in (-360, 360), as `--env-rotate` takes it.
fn wrap_degrees(deg: f32) -> f32 {
    deg % 360.0
}

/// The estimator `by` places after `cur` in the table (wrapping).
fn cycle(
    cur: &'static engine::estimators::EstimatorSpec,
    by: i32,
) -> &'static engine::estimators::EstimatorSpec {
    let all = engine::estimators::ESTIMATORS;
    let i = all.iter().position(|s| s.name == cur.name).unwrap_or(0) as i32;
    let n = all.len() as i32;
    &all[((i + by).rem_euclid(n)) as usize]
}

impl ApplicationHandler for App<'_> {
    fn resumed(&mut self, _event_loop: &ActiveEventLoop) {
        self.window.request_redraw();
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Err(e) = self.presenter.resize(size.width, size.height) {
                    self.result = Err(e.into());
                    event_loop.exit();
                    return;
                }
                if size.width > 0 && size.height > 0 {
                    let (w, h) = self.render_size(size.width, size.height);
                    let o = &self.session.settings.options;
                    if (w, h) != (o.image.width, o.image.height) {
                        self.split_x = w / 2;
                        self.change(&format!("window size {w}x{h}"), |s| {
                            s.options.image.width = w;
                            s.options.image.height = h;
                        });
                    }
                }
            }
            WindowEvent::ModifiersChanged(m) => self.shift = m.state().shift_key(),
            WindowEvent::KeyboardInput { event, .. } => {
                if event.state == ElementState::Pressed {
                    self.key(&event.logical_key, event_loop);
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                match button {
                    MouseButton::Left => {
                        self.left = down;
                        let s = self.options.scale.max(1) as f64;
                        self.dragging_split = down
                            && self.session.settings.split.is_some()
                            && (self.cursor.0 / s - f64::from(self.split_x)).abs() < 6.0;
                    }
                    MouseButton::Right | MouseButton::Middle => self.right = down,
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                let (dx, dy) = (position.x - self.cursor.0, position.y - self.cursor.1);
                self.cursor = (position.x, position.y);
                let h = f64::from(self.window.inner_size().height.max(1));
                if self.dragging_split {
                    let s = self.options.scale.max(1) as f64;
                    self.split_x = (position.x / s).max(0.0) as u32;
                    self.window.request_redraw();
                } else if self.left && !self.shift {
                    self.camera("orbit", |c| c.orbit(dx * 0.01, dy * 0.01));
                } else if self.right || (self.left && self.shift) {
                    self.camera("pan", |c| c.translate(-dx / h, dy / h, 0.0));
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => f64::from(y),
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                self.camera("dolly", |c| c.dolly(0.9f64.powf(lines)));
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.frame() {
                    self.result = Err(e);
                    event_loop.exit();
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if self.session.preview() > 1 {
            if self.last_move.elapsed() >= SETTLE {
                self.session.set_preview(1);
                self.restarted();
                self.message = "settled".into();
                self.window.request_redraw();
            } else {
                event_loop.set_control_flow(ControlFlow::WaitUntil(self.last_move + SETTLE));
                if self.session.samples() < self.options.max_spp {
                    self.window.request_redraw();
                }
                return;
            }
        }
        if self.session.samples() < self.options.max_spp {
            event_loop.set_control_flow(ControlFlow::Poll);
            self.window.request_redraw();
        } else {
            event_loop.set_control_flow(ControlFlow::Wait);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::preview_factor;

    /// The factor's square covers the slowdown, within 1 to 8; fast frames need no preview.
    #[test]
    fn preview_factor_brings_the_frame_to_its_target() {
        assert_eq!(preview_factor(40.0, 50.0), 1);
        assert_eq!(preview_factor(0.0, 50.0), 1);
        assert_eq!(preview_factor(1000.0, 0.0), 1);
        assert_eq!(preview_factor(200.0, 50.0), 2);
        assert_eq!(preview_factor(201.0, 50.0), 3);
        assert_eq!(preview_factor(1441.0, 50.0), 6);
        assert_eq!(preview_factor(1e9, 50.0), 8);
        assert_eq!(preview_factor(f64::NAN, 50.0), 1);
    }
}
