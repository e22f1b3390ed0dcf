//! Value parsers of the flags (ranges, vectors, lights) and the value enums of the CLI, each
//! converting into its library type.

use engine::backend::BackendChoice;
use engine::render::shadow_map::{MsmStorage, ShadowKind};
use engine::render_job::layers::Layer;
use engine::scene::camera::UpAxis;
use jackknife::SupervoxelFormat;
use lab::bench::BenchBackend;
use shared::params::{Sampler, TransmittanceHat};
use shared::shadows::map::{MsmFilter, MAX_FILTER_RADIUS};
use shared::volume::grid::Lookup;
use studies::distributions::Distribution;
use studies::profile::Sampling;

/// A clap value enum mirroring a library enum variant by variant, with `From` into it.
macro_rules! value_enum {
    ($(#[$m:meta])* $name:ident => $lib:ident { $($(#[$vm:meta])* $v:ident,)* }) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
        pub enum $name {
            $($(#[$vm])* $v,)*
        }

        impl From<$name> for $lib {
            fn from(v: $name) -> Self {
                match v {
                    $($name::$v => $lib::$v,)*
                }
            }
        }
    };
}

value_enum! {
    /// An extra EXR layer of `host render --layers`.
    LayerArg => Layer {
        /// Standard error of the pixel's mean.
        #[value(name = "stderr")]
        StdErr,
        /// Samples per pixel.
        Samples,
        /// Mean lookups per sample.
        Lookups,
        /// The camera rays' transmittance.
        CameraTransmittance,
        /// The medium's albedo times the camera rays' opacity (RGB).
        Albedo,
        /// Mean distance of the camera rays' first collision.
        Depth,
    }
}

value_enum! {
    /// Which backend the user asked for.
    BackendArg => BackendChoice {
        /// The Vulkan GPU if a driver is present, else the CPU (with a warning); on a software
        /// device (lavapipe) the backend a cost model of the job says finishes sooner.
        Auto,
        /// The Vulkan GPU; fail if there is none.
        Gpu,
        /// The CPU on all cores.
        Cpu,
    }
}

value_enum! {
    /// High-resolution lookups.
    LookupArg => Lookup {
        /// The voxel containing the sample point.
        Nearest,
        /// Stochastic texture filtering: jitter by up to half a voxel, then nearest (Sec. 4.3).
        Stochastic,
        /// Deterministic trilinear interpolation of the eight nearest voxels.
        Trilinear,
    }
}

value_enum! {
    /// How the super-voxel statistics are stored.
    SupervoxelFormatArg => SupervoxelFormat {
        /// f32 per statistic (exact up to conservative rounding).
        F32,
        /// BC4 block compression as in the paper's figures (conservative).
        Bc4,
    }
}

/// Fixed or adaptive super-voxels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SupervoxelsArg {
    /// One super-voxel per brick (the paper).
    Fixed,
    /// Bricks split into cells where that concentrates the importance.
    Adaptive,
}

value_enum! {
    /// The up axis of a volume.
    UpArg => UpAxis {
        /// x points up.
        X,
        /// y points up (the renderer's world).
        Y,
        /// z points up (Blender, Houdini).
        Z,
    }
}

value_enum! {
    /// Estimate of T(t0) in Eq. 9.
    THatArg => TransmittanceHat {
        /// Jackknife transmittance (tiny bias).
        Jackknife,
        /// Ratio tracking (unbiased).
        Ratio,
    }
}

value_enum! {
    /// Where a sample's uniforms come from.
    SamplerArg => Sampler {
        /// Every number independent (a hash generator per sample).
        Independent,
        /// The pixel jitter and each path vertex's leading dimensions from Owen-scrambled Sobol
        /// patterns, stratified within each pixel; the rest independent.
        Sobol,
    }
}

value_enum! {
    /// Shadow transmittance toward the sun.
    ShadowsArg => ShadowKind {
        /// Shadow rays through --estimator.
        Rays,
        /// The sun's four-moment shadow map (Peters et al. 2017, Algorithm 1).
        Msm4,
        /// The sun's six-moment shadow map.
        Msm6,
    }
}

value_enum! {
    /// Storage of the moment shadow map.
    MsmStorageArg => MsmStorage {
        /// 16-bit unorm after the quantization transform (64 bits a texel; four moments only).
        U16,
        /// 32-bit floats.
        F32,
    }
}

/// `--msm-filter none|box:R|gauss:R`: the prefilter of the moment shadow map and its radius in
/// texels (1 to 64; the Gaussian's standard deviation is R/3).
pub fn parse_msm_filter(s: &str) -> Result<(MsmFilter, u32), String> {
    let usage = || {
        format!(
            "expected none, box:R or gauss:R with a radius R of 1 to {MAX_FILTER_RADIUS} texels, \
              got {s:?}"
        )
    };
    if s == "none" {
        return Ok((MsmFilter::None, 0));
    }
    let (kind, r) = s.split_once(':').ok_or_else(usage)?;
    let filter = match kind {
        "box" => MsmFilter::Box,
        "gauss" => MsmFilter::Gauss,
        _ => return Err(usage()),
    };
    let r: u32 = r.parse().map_err(|_| usage())?;
    if !(1..=MAX_FILTER_RADIUS).contains(&r) {
        return Err(usage());
    }
    Ok((filter, r))
}

value_enum! {
    /// Where `host bench` runs.
    BenchBackendArg => BenchBackend {
        Cpu,
        Gpu,
        /// The CPU, then the GPU (skipped with a warning if there is none).
        Both,
    }
}

value_enum! {
    /// Hypothetical distributions of optical depth estimates, all with mean tau and std sigma.
    DistributionArg => Distribution {
        /// The assumption of Thm. 1: Eq. 4 is unbiased.
        Normal,
        /// Uniform on tau +- sqrt(3) sigma.
        Uniform,
        /// Laplace (double exponential) with scale sigma / sqrt(2).
        Laplace,
        /// One-sided: tau - sigma + Exp(mean sigma), a long tail towards large depths.
        Exponential,
        /// One-sided the other way: tau + sigma - Exp(mean sigma); exp(-X̄) has infinite variance
        /// from sigma = 1 on and infinite mean from sigma = 2 on.
        ExponentialLeft,
        /// tau - sigma or tau + sigma with probability 1/2 each.
        TwoPoint,
    }
}

value_enum! {
    /// How ray marching places its N samples along the segment (Sec. 4.1, Fig. 5).
    SamplingArg => Sampling {
        /// Deterministic midpoint rule, t_j = (j + 1/2) t_max / N.
        Midpoint,
        /// Uniform jittered: one xi shifts all N equidistant samples.
        Uniform,
        /// Stratified jittered: an independent xi_j in every stratum (the paper's choice).
        Stratified,
        /// N i.i.d. uniform positions in [0, t_max].
        Iid,
    }
}

/// Parses `--f-delta`: a CDF step in (0, 10]. Steps far above a ray's F take no sample on most
/// rays (T = exp(-tau_c) there), so larger values are refused rather than rendered as empty.
pub fn parse_f_delta(s: &str) -> Result<f32, String> {
    let v: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if !(v > 0.0 && v <= 10.0) {
        return Err(format!("must be in (0, 10] (got {s}); the paper uses 0.6"));
    }
    Ok(v)
}

/// A value parser of finite numbers in `[lo, hi]` (finite bounds), for a flag's documented range.
fn number_in<T>(lo: T, hi: T) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync
where
    T: std::str::FromStr + PartialOrd + std::fmt::Display + Copy + Send + Sync,
    T::Err: std::fmt::Display,
{
    // With finite bounds, the range test also refuses NaN and infinities.
    move |s: &str| match s.trim().parse::<T>() {
        Ok(v) if (lo..=hi).contains(&v) => Ok(v),
        Ok(v) => Err(format!("must be a finite number in [{lo}, {hi}] (got {v})")),
        Err(e) => Err(format!("not a number: {e}")),
    }
}

/// A value parser of finite f32 numbers in `[lo, hi]`.
pub fn f32_in(lo: f32, hi: f32) -> impl Fn(&str) -> Result<f32, String> + Clone + Send + Sync {
    number_in(lo, hi)
}

/// `--split-ratio`: a number in (0, 1].
pub fn parse_split_ratio(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v > 0.0 && v <= 1.0 => Ok(v),
        Ok(v) => Err(format!("must be in (0, 1] (got {v})")),
        Err(e) => Err(format!("not a number: {e}")),
    }
}

/// A value parser of finite numbers in the open interval `(lo, hi)`.
pub fn f32_open(lo: f32, hi: f32) -> impl Fn(&str) -> Result<f32, String> + Clone + Send + Sync {
    move |s: &str| match s.trim().parse::<f32>() {
        Ok(v) if v > lo && v < hi => Ok(v),
        Ok(v) => Err(format!("must be in ({lo}, {hi}) (got {v})")),
        Err(e) => Err(format!("not a number: {e}")),
    }
}

/// Parses `--density-scale`: a finite number >= 0 that f32 holds (a nonzero value that rounds
/// to 0 is refused rather than rendered as an empty volume). Optical depths beyond f32's sums
/// are refused later, against the volume's densities and size.
pub fn parse_density_scale(s: &str) -> Result<f32, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    let f = v as f32;
    if !(f.is_finite() && f >= 0.0) {
        return Err(format!(
            "must be a finite number >= 0 and at most 3.4e38 (got {s})"
        ));
    }
    if v > 0.0 && f == 0.0 {
        return Err(format!(
            "{s} rounds to 0 in f32 (the smallest is 1.4e-45); use 0 for an empty volume"
        ));
    }
    Ok(f)
}

/// A finite number > 0.
pub fn parse_positive(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(v) => Err(format!("must be a finite number > 0 (got {v})")),
        Err(e) => Err(format!("not a number: {e}")),
    }
}

/// Parses "x,y,z" into three finite floats.
pub fn parse_vec3(s: &str) -> Result<[f32; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!(
            "expected x,y,z (three comma-separated numbers), got {s:?}"
        ));
    }
    let mut v = [0.0f32; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        *slot = p
            .parse()
            .map_err(|_| format!("{p:?} is not a number in {s:?}"))?;
        if !slot.is_finite() {
            return Err(format!("{p:?} is not finite in {s:?}"));
        }
    }
    Ok(v)
}

/// `A..B`: a range of sample indices (`--samples`), A < B.
pub fn parse_samples(s: &str) -> Result<(u32, u32), String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("expected A..B (e.g. 0..256), got {s:?}"))?;
    let index = |t: &str| {
        t.trim()
            .parse::<u32>()
            .map_err(|_| format!("{t:?} is not a sample index (0 to 2^20) in {s:?}"))
    };
    let (a, b) = (index(a)?, index(b)?);
    if a >= b {
        return Err(format!(
            "{s:?} is empty: the first sample must come before the end"
        ));
    }
    Ok((a, b))
}

/// A value parser of finite f64 numbers in `[lo, hi]`.
pub fn finite_in(lo: f64, hi: f64) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    number_in(lo, hi)
}

/// A value parser of finite numbers in `(0, hi]`.
pub fn positive_up_to(hi: f64) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    move |s: &str| match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= hi => Ok(v),
        Ok(v) => Err(format!("must be a finite number in (0, {hi}] (got {v})")),
        Err(e) => Err(format!("not a number: {e}")),
    }
}

/// A value parser of counts (usize) in `lo..=hi`.
pub fn count_in(lo: u64, hi: u64) -> clap::builder::RangedU64ValueParser<usize> {
    clap::builder::RangedU64ValueParser::<usize>::new().range(lo..=hi)
}

/// One coefficient of `--g`: a finite number in [-10^6, 10^6].
pub fn parse_g_coefficient(s: &str) -> Result<f32, String> {
    let v = finite_in(-1e6, 1e6)(s)?;
    Ok(v as f32)
}

/// `--albedo`: one value in [0, 1] or "r,g,b", each in [0, 1].
pub fn parse_albedo(s: &str) -> Result<[f32; 3], String> {
    let v = engine::integrators::parse_f32_list(s)?;
    let ok = |x: &f32| x.is_finite() && (0.0..=1.0).contains(x);
    match v.as_slice() {
        [a] if ok(a) => Ok([*a; 3]),
        [r, g, b] if [r, g, b].into_iter().all(ok) => Ok([*r, *g, *b]),
        _ => Err(format!(
            "expected one value or r,g,b, each in [0, 1], got {s:?}"
        )),
    }
}

/// `--env`: `sky`, `none`, `constant:R,G,B` or an equirectangular `.exr` / `.hdr` file.
pub fn parse_env(s: &str) -> Result<engine::lighting::EnvSource, String> {
    engine::lighting::EnvSource::parse(s)
}

/// `--sun x,y,z[,intensity[,angular_radius_deg]]`: the direction toward the sun (non-zero), its
/// irradiance (finite, >= 0) and its angular radius in [0, 45] degrees.
pub fn parse_sun(s: &str) -> Result<engine::lighting::SunSpec, String> {
    let v = engine::integrators::parse_f32_list(s)?;
    let usage = || {
        format!(
            "expected x,y,z[,intensity[,angular_radius_deg]] with a finite non-zero direction, \
             intensity >= 0 and a radius in [0, 45] degrees, got {s:?}"
        )
    };
    if !(3..=5).contains(&v.len()) || v.iter().any(|x| !x.is_finite()) {
        return Err(usage());
    }
    if v[..3].iter().all(|x| *x == 0.0) {
        return Err(usage());
    }
    let irradiance = v.get(3).copied();
    let radius_deg = v
        .get(4)
        .copied()
        .unwrap_or(engine::lighting::SUN_RADIUS_DEG);
    if irradiance.is_some_and(|e| e < 0.0) || !(0.0..=45.0).contains(&radius_deg) {
        return Err(usage());
    }
    Ok(engine::lighting::SunSpec {
        dir: [v[0], v[1], v[2]],
        irradiance,
        radius_deg,
    })
}

/// `--integrator`'s parser: the names of the integrator table (`engine::integrators`), which
/// clap lists as the flag's possible values in `--help` and in its errors.
#[derive(Clone, Copy, Debug)]
pub struct IntegratorParser;

impl clap::builder::TypedValueParser for IntegratorParser {
    type Value = shared::params::Integrator;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<Self::Value, clap::Error> {
        clap::builder::PossibleValuesParser::new(self.possible_values().into_iter().flatten())
            .parse_ref(cmd, arg, value)
            .map(|name| {
                engine::integrators::integrators()
                    .find(|i| i.unit().name == name)
                    .expect("a possible value is an integrator's name")
            })
    }

    fn possible_values(
        &self,
    ) -> Option<Box<dyn Iterator<Item = clap::builder::PossibleValue> + '_>> {
        Some(Box::new(
            engine::integrators::integrators()
                .map(|i| clap::builder::PossibleValue::new(i.unit().name)),
        ))
    }
}

/// The error of a flag given a value that is not UTF-8, naming the flag and the fix (clap's own
/// message names neither).
fn not_utf8(cmd: &clap::Command, arg: Option<&clap::Arg>, value: &std::ffi::OsStr) -> clap::Error {
    let flag = arg
        .and_then(|a| a.get_long())
        .map_or_else(|| "a value".to_owned(), |l| format!("--{l}"));
    clap::Error::raw(
        clap::error::ErrorKind::InvalidUtf8,
        format!(
            "{flag} {:?}: not valid UTF-8, which this flag takes (it is recorded in the scene and \
             the JSON summary as text); rename the file, or link it under a UTF-8 name\n",
            value
        ),
    )
    .with_cmd(cmd)
}

/// A flag's text that may name a file (`--volume`, `--volumes`, `--profile`): a value that is
/// not UTF-8 is refused naming the flag ([`not_utf8`]).
#[derive(Clone, Copy, Debug)]
pub struct Utf8Text;

impl clap::builder::TypedValueParser for Utf8Text {
    type Value = String;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<String, clap::Error> {
        value
            .to_str()
            .map(str::to_owned)
            .ok_or_else(|| not_utf8(cmd, arg, value))
    }
}

/// `--env`: [`parse_env`] of a UTF-8 value; one that is not UTF-8 is refused naming the flag.
#[derive(Clone, Copy, Debug)]
pub struct EnvParser;

impl clap::builder::TypedValueParser for EnvParser {
    type Value = engine::lighting::EnvSource;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<Self::Value, clap::Error> {
        let text = Utf8Text.parse_ref(cmd, arg, value)?;
        parse_env(&text).map_err(|e| {
            let flag = arg.map_or_else(|| "--env".to_owned(), |a| a.to_string());
            clap::Error::raw(
                clap::error::ErrorKind::ValueValidation,
                format!("invalid value '{text}' for '{flag}': {e}\n"),
            )
            .with_cmd(cmd)
        })
    }
}
