//! The seam between render planning and the backends: how a render's work is cut, and the one
//! trait the CPU and GPU render loops implement.

use crate::lighting::SceneLights;
use anyhow::Result;
use indicatif::ProgressBar;
use shared::kernels::render::PixelSums;
use shared::kernels::shadow_map::MsmPass;
use shared::params::RenderParams;
use shared::sampling::lighting::Lighting;

/// Loop iterations one GPU invocation may run: lavapipe's gallivm ends a shader after 65535
/// iterations summed over all its loops; the rest is margin for small fixed loops.
pub const LOOP_BUDGET: u64 = 60_000;

/// How one backend runs the passes of a render (the CPU loop in `cpu`, the GPU loop in `gpu`).
pub trait RenderBackend: Sync {
    /// The sums of every pixel (row-major) after `schedule`'s passes, advancing `bar` (if any)
    /// by the samples done. The passes continue from `start` (row-major; `None`: zero sums),
    /// the sums of the block's earlier samples, where the first pass does not start a sample
    /// block (the kernels start from zero at a block's first sample).
    fn render_sums(
        &self,
        params: &RenderParams,
        lights: &SceneLights,
        schedule: &Schedule,
        start: Option<&[PixelSums]>,
        bar: Option<&ProgressBar>,
    ) -> Result<Vec<PixelSums>>;

    /// Most loop iterations one invocation may run (None: no limit).
    fn loop_budget(&self) -> Option<u64> {
        None
    }

    /// The stored words of the sun's moment shadow map of `lighting` (its frame and mode), with
    /// the prefilter of `pass` (both passes of `shared::kernels::shadow_map` over every texel).
    fn build_shadow_map(
        &self,
        params: &RenderParams,
        lighting: &Lighting,
        pass: &MsmPass,
    ) -> Result<Vec<u32>>;
}

/// How a render's work is cut: passes of samples, and chunks of work items within a pass.
pub struct Schedule {
    /// Sample ranges (s_begin, s_end) of the passes, in order.
    pub passes: Vec<(u32, u32)>,
    /// Work items per chunk (a whole number of workgroups): the unit of progress and the
    /// longest GPU dispatch.
    pub chunk: u32,
}

impl Schedule {
    /// The samples the passes cover (one sample block or part of one: the wavefronts run them
    /// sample by sample).
    pub fn samples(&self) -> std::ops::Range<u32> {
        let start = self.passes.first().map_or(0, |p| p.0);
        let end = self.passes.last().map_or(0, |p| p.1);
        start..end
    }
}
