//! Strategy 1 of Eq. 9/10: a distance sampled by delta tracking (free flight).

use super::context::Context;
use crate::estimators::tracking::{delta_tracking, FreeFlight};
use crate::rng::HashRng;
use crate::volume::texels::Texels;

/// Free-flight sample on the camera ray by delta tracking (see [`delta_tracking`]).
#[inline]
pub(super) fn free_flight(ctx: &Context<impl Texels>, rng: HashRng) -> (FreeFlight, HashRng) {
    delta_tracking(
        &ctx.vol,
        &ctx.ray,
        ctx.ta,
        ctx.tb,
        ctx.lookup,
        FREE_FLIGHT_SALT,
        rng,
    )
}

/// Salt of the stochastic-lookup jitter key of free-flight sampling on camera rays.
pub(super) const FREE_FLIGHT_SALT: u32 = 0x27d4_eb2f;
