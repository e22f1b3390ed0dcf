//! The integration tests as one binary (`cargo test --release --test suite`), so the GPU tests
//! share one lavapipe device and its pipelines: lavapipe's disk cache keeps only LLVM's output, so
//! each process paid the SPIR-V front end of every pipeline it built again (up to ~110 s for a
//! `restir` stage), and the files below overlap in the (kernel, specialization) pairs they render
//! with. Each file is one module, one concept; run one with `--test suite -- density_sweep::`.

mod adaptive;
mod density_sweep;
mod direct;
mod gpu_vs_cpu;
mod layout;
mod light_sampling;
mod lookup;
mod loop_budget;
mod mis;
mod msm;
mod msm_render;
mod path;
mod pipeline;
mod pool;
mod progressive;
mod rays;
mod restir;
mod sampler;
mod skip;
mod tracking;
mod wide;
