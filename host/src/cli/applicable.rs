//! Which render flags apply to which render: a flag the user typed that the chosen integrator,
//! estimator or shadows would not read is refused before any work, so no output is
//! mislabelled. The command line's check, on clap's ids of the flags given.

use anyhow::{bail, Result};
use engine::render::shadow_map::ShadowKind;
use engine::render_job::RenderOptions;
use shared::integrators::unit::OwnSettings;
use shared::params::{Estimator, Integrator, TransmittanceHat};

/// Options that only an integrator render reads (clap ids, flag spelling).
const INTEGRATOR_ONLY: &[(&str, &str)] = &[
    ("lights", "--light"),
    ("albedo", "--albedo"),
    ("hg_g", "--hg-g"),
    ("t_hat", "--t-hat"),
    ("exposure", "--exposure"),
    ("fixed_exposure", "--fixed-exposure"),
    ("env", "--env"),
    ("env_scale", "--env-scale"),
    ("env_rotate", "--env-rotate"),
    ("sun", "--sun"),
];

/// Options only `--integrator direct` reads.
const DIRECT_ONLY: &[(&str, &str)] = &[
    ("random_lights", "--lights"),
    ("env", "--env"),
    ("env_scale", "--env-scale"),
    ("env_rotate", "--env-rotate"),
    ("sun", "--sun"),
    ("shadows", "--shadows"),
    ("msm_res", "--msm-res"),
    ("msm_storage", "--msm-storage"),
    ("msm_filter", "--msm-filter"),
];

/// Options that only a moment shadow map reads (`--shadows msm4|msm6`).
const MSM_ONLY: &[(&str, &str)] = &[
    ("msm_res", "--msm-res"),
    ("msm_storage", "--msm-storage"),
    ("msm_filter", "--msm-filter"),
];

/// Options only the integrators with `path`'s depths read ([`OwnSettings::PathDepth`]).
const PATH_ONLY: &[(&str, &str)] = &[("rr_depth", "--rr-depth"), ("max_depth", "--max-depth")];

/// Options only the integrators with `restir`'s resampling read ([`OwnSettings::Restir`]).
const RESTIR_ONLY: &[(&str, &str)] = &[
    ("restir_candidates", "--restir-candidates"),
    ("restir_target", "--restir-target"),
    ("restir_n", "--restir-n"),
    ("restir_floor", "--restir-floor"),
    ("restir_passes", "--restir-passes"),
    ("restir_neighbours", "--restir-neighbours"),
    ("restir_radius", "--restir-radius"),
    ("restir_mis", "--restir-mis"),
    ("restir_m_cap", "--restir-m-cap"),
];

/// The flags of each integrator's own settings (the integrator table's `settings`).
const OWN_FLAGS: &[(OwnSettings, &[(&str, &str)])] = &[
    (OwnSettings::PathDepth, PATH_ONLY),
    (OwnSettings::Restir, RESTIR_ONLY),
];

/// Options `--integrator direct` does not read.
const NOT_DIRECT: &[(&str, &str)] = &[("t_hat", "--t-hat")];

/// Flags that no integrator reads: shadow rays always use the jackknife (shared/src/integrator.rs).
const TRANSMITTANCE_ONLY: &[(&str, &str)] =
    &[("estimator", "--estimator"), ("f_delta", "--f-delta")];

/// Whether the flag of clap id `id` applies to some renders only (an integrator, estimator or
/// shadows of its own): a resolved scene leaves out such a flag's default.
pub fn restricted(id: &str) -> bool {
    let tables = [
        INTEGRATOR_ONLY,
        DIRECT_ONLY,
        MSM_ONLY,
        PATH_ONLY,
        RESTIR_ONLY,
        NOT_DIRECT,
        TRANSMITTANCE_ONLY,
    ];
    id == "ratio_roulette" || tables.iter().any(|t| t.iter().any(|(i, _)| *i == id))
}

/// Refuses flag combinations whose flags would be ignored, so no output is mislabelled: each
/// flag the user typed (`given`: clap ids) must be one that `args`' integrator, estimator and
/// shadows read.
pub fn check(args: &RenderOptions, given: &[String]) -> Result<()> {
    let given = |id: &str| given.iter().any(|g| g == id);
    let lit = args.integrator.is_some_and(Integrator::is_lit);
    for (settings, flags) in OWN_FLAGS {
        if args.own_settings() == *settings {
            continue;
        }
        if let Some((_, flag)) = flags.iter().find(|(id, _)| given(id)) {
            let names = engine::integrators::reading(*settings);
            bail!("{flag} only applies to --integrator {names}; add it or drop {flag}");
        }
    }
    if lit {
        if let Some((_, flag)) = NOT_DIRECT.iter().find(|(id, _)| given(id)) {
            bail!(
                "{flag} has no effect with --integrator direct or path (it changes the \
                 equiangular strategy of the single-scattering integrators); drop {flag}"
            );
        }
    } else if let Some((_, flag)) = DIRECT_ONLY.iter().find(|(id, _)| given(id)) {
        bail!(
            "{flag} only applies to --integrator direct, path or restir (the single-scattering \
             integrators are lit by point lights, --light); add --integrator direct or drop {flag}"
        );
    } else if args.integrator.is_some() {
        if let Some((_, flag)) = TRANSMITTANCE_ONLY.iter().find(|(id, _)| given(id)) {
            bail!(
                "{flag} has no effect with --integrator: every integrator's shadow rays use the \
                 jackknife transmittance (with --n samples per estimate); drop {flag}, or drop \
                 --integrator to render transmittance with it"
            );
        }
    } else if let Some((_, flag)) = INTEGRATOR_ONLY.iter().find(|(id, _)| given(id)) {
        bail!(
            "{flag} only applies to single-scattering renders: add --integrator NAME (e.g. \
             --integrator mis-jackknife) or drop {flag}"
        );
    }
    if args.shadows.kind == ShadowKind::Rays {
        if let Some((_, flag)) = MSM_ONLY.iter().find(|(id, _)| given(id)) {
            bail!("{flag} only applies to --shadows msm4 or msm6; add one or drop {flag}");
        }
    }
    let uses_ratio = match args.integrator {
        Some(i) if i.is_lit() => args.estimation.estimator.estimator == Estimator::RatioTracking,
        Some(_) => args.estimation.t_hat == TransmittanceHat::Ratio,
        None => args.estimation.estimator.estimator == Estimator::RatioTracking,
    };
    if given("ratio_roulette") && !uses_ratio {
        bail!(
            "--ratio-roulette has no effect here: it changes ratio tracking, used by --estimator \
             ratio and, with --integrator, by --t-hat ratio (Miller et al.'s MIS always runs \
             without roulette); drop it or use one of those"
        );
    }
    Ok(())
}
