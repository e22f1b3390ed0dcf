//! The CPU's wide transmittance pass (`shared::kernels::wide`: Alg. 2 and Alg. 1 over several
//! rays per instruction) gives every pixel the bytes of the scalar pass
//! (`shared::kernels::render::render_pixel_pass`, which the GPU runs). Both run the one body of
//! Alg. 2 and Alg. 1 (`shared::estimators::wide`); what this ties together is what each reads
//! through: the wide traversal and lookups (`shared::volume::wide::WideVolume`) against the
//! scalar ones (`SuperVoxelDda`, `VolumeView`'s lookups), and the wide pass's camera rays, Eq. 4,
//! tallies and sums lane by lane. Over 8 lanes compiled for
//! the baseline instruction set, over 8 lanes through the CPU backend's dispatch (AVX2 where the
//! CPU has it), and over one lane; for the jackknife, its adaptive variant (partial strata
//! skipped, the strata cap reached) and the naive mean, both importances, both jitters, nearest
//! and stochastic lookups, several brick sizes and N, cameras outside and inside the volume, and
//! pixel counts that are not multiples of 8. And it declines the layouts and estimators it does
//! not read.

use engine::backend::wide::X8;
use engine::scene::bricks::{pack, pack_paged};
use engine::scene::camera::{make_camera, world_bounds, CameraSpec};
use engine::volume::DenseVolume;
use integration_tests::{assert_bytes_equal, camera_params, lumpy_blobs, lumpy_cells};
use jackknife::{SupervoxelFormat, Supervoxels};
use shared::kernels::render::{render_pixel_pass, PixelSums};
use shared::kernels::wide::{renders, transmittance_pass};
use shared::lanes::{Lanes, One};
use shared::params::{Estimator, RenderParams};
use shared::volume::grid::{Lookup, VolumeView};

/// Samples 0..spp of every pixel by the scalar pass.
fn scalar(view: &VolumeView, params: &RenderParams) -> Vec<PixelSums> {
    (0..params.width * params.height)
        .map(|id| render_pixel_pass(view, params, &[], id, 0, params.spp, PixelSums::default()))
        .collect()
}

/// Samples 0..spp of every pixel by `pass`, `lanes` pixels per call (the last call fewer).
fn wide(
    params: &RenderParams,
    lanes: usize,
    pass: impl Fn(&[u32], &mut [PixelSums]),
) -> Vec<PixelSums> {
    let count = (params.width * params.height) as usize;
    let mut sums = vec![PixelSums::default(); count];
    for (j, accs) in sums.chunks_mut(lanes).enumerate() {
        let pixels: Vec<u32> = (0..accs.len()).map(|i| (j * lanes + i) as u32).collect();
        pass(&pixels, accs);
    }
    sums
}

/// Asserts the three wide forms equal the scalar pass for `params` on `view`.
fn check(what: &str, view: &VolumeView, params: &RenderParams) {
    assert!(
        renders(view, params),
        "{what}: the wide pass should render this"
    );
    let want = scalar(view, params);
    let ids: Vec<u32> = (0..params.width * params.height).collect();
    let (s, spp) = (0, params.spp);
    let x8 = wide(params, X8::N, |p, a| {
        transmittance_pass::<X8, _>(view, params, p, s, spp, a)
    });
    assert_bytes_equal(&format!("{what}, 8 lanes"), &ids, &want, &x8);
    let dispatch = wide(params, X8::N, |p, a| {
        engine::backend::wide::transmittance_pass(view, params, p, s, spp, a)
    });
    assert_bytes_equal(
        &format!("{what}, 8 lanes dispatched"),
        &ids,
        &want,
        &dispatch,
    );
    let one = wide(params, 1, |p, a| {
        transmittance_pass::<One, _>(view, params, p, s, spp, a)
    });
    assert_bytes_equal(&format!("{what}, one lane"), &ids, &want, &one);
    // Passes split at a sample add up to the same sums.
    let split = wide(params, X8::N, |p, a| {
        transmittance_pass::<X8, _>(view, params, p, 0, 1, a);
        transmittance_pass::<X8, _>(view, params, p, 1, spp, a);
    });
    assert_bytes_equal(
        &format!("{what}, 8 lanes in two passes"),
        &ids,
        &want,
        &split,
    );
}

/// The view as the CPU backend renders it (stepping through all-zero bricks where exact).
fn stepping(view: VolumeView) -> VolumeView {
    let mut view = view;
    view.desc.brick_stepping = u32::from(view.desc.can_step());
    view
}

/// A camera at `position` looking at the volume's centre.
fn camera_at(vol: &DenseVolume, params: &RenderParams, position: [f32; 3]) -> RenderParams {
    let spec = CameraSpec {
        position: Some(position),
        look_at: None,
        fov_deg: 70.0,
    };
    RenderParams {
        camera: make_camera(&spec, world_bounds(vol), params.width, params.height).unwrap(),
        ..*params
    }
}

#[test]
fn the_wide_pass_gives_every_pixel_the_scalar_bytes() {
    let volumes = [
        (lumpy_blobs(20, 3), 4),
        (lumpy_blobs(20, 3), 8),
        (lumpy_cells(), 8),
    ];
    let mut cases = 0;
    for (v, (vol, brick)) in volumes.iter().enumerate() {
        for lookup in [Lookup::Nearest, Lookup::Stochastic] {
            let packed = pack(vol, 1.5, *brick, lookup).unwrap();
            let view = stepping(packed.view());
            let base = RenderParams {
                spp: 3,
                seed: 11 + v as u32,
                ..camera_params(vol, 23, 17)
            };
            let inside = camera_at(vol, &base, [0.1, -0.2, 0.3]);
            for (c, camera) in [base, inside].iter().enumerate() {
                let estimators = [
                    Estimator::Jackknife,
                    Estimator::NaiveMean,
                    Estimator::JackknifeAdaptive,
                ];
                for estimator in estimators {
                    // The adaptive variant's step F_delta: many strata, few (partial ones
                    // skipped), and at the strata cap.
                    for (importance, jitter, n, f_delta) in [
                        (0, 0, 10, 0.5),
                        (1, 0, 4, 3.0),
                        (0, 1, 1, 0.05),
                        (1, 1, 7, 1e-4),
                    ] {
                        let params = RenderParams {
                            estimator: estimator as u32,
                            importance,
                            jitter,
                            n,
                            f_delta,
                            ..*camera
                        };
                        let what = format!(
                            "volume {v}, brick {brick}, {lookup:?}, camera {c}, {estimator:?}, \
                             importance {importance}, jitter {jitter}, N {n}, F_delta {f_delta}"
                        );
                        check(&what, &view, &params);
                        cases += 1;
                    }
                }
            }
        }
    }
    assert_eq!(cases, 144);
}

#[test]
fn the_wide_pass_declines_what_it_does_not_read() {
    let vol = lumpy_blobs(20, 3);
    let params = RenderParams {
        estimator: Estimator::Jackknife as u32,
        n: 4,
        ..camera_params(&vol, 8, 8)
    };
    let fixed = pack(&vol, 1.0, 4, Lookup::Stochastic).unwrap();
    assert!(renders(&stepping(fixed.view()), &params));
    // Skipping all-zero cubes instead of stepping through them.
    let mut skipping = fixed.view();
    skipping.desc.brick_stepping = 0;
    assert!(!renders(&skipping, &params));
    // Trilinear lookups, bricks of 5 voxels, adaptive super-voxels.
    let trilinear = pack(&vol, 1.0, 4, Lookup::Trilinear).unwrap();
    assert!(!renders(&stepping(trilinear.view()), &params));
    let five = pack(&vol, 1.0, 5, Lookup::Stochastic).unwrap();
    assert!(!renders(&stepping(five.view()), &params));
    let adaptive = pack_paged(
        &vol,
        1.0,
        8,
        SupervoxelFormat::F32,
        Supervoxels::Adaptive {
            cell: 2,
            ratio: 1.0,
            occupancy: 1.0,
        },
        Lookup::Stochastic,
        shared::volume::pages::GPU_PAGE_LOG2,
    )
    .unwrap();
    let adaptive_view = stepping(adaptive.view());
    assert!(adaptive_view.desc.cells_per_brick() > 1);
    assert!(!renders(&adaptive_view, &params));
    // Other estimators and integrators.
    for estimator in [
        Estimator::TrackLength,
        Estimator::RatioTracking,
        Estimator::NaiveSingle,
    ] {
        let p = RenderParams {
            estimator: estimator as u32,
            ..params
        };
        assert!(!renders(&stepping(fixed.view()), &p), "{estimator:?}");
    }
    let lit = RenderParams {
        integrator: 1,
        ..params
    };
    assert!(!renders(&stepping(fixed.view()), &lit));
    // Asked anyway, the pass renders a transmittance image it declines by the scalar pass.
    let ratio = RenderParams {
        estimator: Estimator::RatioTracking as u32,
        spp: 2,
        ..params
    };
    let view = stepping(fixed.view());
    let ids: Vec<u32> = (0..ratio.width * ratio.height).collect();
    let x8 = wide(&ratio, X8::N, |p, a| {
        transmittance_pass::<X8, _>(&view, &ratio, p, 0, ratio.spp, a)
    });
    assert_bytes_equal(
        "declined: ratio tracking",
        &ids,
        &scalar(&view, &ratio),
        &x8,
    );
}
