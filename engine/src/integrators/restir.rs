//! `--integrator restir`: its options, their checks, and what it records in the JSON.

use anyhow::{ensure, Result};
use shared::params::{RenderParams, RestirMis, RestirTarget};

/// Most candidates per sample (each is a dispatch on the GPU).
pub const MAX_CANDIDATES: u32 = 1024;
/// Most samples per optical depth estimate of the target (as `--n`).
pub const MAX_TARGET_N: u32 = 4096;
/// Most spatial reuse passes (each a dispatch over the image).
pub const MAX_PASSES: u32 = 16;
/// Most neighbours per pixel and pass (the balance heuristic costs k^2 target evaluations).
pub const MAX_NEIGHBOURS: u32 = 64;
/// Largest reuse window radius in pixels.
pub const MAX_RADIUS: u32 = 1024;
/// Most pixels of an image with spatial reuse (every pixel's state is held at once).
pub const MAX_REUSE_PIXELS: u64 = 1 << 24;
/// Largest confidence M a reservoir may reach (candidates x (k + 1)^passes, or the cap): exact
/// in f32 and far from u32's end, so summing confidences never wraps.
pub const MAX_CONFIDENCE: u64 = 1 << 24;

/// The options of `restir` (`--restir-*`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestirOptions {
    /// Light candidates per camera sample, M.
    pub candidates: u32,
    /// The transmittance factor of the target p̂.
    pub target: RestirTarget,
    /// Samples per optical depth estimate of the target's jackknife.
    pub n: u32,
    /// Floor on the target's T̂.
    pub floor: f32,
    /// Spatial reuse passes (0: none).
    pub passes: u32,
    /// Neighbours per pixel and pass, k.
    pub neighbours: u32,
    /// Neighbours within this many pixels in x and y.
    pub radius: u32,
    /// The resampling MIS weights of reuse.
    pub mis: RestirMis,
    /// Cap on a reused reservoir's confidence M (0: none).
    pub m_cap: u32,
}

impl Default for RestirOptions {
    fn default() -> Self {
        RestirOptions {
            candidates: 32,
            target: RestirTarget::Jackknife,
            n: 4,
            floor: 0.05,
            passes: 0,
            neighbours: 3,
            radius: 16,
            mis: RestirMis::Pairwise,
            m_cap: 0,
        }
    }
}

/// Target names of `--restir-target`.
pub const TARGETS: &[(&str, RestirTarget)] = &[
    ("jackknife", RestirTarget::Jackknife),
    ("unshadowed", RestirTarget::Unshadowed),
    ("ratio", RestirTarget::Ratio),
];

/// Parses a `--restir-target` name.
pub fn parse_target(s: &str) -> Result<RestirTarget, String> {
    TARGETS
        .iter()
        .find(|(n, _)| *n == s)
        .map(|(_, t)| *t)
        .ok_or_else(|| {
            format!("unknown --restir-target {s:?}; choose one of: jackknife, unshadowed, ratio")
        })
}

/// Names of `--restir-mis`.
pub const MIS: &[(&str, RestirMis)] = &[
    ("pairwise", RestirMis::Pairwise),
    ("balance", RestirMis::Balance),
];

/// Parses a `--restir-mis` name.
pub fn parse_mis(s: &str) -> Result<RestirMis, String> {
    MIS.iter()
        .find(|(n, _)| *n == s)
        .map(|(_, t)| *t)
        .ok_or_else(|| format!("unknown --restir-mis {s:?}; choose one of: pairwise, balance"))
}

/// The name of MIS weights.
pub fn mis_name(m: RestirMis) -> &'static str {
    MIS.iter()
        .find(|(_, x)| *x == m)
        .map(|(n, _)| *n)
        .unwrap_or("pairwise")
}

/// The name of a target.
pub fn target_name(t: RestirTarget) -> &'static str {
    TARGETS
        .iter()
        .find(|(_, x)| *x == t)
        .map(|(n, _)| *n)
        .unwrap_or("jackknife")
}

impl RestirOptions {
    /// Refuses values the integrator cannot use, naming the flag.
    pub fn check(&self) -> Result<()> {
        ensure!(
            (1..=MAX_CANDIDATES).contains(&self.candidates),
            "--restir-candidates must be in 1..={MAX_CANDIDATES} (got {})",
            self.candidates
        );
        ensure!(
            (1..=MAX_TARGET_N).contains(&self.n),
            "--restir-n must be in 1..={MAX_TARGET_N} (got {})",
            self.n
        );
        ensure!(
            self.floor.is_finite() && self.floor > 0.0 && self.floor <= 1.0,
            "--restir-floor must be in (0, 1] (got {}): the target must stay positive wherever \
             the integrand is, or the estimate would be biased",
            self.floor
        );
        ensure!(
            self.passes <= MAX_PASSES,
            "--restir-passes must be in 0..={MAX_PASSES} (got {})",
            self.passes
        );
        ensure!(
            (1..=MAX_NEIGHBOURS).contains(&self.neighbours),
            "--restir-neighbours must be in 1..={MAX_NEIGHBOURS} (got {})",
            self.neighbours
        );
        ensure!(
            (1..=MAX_RADIUS).contains(&self.radius),
            "--restir-radius must be in 1..={MAX_RADIUS} pixels (got {})",
            self.radius
        );
        ensure!(
            u64::from(self.m_cap) <= MAX_CONFIDENCE,
            "--restir-m-cap must be at most {MAX_CONFIDENCE} (got {})",
            self.m_cap
        );
        let worst = self.max_confidence();
        ensure!(
            self.passes == 0 || self.m_cap > 0 || worst <= MAX_CONFIDENCE as f64,
            "with --restir-candidates {} --restir-neighbours {} --restir-passes {} a reservoir's \
             confidence M can reach {worst:.3e}, above {MAX_CONFIDENCE}: set --restir-m-cap (at \
             most {MAX_CONFIDENCE}), or use fewer passes or neighbours",
            self.candidates,
            self.neighbours,
            self.passes
        );
        let d = RestirOptions::default();
        ensure!(
            self.passes > 0
                || (self.neighbours, self.radius, self.mis, self.m_cap)
                    == (d.neighbours, d.radius, d.mis, d.m_cap),
            "--restir-neighbours, --restir-radius, --restir-mis and --restir-m-cap configure \
             spatial reuse, which is off: add --restir-passes 1 (or more) or drop them"
        );
        Ok(())
    }

    /// The largest confidence M of a reservoir without a cap: M (k + 1)^passes.
    pub fn max_confidence(&self) -> f64 {
        f64::from(self.candidates) * f64::from(self.neighbours + 1).powi(self.passes as i32)
    }

    /// Refuses spatial reuse on an image whose states do not fit at once (reuse reads every
    /// pixel's state): `width` x `height` pixels.
    pub fn check_image(&self, width: u32, height: u32) -> Result<()> {
        let pixels = u64::from(width) * u64::from(height);
        ensure!(
            self.passes == 0 || pixels <= MAX_REUSE_PIXELS,
            "--restir-passes {} keeps every pixel's state in memory at once: {width} x {height} \
             = {pixels} pixels is above the limit of {MAX_REUSE_PIXELS}; lower --width/--height \
             or use --restir-passes 0",
            self.passes
        );
        Ok(())
    }

    /// Writes the options into the render parameters.
    pub fn apply(&self, params: &mut RenderParams) {
        params.restir.candidates = self.candidates;
        params.restir.target = self.target as u32;
        params.restir.n = self.n;
        params.restir.floor = self.floor;
        params.restir.passes = self.passes;
        params.restir.neighbours = self.neighbours;
        params.restir.radius = self.radius;
        params.restir.mis = self.mis as u32;
        params.restir.m_cap = self.m_cap;
    }

    /// The JSON record.
    pub fn settings(&self) -> RestirSettings {
        RestirSettings {
            candidates: self.candidates,
            target: target_name(self.target).into(),
            target_n: self.n,
            target_floor: self.floor,
            passes: self.passes,
            neighbours: self.neighbours,
            radius: self.radius,
            mis: mis_name(self.mis).into(),
            m_cap: self.m_cap,
        }
    }
}

/// `restir`'s settings in the render JSON.
#[derive(serde::Serialize, Clone, Debug)]
pub struct RestirSettings {
    /// Light candidates per camera sample (M), drawn by power.
    pub candidates: u32,
    /// The target's transmittance factor: `jackknife`, `unshadowed` or `ratio`.
    pub target: String,
    /// Samples per optical depth estimate of the target's jackknife.
    pub target_n: u32,
    /// Floor on the target's T̂ (clamped to [floor, 1]).
    pub target_floor: f32,
    /// Spatial reuse passes (0: none).
    pub passes: u32,
    /// Neighbours per pixel and pass.
    pub neighbours: u32,
    /// Neighbours lie within this many pixels in x and y.
    pub radius: u32,
    /// Resampling MIS weights of reuse: `pairwise` or `balance`.
    pub mis: String,
    /// Cap on a reused reservoir's confidence M (0: none).
    pub m_cap: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reuse holds every pixel's state: images above 2^24 pixels are refused with it, naming the
    /// flag; without reuse any size passes.
    #[test]
    fn reuse_refuses_images_too_large_to_hold() {
        let reuse = RestirOptions {
            passes: 1,
            ..Default::default()
        };
        assert!(reuse.check_image(4096, 4096).is_ok());
        let e = reuse.check_image(8192, 4096).unwrap_err().to_string();
        assert!(e.contains("--restir-passes") && e.contains("pixels"), "{e}");
        assert!(RestirOptions::default().check_image(8192, 4096).is_ok());
    }

    /// Confidences that could pass 2^24 are refused unless capped; the cap is bounded too.
    #[test]
    fn confidence_stays_exact() {
        let o = RestirOptions {
            candidates: 1024,
            neighbours: 63,
            passes: 2,
            ..Default::default()
        };
        assert!(o.check().is_ok()); // 1024 x 64^2 = 2^22
        let deep = RestirOptions { passes: 3, ..o };
        let e = deep.check().unwrap_err().to_string();
        assert!(e.contains("--restir-m-cap"), "{e}");
        assert!(RestirOptions {
            m_cap: 1000,
            ..deep
        }
        .check()
        .is_ok());
        let huge = RestirOptions {
            m_cap: (1 << 24) + 1,
            ..deep
        };
        assert!(huge.check().is_err());
    }

    /// The reuse flags are refused while reuse is off, accepted with it.
    #[test]
    fn reuse_flags_need_passes() {
        let off = RestirOptions {
            neighbours: 5,
            ..Default::default()
        };
        assert!(off
            .check()
            .unwrap_err()
            .to_string()
            .contains("--restir-passes 1"));
        assert!(RestirOptions { passes: 2, ..off }.check().is_ok());
    }
}
