//! Lab tools on top of the engine: `host eval` (bias and standard deviation against a
//! reference), `host bench` (timings per estimator and backend), `host report` (an HTML report
//! of both) and `host probe` (Eq. 4 on simulated pairs).

pub mod bench;
pub mod eval;
pub mod eval_direct;
pub mod evaluate;
pub mod probe;
pub mod reference;
pub mod report;

/// Defaults of the `host eval` options (the CLI shows them as its defaults).
pub mod defaults {
    /// `host eval --width` and `--height`.
    pub const EVAL_SIZE: u32 = 128;
    /// `host eval --spp`.
    pub const EVAL_SPP: u32 = 1024;
    /// `host eval --bias-scale`.
    pub const BIAS_SCALE: f32 = 0.05;
    /// `host eval --std-scale`.
    pub const STD_SCALE: f32 = 0.5;
    /// `host eval --out-dir`.
    pub const EVAL_OUT_DIR: &str = "out/eval";
}
