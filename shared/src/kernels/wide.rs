//! The CPU's transmittance pass over several pixels per instruction: the jackknife, its adaptive
//! variant and the naive mean of [`crate::kernels::render::transmittance_pixel_pass`], one pixel
//! per lane, on the
//! layouts [`WideVolume::of`] reads. Each pixel gets the scalar pass's bytes: the same camera
//! rays and generators, Alg. 2 and Alg. 1 lane by lane ([`crate::estimators::wide`]), and the
//! same Eq. 4, tally and sums per lane in sample order.

use crate::estimators::optical_depth::{adaptive_capped, adaptive_unsampled};
use crate::estimators::transmittance;
use crate::estimators::wide::{estimate_pair, prepare, WidePlan};
use crate::geometry::{Ray, V3};
use crate::kernels::render::{camera_ray, index_segment, render_pixel_pass, PixelSums};
use crate::lanes::Lanes;
use crate::params::{Config, Estimator, RenderParams};
use crate::rgb::Rgb;
use crate::tally::Tally;
use crate::volume::grid::VolumeView;
use crate::volume::texels::Texels;
use crate::volume::wide::{WideRays, WideVolume, MAX_LANES};

/// Whether [`transmittance_pass`] renders `params` (a primary-ray transmittance image by the
/// jackknife, its adaptive variant or the naive mean of a pair) on `vol`, i.e. whether it has a
/// [`WideVolume`].
#[inline(always)]
pub fn renders<T: Texels>(vol: &VolumeView<T>, params: &RenderParams) -> bool {
    let cfg = Config::decode(params, &vol.desc);
    let estimator = matches!(
        cfg.estimator,
        Estimator::Jackknife | Estimator::NaiveMean | Estimator::JackknifeAdaptive
    );
    params.integrator == 0 && estimator && WideVolume::of(vol).is_some()
}

/// Adds samples s_begin..s_end of the pixels `pixels` (at most `L::N`, each its own lane) to
/// `acc` (one [`PixelSums`] per pixel): what [`render_pixel_pass`] adds to each. Where
/// [`renders`] does not hold it runs that scalar pass pixel by pixel, without lights: call it
/// for transmittance renders only. Inlined into its caller, which may compile it for a wider
/// instruction set than the crate's.
#[inline(always)]
pub fn transmittance_pass<L: Lanes, T: Texels>(
    vol: &VolumeView<T>,
    params: &RenderParams,
    pixels: &[u32],
    s_begin: u32,
    s_end: u32,
    acc: &mut [PixelSums],
) {
    let count = pixels.len();
    assert!(count <= L::N && L::N <= MAX_LANES && acc.len() == count);
    let wide = match WideVolume::of(vol) {
        Some(wide) if renders(vol, params) => wide,
        _ => {
            for (sums, &pixel) in acc.iter_mut().zip(pixels) {
                *sums = render_pixel_pass(vol, params, &[], pixel, s_begin, s_end, *sums);
            }
            return;
        }
    };
    let cfg = Config::decode(params, &vol.desc);
    let none = Ray {
        o: V3::new(0.0, 0.0, 0.0),
        d: V3::new(0.0, 0.0, 1.0),
    };
    let mut s = s_begin;
    while s < s_end {
        let mut rays = [none; MAX_LANES];
        let (mut t0, mut t1, mut rng) = ([0.0f32; MAX_LANES], [0.0; MAX_LANES], [0; MAX_LANES]);
        for (l, &pixel) in pixels.iter().enumerate() {
            let (world, r) = camera_ray(params, pixel, s);
            let (ray, a, b) = index_segment(vol, params, &world);
            (rays[l], t0[l], t1[l], rng[l]) = (ray, a, b, r.state);
        }
        let on = L::m_from(|l| l < count && t0[l] < t1[l]);
        let (a, b) = (L::f_from(|l| t0[l]), L::f_from(|l| t1[l]));
        let rays = WideRays::<L>::of(&rays);
        let prep = prepare::<L, _>(&wide, &rays, a, b, on, cfg.importance, false);
        let rng = L::u_from(|l| rng[l]);
        let adaptive = cfg.estimator == Estimator::JackknifeAdaptive;
        let plan = if adaptive {
            WidePlan::adaptive(&prep, params.f_delta)
        } else {
            WidePlan::fixed(&prep, params.n, params.n)
        };
        let est = estimate_pair::<L, _>(
            &wide,
            &rays,
            &prep,
            on,
            &plan,
            cfg.importance,
            cfg.jitter,
            rng,
        );
        for (l, sums) in acc.iter_mut().enumerate() {
            let (t, tally) = if !L::m_at(on, l) {
                (1.0, Tally::default())
            } else {
                let (x0, x1) = (L::f_at(est.x0, l), L::f_at(est.x1, l));
                let tally =
                    Tally::lookups(L::u_at(est.samples, l)).capped_if(L::m_at(est.capped, l));
                if adaptive {
                    // As `estimate::transmittance`'s arm for the adaptive variant.
                    let (p, samples) = (prep.lane(l), L::u_at(est.samples, l));
                    let tally = tally.capped_if(adaptive_capped(&p, params.f_delta));
                    let outside = transmittance::outside_regime(x0, x1)
                        | adaptive_unsampled(&p, params.f_delta, samples);
                    (transmittance::jackknife(x0, x1), tally.outside_if(outside))
                } else if cfg.estimator == Estimator::Jackknife {
                    let outside = transmittance::outside_regime(x0, x1);
                    (transmittance::jackknife(x0, x1), tally.outside_if(outside))
                } else {
                    (transmittance::naive(x0, x1), tally)
                }
            };
            *sums = sums.add(Rgb::splat(t), t, tally);
        }
        s += 1;
    }
}
