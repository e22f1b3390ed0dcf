//! The two passes that build the sun's moment shadow map, one texel per invocation: the raw
//! moments of each texel's light ray, then each texel prefiltered and stored.

use crate::params::RenderParams;
use crate::sampling::lighting::Lighting;
use crate::shadows::map::{
    build_raw_texel, filter_texel, store_texel, MsmFilter, Shadows, RAW_PER_TEXEL,
};
use crate::volume::grid::VolumeView;
use crate::volume::texels::Texels;
use bytemuck::{Pod, Zeroable};

/// Push constants of `msm_build_cs` and `msm_store_cs`: the launch header and the prefilter.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MsmPass {
    pub launch: crate::kernels::launch::Launch,
    /// [`MsmFilter`] as u32.
    pub filter: u32,
    /// Prefilter radius in texels.
    pub radius: u32,
    pub _pad: [u32; 2],
}

/// Pass 1 for texel `k`: b_1 .. b_6 of its light ray, written to `raw[6 k ..]`.
#[inline]
pub fn msm_raw_texel(
    vol: &VolumeView<impl Texels>,
    params: &RenderParams,
    lighting: &Lighting,
    k: u32,
) -> [f32; RAW_PER_TEXEL] {
    build_raw_texel(vol, &params.world_to_index, &lighting.shadow_map, k)
}

/// Pass 2 for texel `k`: its prefiltered moments in the stored format of the render's mode
/// (the first `words_per_texel` words are written to the map).
#[inline]
pub fn msm_store_texel(lighting: &Lighting, raw: &[f32], pass: &MsmPass, k: u32) -> [u32; 6] {
    let m = filter_texel(
        &lighting.shadow_map,
        raw,
        MsmFilter::from_u32(pass.filter),
        pass.radius,
        k,
    );
    store_texel(
        Shadows::from_u32(lighting.shadows),
        m,
        lighting.shadow_map.ones,
    )
}
