//! Per-image counts of the flags `shared` raises per ray ([`shared::Tally`]): rays whose estimate
//! a loop bound changed, and jackknife estimates outside the regime where the paper's analysis
//! holds. They go into every JSON summary and, when non-zero, into a warning.

use shared::params::Estimator;

use shared::kernels::render::PixelOut;

use shared::params::RenderParams;

/// Fraction of rays outside the jackknife's regime above which a render warns.
pub const OUTSIDE_WARN_FRACTION: f64 = 0.01;

/// Counts over all rays (pixels x spp) of one image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct RayFlags {
    /// Camera rays traced (pixels x spp).
    pub rays: u64,
    /// Rays whose estimate a loop bound of `shared` changed (see [`capped_advice`]).
    pub capped_rays: u64,
    /// Rays with a jackknife estimate whose S exceeds `shared::estimators::transmittance::S_REGIME`.
    pub jackknife_outside_rays: u64,
    /// Rays with a moment-shadow-map lookup whose reconstruction fell back to a stronger bias
    /// or fewer moments (`--shadows msm4|msm6`).
    pub msm_fallback_rays: u64,
    /// Pixels of the image.
    pub pixels: u64,
    /// Pixels whose rays read at least one voxel (0: no ray met the volume's density).
    pub pixels_hit: u64,
}

/// Fraction of pixels reading a voxel below which a render warns that it barely sees the volume.
pub const HIT_WARN_FRACTION: f64 = 0.001;

impl RayFlags {
    /// Sums the per-pixel counts of an image rendered with `spp` samples per pixel.
    pub fn of(pixels: &[PixelOut], spp: u32) -> Self {
        RayFlags {
            rays: pixels.len() as u64 * spp as u64,
            capped_rays: pixels.iter().map(|p| p.capped as u64).sum(),
            jackknife_outside_rays: pixels.iter().map(|p| p.outside as u64).sum(),
            msm_fallback_rays: pixels.iter().map(|p| p.fallback as u64).sum(),
            pixels: pixels.len() as u64,
            pixels_hit: pixels.iter().filter(|p| p.samples > 0).count() as u64,
        }
    }

    /// The warnings these counts call for (empty when there is nothing to report).
    pub fn warnings(&self, params: &RenderParams) -> Vec<String> {
        let mut out = Vec::new();
        let pct = |n: u64| 100.0 * n as f64 / self.rays.max(1) as f64;
        if self.capped_rays > 0 {
            out.push(format!(
                "{} of {} rays ({:.3}%) reached a loop bound: {}",
                self.capped_rays,
                self.rays,
                pct(self.capped_rays),
                capped_advice(params)
            ));
        }
        let outside = self.jackknife_outside_rays as f64 / self.rays.max(1) as f64;
        if outside > OUTSIDE_WARN_FRACTION
            && params.estimator == Estimator::JackknifeAdaptive as u32
        {
            out.push(format!(
                "{} of {} rays ({:.2}%) have jackknife-adaptive estimates outside the regime of \
                 Eq. 4's normal model: S > {}, or an estimate that took no sample (the ray's \
                 importance integral F is at most --f-delta, so its one stratum is sampled with \
                 probability F / F_delta): expect bias there; lower --f-delta \
                 (docs/guide/regime.md)",
                self.jackknife_outside_rays,
                self.rays,
                100.0 * outside,
                shared::estimators::transmittance::S_REGIME
            ));
        } else if outside > OUTSIDE_WARN_FRACTION {
            out.push(format!(
                "{} of {} rays ({:.2}%) have jackknife estimates with S > {} (optical-depth \
                 estimates too far apart for Eq. 4's normal model, paper Sec. 6.3): expect bias \
                 there; raise --n, lower --density-scale or use a smaller --brick-size \
                 (docs/guide/regime.md)",
                self.jackknife_outside_rays,
                self.rays,
                100.0 * outside,
                shared::estimators::transmittance::S_REGIME
            ));
        }
        if self.pixels > 0 && self.pixels_hit == 0 {
            out.push(
                "no ray of the image read a voxel of the volume: every pixel shows the background \
                 (T = 1); check that --camera, --look-at and --fov frame the volume, and \
                 --density-scale"
                    .to_owned(),
            );
        } else if (self.pixels_hit as f64) < HIT_WARN_FRACTION * self.pixels as f64 {
            out.push(format!(
                "only {} of {} pixels read a voxel of the volume: the camera barely sees it; \
                 check --camera, --look-at and --fov",
                self.pixels_hit, self.pixels
            ));
        }
        if self.msm_fallback_rays > 0 {
            out.push(format!(
                "{} of {} rays ({:.3}%) had a moment-shadow-map lookup whose reconstruction was \
                  numerically singular and fell back to a stronger bias or fewer moments (shadows \
                  there are smoother than the map's moments say); a smaller --msm-res or a \
                  --msm-filter makes the moments less extreme",
                self.msm_fallback_rays,
                self.rays,
                pct(self.msm_fallback_rays)
            ));
        }
        out
    }

    /// Prints [`RayFlags::warnings`] to stderr.
    pub fn warn(&self, params: &RenderParams) {
        for w in self.warnings(params) {
            tracing::warn!("{w}");
        }
    }
}

/// What the loop bound of this render's estimator does when reached, and what to change; and
/// the bound every render shares: a traversal of the grid past its iteration budget.
pub fn capped_advice(params: &RenderParams) -> String {
    format!(
        "{}; or a traversal of the grid used up its iteration budget (the bound from the \
         occupied bricks that empty-space skipping keeps to: docs/guide/volumes.md, Empty \
         space) and the rest of that ray segment was taken as empty; that is a bug: please report the volume",
        estimator_advice(params)
    )
}

/// [`capped_advice`] of the estimator's or integrator's own loop bound.
fn estimator_advice(params: &RenderParams) -> String {
    use shared::estimators::ray_marching::{MAX_BIASED_SAMPLES, MAX_UNBIASED_SAMPLES};
    let cap = params.collision_cap();
    let tracking = format!(
        "after {cap} tentative collisions the rest of the ray was finished \
         by regular tracking (exact for --lookup nearest, approximate for stochastic and trilinear lookups); \
         the medium is too dense for its per-brick majorants: lower --density-scale or use a \
         smaller --brick-size"
    );
    use shared::integrators::{stages::Wavefront, unit::Family};
    match shared::params::Integrator::from_u32(params.integrator).family() {
        Family::Lit(Wavefront::Path) => {
            return format!(
                "a path scattered more than --max-depth {} times and was cut off (its radiance \
                 is underestimated; raise --max-depth), or a free flight or tracking estimate \
                 {tracking}",
                params.max_depth
            )
        }
        Family::Lit(_) => return format!("free-flight sampling or a tracking estimate {tracking}"),
        Family::SingleScattering => {
            return format!("free-flight sampling or ratio tracking {tracking}")
        }
        Family::Transmittance => {}
    }
    match Estimator::from_u32(params.estimator) {
        Estimator::TrackLength | Estimator::RatioTracking | Estimator::FirstCollision => {
            format!("tracking {tracking}")
        }
        Estimator::BiasedRayMarching => format!(
            "ray marching used its cap of {MAX_BIASED_SAMPLES} samples instead of N_CMF's count \
             (more bias); lower --density-scale"
        ),
        Estimator::UnbiasedRayMarching => format!(
            "ray marching used its cap of {MAX_UNBIASED_SAMPLES} samples per estimate instead of \
             N_CMF's count (still unbiased, more variance), or its power series overflowed f32 \
             (the estimate is then 0); lower --density-scale"
        ),
        Estimator::Telescoping => format!(
            "the telescoping series was cut at its cap of {} samples (n 2^L) or level {}, \
             or its corrections overflowed f32 (the estimate is then 0); lower --n or \
             --density-scale",
            shared::estimators::telescoping::MAX_TELESCOPING_SAMPLES,
            shared::estimators::telescoping::MAX_LEVEL
        ),
        Estimator::TelescopingCycles => format!(
            "Cycles' telescoping used its cap of {} lookups per ray (fewer steps than \
             round(range x length)); lower --density-scale",
            shared::estimators::telescoping::MAX_CYCLES_SAMPLES
        ),
        Estimator::JackknifeAdaptive => format!(
            "F / F_delta exceeded {} strata, so the CDF step was widened (fewer samples than \
             --f-delta asks for); raise --f-delta",
            shared::estimators::wide::MAX_ADAPTIVE_STRATA
        ),
        _ => "an internal loop bound was reached".into(),
    }
}

/// Refuses an image with a pixel whose mean is not finite (an overflow of f32 in the light
/// transport: radiance near a point light, or an estimator outside its range), naming the first
/// such pixel and how many there are: a result is right or refused, never written with inf or NaN.
pub fn check_finite(pixels: &[PixelOut], width: u32) -> anyhow::Result<()> {
    let bad = |p: &PixelOut| {
        let v = [p.t_mean, p.rgb_mean.r, p.rgb_mean.g, p.rgb_mean.b];
        !v.iter().all(|x| x.is_finite())
    };
    let count = pixels.iter().filter(|p| bad(p)).count();
    if let Some(k) = pixels.iter().position(bad) {
        let p = &pixels[k];
        let w = width.max(1) as usize;
        anyhow::bail!(
            "{count} of {} pixels are not finite, the first at x {}, y {} (value {}, RGB {}, {}, \
             {}): the radiance overflowed f32 there (a light too bright for the scene, or one \
             inside the medium, where 1 / r^2 grows without bound); nothing was written. Lower \
             the light's intensity or move it out of the volume",
            pixels.len(),
            k % w,
            k / w,
            p.t_mean,
            p.rgb_mean.r,
            p.rgb_mean.g,
            p.rgb_mean.b
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pixel that is not finite is refused with its position and the count; finite images pass.
    #[test]
    fn non_finite_pixels_are_refused_by_position() {
        let mut pixels = vec![PixelOut::default(); 12];
        assert!(check_finite(&pixels, 4).is_ok());
        pixels[6].rgb_mean.g = f32::INFINITY;
        pixels[9].t_mean = f32::NAN;
        let e = check_finite(&pixels, 4).unwrap_err().to_string();
        assert!(
            e.starts_with("2 of 12 pixels") && e.contains("x 2, y 1"),
            "{e}"
        );
    }

    /// An image no ray of which read a voxel warns; so does one where under 0.1 % did; one hit
    /// pixel in 100 does not.
    #[test]
    fn images_that_miss_the_volume_warn() {
        let params = RenderParams::default();
        let mut pixels = vec![PixelOut::default(); 2000];
        let warns = |p: &[PixelOut]| RayFlags::of(p, 1).warnings(&params);
        assert!(warns(&pixels)[0].starts_with("no ray of the image read a voxel"));
        pixels[7].samples = 3;
        assert!(warns(&pixels)[0].starts_with("only 1 of 2000 pixels"));
        for p in pixels.iter_mut().step_by(100) {
            p.samples = 1;
        }
        assert!(warns(&pixels).is_empty());
        assert_eq!(RayFlags::of(&pixels, 1).pixels_hit, 21);
    }
}
