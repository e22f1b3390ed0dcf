//! Saving what the viewer shows: the view as a scene file that `host render` reproduces, and a
//! screenshot (EXR + PNG, written as `host render` writes its images) of the samples so far.

use crate::session::{with_camera, Settings};
use crate::SceneRules;
use anyhow::Result;
use engine::render_job::scene_record::{SceneRecord, SceneValue};
use shared::kernels::render::PixelOut;
use std::path::{Path, PathBuf};

/// `settings`' scene at `spp` samples per pixel: the scene the viewer was started with, its
/// camera, integrator, lookup, estimator, N, exposure, light probe rotation and sun replaced by
/// the current ones, and without the keys that do not apply to the current integrator,
/// estimator and shadows (`rules`: `host render` refuses such keys).
pub fn record(settings: &Settings, spp: u32, rules: &dyn SceneRules) -> SceneRecord {
    let o = with_camera(&settings.options, &settings.camera);
    let mut rec = o.scene_record.clone();
    let list = |v: [f32; 3]| SceneValue::List(v.iter().map(|&x| number(x)).collect());
    rec.insert("camera".into(), list(settings.camera.eye));
    rec.insert("look-at".into(), list(settings.camera.target));
    rec.insert("fov".into(), number(settings.camera.fov_deg));
    match o.integrator {
        Some(i) => rec.insert("integrator".into(), SceneValue::Text(i.unit().name.into())),
        None => rec.remove("integrator"),
    };
    rec.insert(
        "lookup".into(),
        SceneValue::Text(lookup_name(o.estimation.lookup).into()),
    );
    rec.insert(
        "estimator".into(),
        SceneValue::Text(o.estimation.estimator.name.to_owned()),
    );
    rec.insert("n".into(), SceneValue::Integer(o.estimation.n.into()));
    rec.insert("exposure".into(), number(o.exposure.gain));
    rec.insert("width".into(), SceneValue::Integer(o.image.width.into()));
    rec.insert("height".into(), SceneValue::Integer(o.image.height.into()));
    rec.insert("spp".into(), SceneValue::Integer(spp.into()));
    if rec.contains_key("env-rotate") || o.lighting.env_rotate != 0.0 {
        rec.insert("env-rotate".into(), number(o.lighting.env_rotate));
    }
    if let Some(sun) = &o.lighting.sun {
        let mut v: Vec<SceneValue> = sun.dir.iter().map(|&x| number(x)).collect();
        if let Some(e) = sun.irradiance {
            v.push(number(e));
            v.push(number(sun.radius_deg));
        }
        rec.insert("sun".into(), SceneValue::List(v));
    }
    rec.retain(|key, _| rules.applies(key, &o));
    rec
}

/// The `--lookup` name of `l`.
pub fn lookup_name(l: shared::volume::grid::Lookup) -> &'static str {
    use shared::volume::grid::Lookup;
    match l {
        Lookup::Nearest => "nearest",
        Lookup::Stochastic => "stochastic",
        Lookup::Trilinear => "trilinear",
    }
}

/// An f32 as the scene value that reads back as the same f32.
fn number(x: f32) -> SceneValue {
    SceneValue::Number(f64::from(x))
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
