//! Each integrator as one unit: its family ([`Integrator::family`]: how it runs on both backends,
//! which loops bound it, which lights it sees) and its row of [`UNITS`] (the name users type,
//! the settings it reads beyond the common ones, its cost class, the integrator whose converged
//! image is its reference). The CPU pass ([`crate::kernels::render::cpu_pixel_pass`]), the GPU
//! plan (a lit family's [`Wavefront`]), the loop budget ([`super::budget`]), the engine's
//! diagnostics and `--backend auto`'s cost model, and the command line's flag checks read these
//! two; adding an integrator of an existing family adds a row here and an arm to
//! [`Integrator::family`] (ARCHITECTURE.md lists the other files).

use super::stages::Wavefront;
use crate::params::Integrator;

/// How an integrator runs and what bounds its loops.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Primary-ray transmittance by the chosen estimator (no integrator).
    Transmittance,
    /// Single scattering from point lights along primary rays (Sec. 5.2): a whole sample per
    /// invocation, every shadow ray by the jackknife (or ratio tracking, `--t-hat ratio`).
    SingleScattering,
    /// RGB light transport lit by the scene's map, sun and point lights, as a wavefront of
    /// stages (one dispatch each on a GPU), shadow rays by the chosen estimator.
    Lit(Wavefront),
}

impl Integrator {
    /// The integrator's family. A `match` without tables or strings, so that kernels may call
    /// it; the rest of the unit is its row of [`UNITS`].
    #[inline]
    pub const fn family(self) -> Family {
        match self {
            Integrator::Transmittance => Family::Transmittance,
            Integrator::Direct => Family::Lit(Wavefront::Direct),
            Integrator::Path => Family::Lit(Wavefront::Path),
            Integrator::Restir => Family::Lit(Wavefront::Restir),
            Integrator::FreeFlight
            | Integrator::Equiangular
            | Integrator::MisJackknife
            | Integrator::MisNaive
            | Integrator::CombinedJackknife
            | Integrator::CombinedNaive
            | Integrator::Miller
            | Integrator::MisPowerJackknife => Family::SingleScattering,
        }
    }

    /// The RGB light-transport integrators ([`Family::Lit`]): lit by the scene's map, sun and
    /// point lights, rendered as wavefronts on the GPU.
    #[inline]
    pub const fn is_lit(self) -> bool {
        matches!(self.family(), Family::Lit(_))
    }

    /// The wavefront of a lit integrator (None: it renders a whole sample per invocation).
    #[inline]
    pub const fn wavefront(self) -> Option<Wavefront> {
        match self.family() {
            Family::Lit(w) => Some(w),
            _ => None,
        }
    }

    /// The integrator's row of [`UNITS`] (host code only: the row holds strings).
    pub fn unit(self) -> &'static Unit {
        &UNITS[self as usize]
    }
}

/// The settings an integrator reads beyond those of its family (typed, in the engine's
/// `RenderOptions`; the command line refuses their flags for every other integrator).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OwnSettings {
    /// None.
    None,
    /// `path`'s depths: vertices before Russian roulette, most vertices.
    PathDepth,
    /// `restir`'s resampling: candidates, target, spatial reuse (`RestirOptions`).
    Restir,
}

/// Cost classes of `--backend auto`'s model (the engine holds their measured times per sample).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Work {
    /// Primary-ray transmittance.
    Transmittance,
    /// Free-flight distance sampling and its shadow ray.
    FreeFlight,
    /// The single-scattering integrators with two strategies or a second estimate.
    SingleScattering,
    /// `direct`.
    Direct,
    /// `path` (a wavefront of several kernels per vertex).
    Path,
    /// `restir` (eight kernels per sample).
    Restir,
}

impl Work {
    /// The name the messages use.
    pub fn name(self) -> &'static str {
        match self {
            Work::Transmittance => "transmittance",
            Work::FreeFlight => "free-flight",
            Work::SingleScattering => "single scattering",
            Work::Direct => "direct",
            Work::Path => "path",
            Work::Restir => "restir",
        }
    }
}

/// One integrator's row: everything about it that is not its kernels' code.
#[derive(Clone, Copy, Debug)]
pub struct Unit {
    pub integrator: Integrator,
    /// The name of `--integrator` and `--integrators` ("transmittance": no integrator, not a
    /// value of those flags).
    pub name: &'static str,
    pub settings: OwnSettings,
    pub work: Work,
    /// The integrator whose converged image `host eval` compares this one's with (the same
    /// integral): itself, or `direct` for `restir`.
    pub reference: Integrator,
    /// Whether it resamples the scene's point lights itself (they leave the pmf over light
    /// kinds: `restir`).
    pub resamples_points: bool,
}

/// A row with the defaults: no own settings, its own reference, no resampling.
const fn row(integrator: Integrator, name: &'static str, work: Work) -> Unit {
    Unit {
        integrator,
        name,
        settings: OwnSettings::None,
        work,
        reference: integrator,
        resamples_points: false,
    }
}

/// Every integrator, in enum order ([`Integrator::unit`]).
pub const UNITS: [Unit; 12] = {
    use Integrator as I;
    use Work as W;
    [
        row(I::Transmittance, "transmittance", W::Transmittance),
        row(I::FreeFlight, "free-flight", W::FreeFlight),
        row(I::Equiangular, "equiangular", W::SingleScattering),
        row(I::MisJackknife, "mis-jackknife", W::SingleScattering),
        row(I::MisNaive, "mis-naive", W::SingleScattering),
        row(
            I::CombinedJackknife,
            "combined-jackknife",
            W::SingleScattering,
        ),
        row(I::CombinedNaive, "combined-naive", W::SingleScattering),
        row(I::Miller, "miller", W::SingleScattering),
        row(I::MisPowerJackknife, "mis-power", W::SingleScattering),
        row(I::Direct, "direct", W::Direct),
        Unit {
            settings: OwnSettings::PathDepth,
            ..row(I::Path, "path", W::Path)
        },
        Unit {
            settings: OwnSettings::Restir,
            reference: I::Direct,
            resamples_points: true,
            ..row(I::Restir, "restir", W::Restir)
        },
    ]
};

#[cfg(test)]
mod tests {
    use super::*;

    /// Row i is integrator i, every name is distinct, and the integrators `--integrator` takes
    /// are all but transmittance.
    #[test]
    fn every_integrator_has_its_row() {
        for (i, u) in UNITS.iter().enumerate() {
            assert_eq!(u.integrator as usize, i, "{}", u.name);
            assert_eq!(Integrator::from_u32(i as u32), u.integrator);
            assert_eq!(u.integrator.unit().name, u.name);
            for v in &UNITS[i + 1..] {
                assert_ne!(u.name, v.name);
            }
            // A reference renders the same integral in the same family.
            assert_eq!(u.reference.is_lit(), u.integrator.is_lit(), "{}", u.name);
        }
        assert_eq!(
            Integrator::from_u32(UNITS.len() as u32),
            Integrator::Transmittance
        );
        assert_eq!(Integrator::Path.wavefront(), Some(Wavefront::Path));
        assert_eq!(Integrator::MisJackknife.wavefront(), None);
        assert_eq!(Integrator::Restir.unit().reference, Integrator::Direct);
    }
}
