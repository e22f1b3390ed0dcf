//! The `--restir-*` flags of `host render` and `host eval`.

use engine::integrators::restir::RestirOptions;

/// `--integrator restir` (render) / `--integrators restir` (eval) options.
#[derive(clap::Args, Debug, Clone)]
pub struct RestirArgs {
    /// `restir`: light candidates per sample (M, drawn by power; 1..=1024).
    #[arg(long, default_value_t = 32)]
    pub restir_candidates: u32,
    /// `restir`: transmittance factor of the target p̂: `jackknife` (N = --restir-n), `unshadowed`
    /// (T̂ = 1) or `ratio` (ratio tracking).
    #[arg(long, default_value = "jackknife", value_parser = engine::integrators::restir::parse_target)]
    pub restir_target: shared::params::RestirTarget,
    /// `restir`: samples per optical depth estimate of the target's jackknife (1..=4096).
    #[arg(long, default_value_t = 4)]
    pub restir_n: u32,
    /// `restir`: floor on the target's T̂, in (0, 1] (T̂ is clamped to [floor, 1] so that p̂ > 0
    /// wherever the integrand is).
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true)]
    pub restir_floor: f32,
    /// `restir`: spatial reuse passes over the image (0: none; 0..=16). Each pass resamples
    /// every pixel's reservoir with --restir-neighbours random neighbours' (GRIS).
    #[arg(long, default_value_t = 0)]
    pub restir_passes: u32,
    /// `restir`: neighbours per pixel and reuse pass, k (1..=64).
    #[arg(long, default_value_t = 3)]
    pub restir_neighbours: u32,
    /// `restir`: neighbours are drawn uniformly within this many pixels in x and y (1..=1024).
    #[arg(long, default_value_t = 16)]
    pub restir_radius: u32,
    /// `restir`: resampling MIS weights of reuse: `pairwise` (O(k) target evaluations per pixel)
    /// or `balance` (generalized balance heuristic, O(k^2)).
    #[arg(long, default_value = "pairwise", value_parser = engine::integrators::restir::parse_mis)]
    pub restir_mis: shared::params::RestirMis,
    /// `restir`: cap on a reused reservoir's confidence M, in candidates (0: no cap).
    #[arg(long, default_value_t = 0)]
    pub restir_m_cap: u32,
}

impl RestirArgs {
    /// The library's options.
    pub fn options(&self) -> RestirOptions {
        RestirOptions {
            candidates: self.restir_candidates,
            target: self.restir_target,
            n: self.restir_n,
            floor: self.restir_floor,
            passes: self.restir_passes,
            neighbours: self.restir_neighbours,
            radius: self.restir_radius,
            mis: self.restir_mis,
            m_cap: self.restir_m_cap,
        }
    }
}
