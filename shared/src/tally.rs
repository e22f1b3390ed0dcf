//! What one ray's estimate reports besides its value: the high-resolution lookups it took and the
//! flags the host counts per image, so that no loop bound or regime change goes unreported.

/// Lookups and report flags of one estimate; combine the parts of a ray with [`Tally::merge`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tally {
    /// High-resolution volume lookups (voxel reads).
    pub lookups: u32,
    /// 1 if a loop bound of `shared` (collision cap, sample cap, strata cap) changed the estimate.
    pub capped: u32,
    /// 1 if a jackknife estimate of the ray lies outside the regime where the paper's analysis
    /// holds ([`crate::estimators::transmittance::outside_regime`]).
    pub outside: u32,
    /// 1 if a moment-shadow-map reconstruction of the ray fell back to a stronger bias or fewer
    /// moments ([`crate::shadows::msm::shadow_bounds_flagged`]).
    pub fallback: u32,
}

impl Tally {
    /// A tally of `lookups` lookups and no flags.
    #[inline]
    pub fn lookups(lookups: u32) -> Self {
        Tally {
            lookups,
            capped: 0,
            outside: 0,
            fallback: 0,
        }
    }

    /// Both tallies of one ray together: lookups add, flags are or-ed.
    #[inline]
    pub fn merge(self, other: Tally) -> Self {
        Tally {
            lookups: self.lookups + other.lookups,
            capped: self.capped | other.capped,
            outside: self.outside | other.outside,
            fallback: self.fallback | other.fallback,
        }
    }

    /// This tally with the capped flag set when `hit` is true.
    #[inline]
    pub fn capped_if(self, hit: bool) -> Self {
        Tally {
            capped: self.capped | hit as u32,
            ..self
        }
    }

    /// This tally with the outside-regime flag set when `outside` is true.
    #[inline]
    pub fn outside_if(self, outside: bool) -> Self {
        Tally {
            outside: self.outside | outside as u32,
            ..self
        }
    }

    /// This tally with the fallback flag set when `fell_back` is nonzero.
    #[inline]
    pub fn fallback_if(self, fell_back: u32) -> Self {
        Tally {
            fallback: self.fallback | (fell_back != 0) as u32,
            ..self
        }
    }
}
