//! The stages of the wavefront integrators (`direct`, `path`, `restir`), stated once: how many
//! stages a sample has, each stage's push mode and kind, the kernel that runs a kind, whether a
//! kind reads the render's estimator, and the state one stage hands the next. The GPU plan
//! dispatches these stages one after another (`engine::gpu::render`); the CPU runs the same
//! stages of a sample in one call (`direct_radiance`, `path_radiance`, `restir_radiance`).

use super::direct::DirectState;
use super::path::PathState;
use super::restir::{
    stage_count as restir_stage_count, stage_kind as restir_stage_kind, RestirState,
    KIND_CANDIDATE, KIND_QUERY, KIND_RESOLVE, KIND_REUSE, KIND_START,
};
use crate::params::RenderParams;

/// The kind of wavefront stage `stage` of `direct` and `path`: 0 starts the sample, 1 is any
/// later stage (the stage specialization constant of `direct_cs` and `path_cs`).
#[inline]
pub fn wave_kind(_params: &RenderParams, stage: u32) -> u32 {
    (stage != 0) as u32
}

/// The kernel that runs a stage kind: one entry point, and one SPIR-V module, each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StageKernel {
    /// `direct_cs`: a start and three estimates.
    Direct,
    /// `path_cs`: a start and one bounce of every live path.
    Path,
    /// `restir_start_cs`: the camera ray, the vertex, `direct`'s light and phase samples.
    RestirStart,
    /// `restir_candidate_cs`: one light candidate streamed through the reservoir.
    RestirCandidate,
    /// `restir_reuse_cs`: one spatial reuse pass.
    RestirReuse,
    /// `restir_resolve_cs`: the reservoir's sample and its contribution weight.
    RestirResolve,
    /// `restir_query_cs`: one transmittance query's estimate.
    RestirQuery,
}

/// An integrator that runs as a wavefront: each sample is a sequence of stages, one dispatch
/// each on a GPU, each handing a state to the next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wavefront {
    /// `direct`: a start and three estimates.
    Direct,
    /// `path`: a start and `max_depth + 1` bounces.
    Path,
    /// `restir`: a start, M candidates, P reuse passes, the resolve and four estimates.
    Restir,
}

impl Wavefront {
    /// Bytes of one sample's state.
    #[inline]
    pub fn state_bytes(self) -> u32 {
        (match self {
            Wavefront::Direct => core::mem::size_of::<DirectState>(),
            Wavefront::Path => core::mem::size_of::<PathState>(),
            Wavefront::Restir => core::mem::size_of::<RestirState>(),
        }) as u32
    }

    /// The stages of one sample.
    #[inline]
    pub fn stage_count(self, params: &RenderParams) -> u32 {
        match self {
            Wavefront::Direct => 4,
            Wavefront::Path => params.max_depth + 2,
            Wavefront::Restir => restir_stage_count(params),
        }
    }

    /// The push mode of stage `stage` (what the kernel reads as its stage): `path`'s bounces
    /// all run mode 1, the other stages their own index.
    #[inline]
    pub fn mode(self, stage: u32) -> u32 {
        match self {
            Wavefront::Path => (stage != 0) as u32,
            Wavefront::Direct | Wavefront::Restir => stage,
        }
    }

    /// The kind of the stage of push mode `mode`: the kernel's stage specialization constant
    /// (id 2), so that one pipeline compiles one kind's code.
    #[inline]
    pub fn kind(self, params: &RenderParams, mode: u32) -> u32 {
        match self {
            Wavefront::Direct | Wavefront::Path => wave_kind(params, mode),
            Wavefront::Restir => restir_stage_kind(params, mode),
        }
    }

    /// The kernel that runs stages of kind `kind`.
    #[inline]
    pub fn kernel(self, kind: u32) -> StageKernel {
        match (self, kind) {
            (Wavefront::Direct, _) => StageKernel::Direct,
            (Wavefront::Path, _) => StageKernel::Path,
            (Wavefront::Restir, KIND_START) => StageKernel::RestirStart,
            (Wavefront::Restir, KIND_CANDIDATE) => StageKernel::RestirCandidate,
            (Wavefront::Restir, KIND_REUSE) => StageKernel::RestirReuse,
            (Wavefront::Restir, KIND_RESOLVE) => StageKernel::RestirResolve,
            // KIND_QUERY, the only other kind `restir::stage_kind` gives.
            (Wavefront::Restir, _) => StageKernel::RestirQuery,
        }
    }

    /// Whether stages of kind `kind` read the render's estimator: `direct`'s start (free
    /// flight by delta tracking, light and phase samples) and `restir`'s start, candidates,
    /// reuse and resolve (their targets' T̂ has its own estimator, `--restir-target`) do not,
    /// so one pipeline of theirs serves every estimator.
    #[inline]
    pub fn reads_estimator(self, kind: u32) -> bool {
        match self {
            Wavefront::Direct => kind != 0,
            Wavefront::Path => true,
            Wavefront::Restir => kind == KIND_QUERY,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn modes(wave: Wavefront, params: &RenderParams) -> Vec<u32> {
        (0..wave.stage_count(params))
            .map(|s| wave.mode(s))
            .collect()
    }

    /// The stage sequences of a sample: `direct` 0..4; `path` a start and max_depth + 1 bounces
    /// of mode 1; `restir` each stage its own mode, kinds in the order start, candidates, reuse,
    /// resolve, queries, each kind run by its own kernel.
    #[test]
    fn each_wavefront_states_its_stages_once() {
        let params = RenderParams {
            max_depth: 3,
            restir: crate::params::RestirParams {
                candidates: 2,
                passes: 1,
                ..Default::default()
            },
            ..RenderParams::default()
        };
        assert_eq!(modes(Wavefront::Direct, &params), [0, 1, 2, 3]);
        assert_eq!(modes(Wavefront::Path, &params), [0, 1, 1, 1, 1]);
        let restir = modes(Wavefront::Restir, &params);
        assert_eq!(restir, (0..9).collect::<Vec<u32>>());
        let kinds: Vec<u32> = restir
            .iter()
            .map(|&m| Wavefront::Restir.kind(&params, m))
            .collect();
        let q = KIND_QUERY;
        assert_eq!(
            kinds,
            [
                KIND_START,
                KIND_CANDIDATE,
                KIND_CANDIDATE,
                KIND_REUSE,
                KIND_RESOLVE,
                q,
                q,
                q,
                q
            ]
        );
        let kernels: Vec<StageKernel> =
            kinds.iter().map(|&k| Wavefront::Restir.kernel(k)).collect();
        assert_eq!(kernels[0], StageKernel::RestirStart);
        assert_eq!(kernels[3], StageKernel::RestirReuse);
        assert_eq!(kernels[8], StageKernel::RestirQuery);
        for wave in [Wavefront::Direct, Wavefront::Path] {
            assert_eq!(wave.kind(&params, 0), 0);
            assert_eq!(wave.kind(&params, 1), 1);
        }
        assert_eq!(
            Wavefront::Restir.state_bytes() as usize,
            core::mem::size_of::<RestirState>()
        );
    }
}
