//! The size of a command's work, and `--backend auto`'s cost model for a software Vulkan device
//! (lavapipe), which runs the kernels on the same cores as the CPU backend: it is faster per
//! sample for some integrators, but its pipeline builds cost seconds before the first sample.

use shared::params::Integrator;

/// The kernels' cost classes as the cost model tells them apart: each integrator's row of the
/// integrator table (`shared::integrators::unit`) names its class.
pub use shared::integrators::unit::Work as WorkKind;

/// The cost class of `integrator` (`None`: transmittance).
pub fn work_of(integrator: Option<Integrator>) -> WorkKind {
    integrator.unwrap_or(Integrator::Transmittance).unit().work
}

/// The kind among `kinds` that a software device runs worst (the largest time ratio), which
/// stands for a job of several; transmittance if there is none.
pub fn costliest(kinds: &[WorkKind]) -> WorkKind {
    kinds
        .iter()
        .copied()
        .max_by(|a, b| costs(*a).1.total_cmp(&costs(*b).1))
        .unwrap_or(WorkKind::Transmittance)
}

/// CPU core-nanoseconds per sample on the embedded cloud at its defaults, and a software
/// device's time per sample over the CPU backend's on the same cores: the mean of two runs of
/// `scripts/results/speed_integrators.sh target/release/host OUT 256` on 2 cores after a first that
/// warms lavapipe's shader cache (docs/results/speed.md, "`--backend auto` on a software
/// device").
pub fn costs(kind: WorkKind) -> (f64, f64) {
    match kind {
        WorkKind::Transmittance => (2.0 * 370.0, 0.44),
        WorkKind::FreeFlight => (2.0 * 634.0, 0.93),
        WorkKind::SingleScattering => (2.0 * 1155.0, 0.85),
        WorkKind::Direct => (2.0 * 1453.0, 0.99),
        WorkKind::Path => (2.0 * 1497.0, 15.9),
        WorkKind::Restir => (2.0 * 5140.0, 1.70),
    }
}

/// [`costs`] of a primary-ray transmittance render that the CPU backend runs eight pixels per
/// instruction ([`Job::wide`]: the jackknife and the naive mean on the fixed grid): CPU
/// core-nanoseconds per sample from the mean of two runs of `scripts/results/speed_integrators.sh
/// target/release/host OUT 256` (after a first), and the software device's time per sample over
/// the CPU's from `host bench --backend both` (min frames, 256x256 at 8 spp, two rounds: the
/// marginal times of two renders scattered by +-30 % on this VM), docs/results/speed.md.
pub const WIDE_TRANSMITTANCE: (f64, f64) = (2.0 * 179.0, 1.0);

/// Seconds a software device spends before its first sample that the CPU backend does not:
/// device creation, pipeline builds (LLVM compiles of the specialized kernels; about 4 s for one
/// to four pipelines on this project's 2-core machine, `pipeline_build_ms` in the render JSON)
/// and the driver's work on the first dispatch.
pub const SOFTWARE_FIXED_S: f64 = 4.0;

/// What a command renders: `samples` camera samples (pixels x spp, summed over its renders) of
/// one kind of kernel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Job {
    pub kind: WorkKind,
    pub samples: u64,
    /// Whether the CPU backend renders it eight pixels per instruction
    /// (`shared::kernels::wide`; [`crate::backend::cpu::renders_wide`]).
    pub wide: bool,
}

/// The cost model's estimate for a job on each backend, in seconds of wall time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    pub cpu_s: f64,
    pub software_s: f64,
}

impl Job {
    /// A render of `width` x `height` pixels at `spp` samples each.
    pub fn render(integrator: Option<Integrator>, width: u32, height: u32, spp: u32) -> Self {
        Self {
            kind: work_of(integrator),
            samples: u64::from(width) * u64::from(height) * u64::from(spp),
            wide: false,
        }
    }

    /// This job, rendered eight pixels per instruction on the CPU if `wide`.
    pub fn wide_if(self, wide: bool) -> Self {
        Self { wide, ..self }
    }

    /// CPU core-nanoseconds per sample and the software device's time ratio ([`costs`]).
    pub fn costs(&self) -> (f64, f64) {
        if self.wide && self.kind == WorkKind::Transmittance {
            WIDE_TRANSMITTANCE
        } else {
            costs(self.kind)
        }
    }

    /// Estimated wall time on the CPU backend and on a software device sharing its `threads`
    /// cores: both divide the same per-sample work among the cores; the device adds
    /// [`SOFTWARE_FIXED_S`].
    pub fn estimate(&self, threads: usize) -> Estimate {
        let (core_ns, ratio) = self.costs();
        let cpu_s = self.samples as f64 * core_ns * 1e-9 / threads.max(1) as f64;
        Estimate {
            cpu_s,
            software_s: SOFTWARE_FIXED_S + cpu_s * ratio,
        }
    }
}

impl Estimate {
    /// Whether the CPU backend finishes the job no later than the software device.
    pub fn cpu_is_faster(&self) -> bool {
        self.cpu_s <= self.software_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The README's quick-start render (512x512, 4 spp of transmittance) is short: the CPU wins;
    /// a long one by an estimator the CPU runs one ray at a time is the device's, and a long
    /// jackknife render, as fast per sample on the CPU's eight lanes, stays.
    #[test]
    fn the_default_render_stays_on_the_cpu_and_a_long_one_moves() {
        for wide in [false, true] {
            let small = Job::render(None, 512, 512, 4).wide_if(wide).estimate(2);
            assert!(small.cpu_is_faster(), "{small:?}");
        }
        let long = Job::render(None, 512, 512, 1024).estimate(2);
        assert!(!long.cpu_is_faster(), "{long:?}");
        let wide = Job::render(None, 512, 512, 1 << 16)
            .wide_if(true)
            .estimate(2);
        assert!(wide.cpu_is_faster(), "{wide:?}");
    }

    /// `path` and `restir` are slower per sample on a software device, so no size moves them
    /// there; free flights, single scattering and `direct` (about as fast there as on the CPU)
    /// move only when very long.
    #[test]
    fn integrators_no_faster_per_sample_never_move() {
        for integrator in [Integrator::Path, Integrator::Restir] {
            for spp in [1, 64, 1 << 16] {
                let e = Job::render(Some(integrator), 1920, 1080, spp).estimate(2);
                assert!(e.cpu_is_faster(), "{integrator:?} {spp}: {e:?}");
            }
        }
        for integrator in [
            Integrator::FreeFlight,
            Integrator::MisJackknife,
            Integrator::Direct,
        ] {
            let short = Job::render(Some(integrator), 512, 512, 64).estimate(2);
            assert!(short.cpu_is_faster(), "{integrator:?}: {short:?}");
            let long = Job::render(Some(integrator), 1920, 1080, 1024).estimate(2);
            assert!(!long.cpu_is_faster(), "{integrator:?}: {long:?}");
        }
    }

    /// An evaluation's kinds are represented by the one a software device runs worst.
    #[test]
    fn the_costliest_kind_stands_for_a_mix() {
        let mix = [WorkKind::Transmittance, WorkKind::Path, WorkKind::Direct];
        assert_eq!(costliest(&mix), WorkKind::Path);
        assert_eq!(costliest(&[]), WorkKind::Transmittance);
    }

    /// More cores shorten both backends' sample work but not the fixed cost, so a job that
    /// moves on 2 cores may stay on 64.
    #[test]
    fn more_cores_keep_more_jobs_on_the_cpu() {
        let job = Job::render(None, 512, 512, 1024);
        assert!(!job.estimate(2).cpu_is_faster());
        assert!(job.estimate(64).cpu_is_faster());
    }
}
