//! The scene `host view` saves: the settings the viewer changes, written back into a render's
//! scene record under the keys `host render` reads (the scene file's keys), so that the saved
//! file renders what the window shows.

use super::options::RenderOptions;
use super::scene_record::{SceneRecord, SceneValue};

/// Writes into `rec` the settings of `o` that the viewer changes, at `spp` samples per pixel:
/// the camera (position, look-at, field of view), the integrator (removed for transmittance),
/// lookup, estimator, N, exposure, image size, the light probe's rotation (where the record has
/// one or it is not 0) and the sun.
pub fn record_view(rec: &mut SceneRecord, o: &RenderOptions, spp: u32) {
    let list = |v: [f32; 3]| SceneValue::List(v.iter().map(|&x| number(x)).collect());
    if let Some(eye) = o.scene.camera {
        rec.insert("camera".into(), list(eye));
    }
    if let Some(target) = o.scene.look_at {
        rec.insert("look-at".into(), list(target));
    }
    rec.insert("fov".into(), number(o.scene.fov));
    match o.integrator {
        Some(i) => rec.insert("integrator".into(), SceneValue::Text(i.unit().name.into())),
        None => rec.remove("integrator"),
    };
    rec.insert(
        "lookup".into(),
        SceneValue::Text(crate::scene::lookup_name(o.estimation.lookup)),
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
}

/// An f32 as the scene value that reads back as the same f32.
fn number(x: f32) -> SceneValue {
    SceneValue::Number(f64::from(x))
}
