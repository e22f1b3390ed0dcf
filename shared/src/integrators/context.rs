//! What the strategies of one camera ray share: the ray, its segment in the grid, the light.

use crate::estimators::lane_volume::mu_at;
use crate::geometry::{Ray, V3};
use crate::params::{Config, RenderParams};
use crate::rng::HashRng;
use crate::sampling::equiangular::Equiangular;
use crate::sampling::lights::PointLight;
use crate::volume::grid::{Lookup, VolumeView};
use crate::volume::texels::Texels;

/// Everything about one camera ray that the strategies share.
pub(super) struct Context<'a, T: Texels> {
    /// By value: a kernel's view holds texel buffers, which SPIR-V may not keep behind a
    /// pointer stored in a struct.
    pub(super) vol: VolumeView<'a, T>,
    pub(super) params: &'a RenderParams,
    pub(super) cfg: &'a Config,
    /// World-space unit ray.
    pub(super) world: Ray,
    /// The same ray in index space (t is world distance).
    pub(super) ray: Ray,
    pub(super) ta: f32,
    pub(super) tb: f32,
    pub(super) light: PointLight,
    /// Probability of having selected `light`.
    pub(super) p_light: f32,
    pub(super) eq: Equiangular,
    pub(super) lookup: Lookup,
}

/// The box [0, dims] of the grid as a vector.
#[inline]
pub(super) fn grid_hi(vol: &VolumeView<impl Texels>) -> V3 {
    let d = &vol.desc.dims;
    V3::new(d[0] as f32, d[1] as f32, d[2] as f32)
}

/// Extinction at distance t along the camera ray.
#[inline]
pub(super) fn mu_on_ray(ctx: &Context<impl Texels>, t: f32, rng: HashRng) -> (f32, HashRng) {
    let (bits, rng) = rng.next_u32();
    (
        mu_at(&ctx.vol, ctx.ray.at(t), ctx.lookup, [bits, 0x1656_67b1, 7]),
        rng,
    )
}
