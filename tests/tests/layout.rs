//! Pins the byte layout of every struct shared between host, kernels and CPU backend.

use shared::grid::{Brick, GridDesc};
use shared::launch::Launch;
use shared::lights::PointLight;
use shared::probe::{
    DepthPair, EquiangularIn, EquiangularOut, MathValues, RngDraws, TransmittancePair,
};
use shared::render::{PixelOut, PixelSums, RenderParams, RenderPass};
use shared::rng::Pcg32;
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
    assert_eq!(size_of::<GridDesc>(), 48);
    assert_eq!(size_of::<Brick>(), 16);
    assert_eq!(size_of::<RenderParams>(), 184);
    assert_eq!(size_of::<RenderPass>(), 32);
    assert_eq!(size_of::<PixelSums>(), 16);
    assert_eq!(size_of::<PixelOut>(), 16);
    assert_eq!(size_of::<PointLight>(), 16);
    assert_eq!(size_of::<EquiangularIn>(), 48);
    assert_eq!(size_of::<EquiangularOut>(), 32);
    // The render kernel reads the pass range right after the Launch header in push constants.
    assert_eq!(
        std::mem::offset_of!(RenderPass, s_begin),
        size_of::<Launch>()
    );
}
