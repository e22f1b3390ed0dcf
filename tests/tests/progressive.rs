//! Progressive renders (`host view`): samples added a few at a time, each frame continuing the
//! pixels' sums, give the bytes of one render of as many samples per pixel, on the CPU and on
//! the GPU (lavapipe), for transmittance, `direct`, `path` and `restir` with spatial reuse, and
//! across a sample block (256 samples).

use engine::lighting::SceneLights;
use engine::render::progressive::Progressive;
use engine::render::{render_resident_lit, Resident};
use engine::scene::bricks::{pack, PackedVolume};
use engine::Backend;
use integration_tests::{assert_bytes_equal, camera_params, gpu, lumpy_blobs, many_lights};
use shared::kernels::render::PixelOut;
use shared::params::{Estimator, Integrator, RenderParams, RestirParams};
use shared::volume::grid::Lookup;

fn packed() -> (engine::volume::DenseVolume, PackedVolume) {
    let vol = lumpy_blobs(24, 6);
    let packed = pack(&vol, 1.0, 8, Lookup::Stochastic).unwrap();
    (vol, packed)
}

/// Six point lights, the sky and a sun (`restir` resamples the points).
fn lights(restir: bool) -> SceneLights {
    many_lights(6, true, restir)
}

fn params(
    vol: &engine::volume::DenseVolume,
    packed: &PackedVolume,
    integrator: Option<Integrator>,
    spp: u32,
    lights: &SceneLights,
) -> RenderParams {
    let mut p = RenderParams {
        spp,
        seed: 7,
        n: 10,
        estimator: Estimator::Jackknife as u32,
        rm_scale: 1.0,
        f_delta: 0.6,
        pixel_jitter: 1,
        ..camera_params(vol, 10, 7)
    };
    if let Some(i) = integrator {
        p.integrator = i as u32;
        p.hg_g = 0.3;
        p.albedo = 0.8;
        p.rr_depth = 2;
        p.max_depth = 5;
        p.light_count = lights.points.len() as u32;
        if i == Integrator::Restir {
            p.restir = RestirParams {
                candidates: 4,
                n: 4,
                floor: 0.05,
                passes: 1,
                neighbours: 3,
                radius: 2,
                ..p.restir
            };
        }
        p = engine::render::fit_collision_cap(&p, &packed.desc);
    }
    p
}

/// The pixels after frames of `frames` samples each (cycled) until `spp`.
fn progressive(
    resident: &Resident,
    p: &RenderParams,
    lights: &SceneLights,
    spp: u32,
    frames: &[u32],
) -> Vec<PixelOut> {
    let mut acc = Progressive::new();
    let mut k = 0;
    while acc.samples() < spp {
        let want = frames[k % frames.len()].min(spp - acc.samples());
        let got = acc.advance(resident, p, lights, want).unwrap();
        assert!(
            got >= 1 && got <= want,
            "frame {k}: {got} of {want} samples"
        );
        k += 1;
    }
    acc.pixels().unwrap()
}

/// Each integrator, on both backends: frames of 1, 2 and 3 samples equal one render.
#[test]
fn frames_add_up_to_one_render_on_both_backends() {
    let (vol, packed) = packed();
    let (cpu, gpu) = (Backend::Cpu, Backend::Gpu(gpu()));
    let rc = Resident::new(&cpu, &packed).unwrap();
    let rg = Resident::new(&gpu, &packed).unwrap();
    for integrator in [
        None,
        Some(Integrator::Direct),
        Some(Integrator::Path),
        Some(Integrator::Restir),
    ] {
        let l = lights(integrator == Some(Integrator::Restir));
        let spp = 7;
        let p = params(&vol, &packed, integrator, spp, &l);
        let whole = render_resident_lit(&rc, &p, &l, false).unwrap();
        let ids: Vec<u32> = (0..whole.len() as u32).collect();
        for (name, r) in [("cpu", &rc), ("gpu", &rg)] {
            let frames = progressive(r, &p, &l, spp, &[1, 2, 3]);
            assert_bytes_equal(
                &format!("{integrator:?} on the {name}: frames vs one render"),
                &ids,
                &frames,
                &whole,
            );
        }
    }
}

/// Across a sample block: 300 samples in frames of 16 and 7 (one frame ends at sample 256)
/// equal one render of 300 samples, which adds its two blocks exactly; and the progressive
/// state after 256 samples equals a render of 256.
#[test]
fn frames_cross_a_sample_block_like_one_render() {
    let (vol, packed) = packed();
    let cpu = Backend::Cpu;
    let rc = Resident::new(&cpu, &packed).unwrap();
    let l = lights(false);
    for spp in [256, 300] {
        let p = params(&vol, &packed, None, spp, &l);
        let whole = render_resident_lit(&rc, &p, &l, false).unwrap();
        let frames = progressive(&rc, &p, &l, spp, &[16, 7]);
        let ids: Vec<u32> = (0..whole.len() as u32).collect();
        assert_bytes_equal(
            &format!("{spp} spp: frames vs one render"),
            &ids,
            &frames,
            &whole,
        );
    }
}
