//! Pins the byte layout of every struct shared between host, kernels and CPU backend.

use shared::integrators::path::PathState;
use shared::kernels::launch::Launch;
use shared::kernels::probe::{
    DepthPair, EquiangularIn, EquiangularOut, MathValues, MsmLookupIn, MsmLookupOut, PhaseIn,
    PhaseOut, RngDraws, TransmittancePair,
};
use shared::kernels::render::{PathPass, PixelOut, PixelSums, RenderPass};
use shared::kernels::shadow_map::MsmPass;
use shared::params::RenderParams;
use shared::rgb::Rgb;
use shared::rng::Pcg32;
use shared::sampling::env::EnvDesc;
use shared::sampling::lighting::Lighting;
use shared::sampling::lights::PointLight;
use shared::sampling::sun::Sun;
use shared::shadows::map::MsmDesc;
use shared::volume::grid::{Brick, GridDesc};
use shared::Complex;
use std::mem::{align_of, size_of};

#[test]
fn shared_struct_layouts() {
    assert_eq!(size_of::<Launch>(), 16);
    assert_eq!(size_of::<DepthPair>(), 8);
    assert_eq!(size_of::<TransmittancePair>(), 8);
    assert_eq!(size_of::<MathValues>(), 32);
    assert_eq!(size_of::<RngDraws>(), 32);
    assert_eq!(size_of::<Pcg32>(), 16);
    assert_eq!(align_of::<Pcg32>(), 8);
    assert_eq!(size_of::<Complex>(), 8);
    assert_eq!(size_of::<GridDesc>(), 72);
    assert_eq!(std::mem::offset_of!(GridDesc, brick_steps), 48);
    assert_eq!(std::mem::offset_of!(GridDesc, voxel_steps), 52);
    assert_eq!(std::mem::offset_of!(GridDesc, cells_per_brick), 56);
    assert_eq!(std::mem::offset_of!(GridDesc, cell_steps), 60);
    assert_eq!(std::mem::offset_of!(GridDesc, brick_log2), 64);
    assert_eq!(std::mem::offset_of!(GridDesc, brick_stepping), 68);
    assert_eq!(size_of::<Brick>(), 24);
    assert_eq!(std::mem::offset_of!(Brick, cells), 20);
    assert_eq!(size_of::<RenderParams>(), 232);
    assert_eq!(size_of::<RenderPass>(), 32);
    assert_eq!(size_of::<PixelSums>(), 36);
    assert_eq!(size_of::<PixelOut>(), 36);
    assert_eq!(size_of::<PointLight>(), 48);
    assert_eq!(size_of::<EquiangularIn>(), 48);
    assert_eq!(size_of::<EquiangularOut>(), 32);
    assert_eq!(size_of::<PathPass>(), 32);
    assert_eq!(size_of::<PathState>(), 88);
    assert_eq!(size_of::<Lighting>(), 192);
    assert_eq!(size_of::<MsmDesc>(), 112);
    assert_eq!(size_of::<MsmPass>(), 32);
    assert_eq!(size_of::<PhaseIn>(), 32);
    assert_eq!(size_of::<PhaseOut>(), 32);
    assert_eq!(size_of::<MsmLookupIn>(), 224);
    assert_eq!(size_of::<MsmLookupOut>(), 16);
    assert_eq!(size_of::<shared::integrators::direct::DirectState>(), 160);
    assert_eq!(size_of::<shared::integrators::restir::RestirState>(), 260);
    assert_eq!(size_of::<shared::integrators::restir::Reservoir>(), 16);
    assert_eq!(size_of::<Sun>(), 32);
    assert_eq!(size_of::<EnvDesc>(), 16);
    assert_eq!(size_of::<Rgb>(), 12);
    // The render and path kernels read their pass fields right after the Launch header.
    assert_eq!(std::mem::offset_of!(PathPass, sample), size_of::<Launch>());
    assert_eq!(
        std::mem::offset_of!(RenderPass, s_begin),
        size_of::<Launch>()
    );
}

#[test]
fn tile_order_is_a_bijection_of_the_pixels() {
    use shared::kernels::render::tile_order_pixel;
    for (w, h) in [
        (1, 1),
        (8, 8),
        (9, 7),
        (33, 21),
        (64, 64),
        (100, 37),
        (7, 300),
    ] {
        let mut seen = vec![false; (w * h) as usize];
        for k in 0..w * h {
            let p = tile_order_pixel(k, w, h) as usize;
            assert!(p < seen.len() && !seen[p], "{w}x{h}: k = {k} -> {p}");
            seen[p] = true;
        }
        if w >= 8 && h >= 8 {
            // The first 64 work items are the top-left 8 x 8 tile.
            let first: Vec<u32> = (0..64).map(|k| tile_order_pixel(k, w, h)).collect();
            assert!(
                first.iter().all(|&p| p % w < 8 && p / w < 8),
                "{w}x{h}: {first:?}"
            );
        }
    }
}
