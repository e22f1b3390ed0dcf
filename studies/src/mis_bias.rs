//! `host study mis-bias`: bias of the jackknife MIS weight estimate Re g(X̄ + iS) (Eq. 12) and of
//! the naive g(X̄) for g(tau) = (u0 e^-tau + u1) / (v0 e^-tau + v1) and normal inputs X0, X1 over a
//! (tau, sigma) grid (Fig. 7). Inputs are drawn in f64 and rounded to f32 for the renderer's own
//! `shared::mis::Mobius::{jackknife, naive}`; statistics are f64.

use super::files::Output;
use super::limits::check_trials;
use super::plot::{colorbar, Figure, HeatPanel, Series, Style, GREY, INK};
use super::rng::{sub_seed, Rng};
use super::stats::{progress, Moments};
use anyhow::{bail, Result};
use indicatif::ProgressBar;
use plotters::coord::Shift;
use plotters::prelude::{DrawingArea, DrawingBackend};
use rayon::prelude::*;
use serde::Serialize;
use shared::mis::Mobius;

/// sigma / tau at which N(tau, sigma^2) has 5% of its mass below 0 (the dashed line of Fig. 7).
pub const NEGATIVE_5_PERCENT: f64 = 1.645;

/// g(tau) in f64: the exact weight.
pub fn g_exact(g: &Mobius, tau: f64) -> f64 {
    let e = (-tau).exp();
    (g.u0 as f64 * e + g.u1 as f64) / (g.v0 as f64 * e + g.v1 as f64)
}

/// One grid cell (its centre).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Cell {
    pub tau: f64,
    pub sigma: f64,
    pub exact: f64,
    pub jackknife_bias: f64,
    pub jackknife_se: f64,
    pub naive_bias: f64,
    pub naive_se: f64,
}

/// The grid: nx cells over tau in [0, tau_max], ny over sigma in [0, sigma_max].
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Grid {
    pub tau_max: f64,
    pub sigma_max: f64,
    pub nx: usize,
    pub ny: usize,
}

impl Grid {
    /// Centre (tau, sigma) of cell index i = iy * nx + ix.
    pub fn centre(&self, i: usize) -> (f64, f64) {
        let (ix, iy) = (i % self.nx, i / self.nx);
        (
            (ix as f64 + 0.5) / self.nx as f64 * self.tau_max,
            (iy as f64 + 0.5) / self.ny as f64 * self.sigma_max,
        )
    }
}

/// `trials` pairs X0, X1 ~ N(tau, sigma^2) for one (tau, sigma); seed per call.
pub fn cell(g: &Mobius, tau: f64, sigma: f64, trials: u64, seed: u64) -> Cell {
    let exact = g_exact(g, tau);
    let (mut jk, mut nv) = (Moments::new(exact), Moments::new(exact));
    let mut rng = Rng::for_chunk(seed, 0);
    for _ in 0..trials {
        let (z0, z1) = rng.normal_pair();
        let (x0, x1) = ((tau + sigma * z0) as f32, (tau + sigma * z1) as f32);
        jk.push(g.jackknife(x0, x1) as f64);
        nv.push(g.naive(x0, x1) as f64);
    }
    Cell {
        tau,
        sigma,
        exact,
        jackknife_bias: jk.mean() - exact,
        jackknife_se: jk.mean_se(),
        naive_bias: nv.mean() - exact,
        naive_se: nv.mean_se(),
    }
}

/// Every cell of the grid, in row-major order; cell i uses seed sub_seed(seed, i).
pub fn measure(g: &Mobius, grid: &Grid, trials: u64, seed: u64, bar: &ProgressBar) -> Vec<Cell> {
    (0..grid.nx * grid.ny)
        .into_par_iter()
        .map(|i| {
            let (tau, sigma) = grid.centre(i);
            let c = cell(g, tau, sigma, trials, sub_seed(seed, i as u64));
            bar.inc(1);
            c
        })
        .collect()
}

/// Largest and mean |bias| of both estimators over the cells below sigma = 1.645 tau with
/// sigma <= `sigma_cap` (the maxima include each cell's Monte Carlo noise, `jackknife_se`).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct BelowLine {
    pub sigma_cap: f64,
    pub cells: usize,
    pub jackknife_max_abs_bias: f64,
    pub jackknife_mean_abs_bias: f64,
    pub naive_max_abs_bias: f64,
    pub naive_mean_abs_bias: f64,
}

pub fn below_line(cells: &[Cell], sigma_cap: f64) -> BelowLine {
    let below: Vec<&Cell> = cells
        .iter()
        .filter(|c| c.sigma < NEGATIVE_5_PERCENT * c.tau && c.sigma <= sigma_cap)
        .collect();
    let n = below.len().max(1) as f64;
    let stat = |f: &dyn Fn(&Cell) -> f64| {
        let max = below.iter().map(|c| f(c).abs()).fold(0.0, f64::max);
        let mean = below.iter().map(|c| f(c).abs()).sum::<f64>() / n;
        (max, mean)
    };
    let (jm, ja) = stat(&|c| c.jackknife_bias);
    let (nm, na) = stat(&|c| c.naive_bias);
    BelowLine {
        sigma_cap,
        cells: below.len(),
        jackknife_max_abs_bias: jm,
        jackknife_mean_abs_bias: ja,
        naive_max_abs_bias: nm,
        naive_mean_abs_bias: na,
    }
}

/// Fig. 7: two heat maps of the bias (jackknife, naive) on one colour scale.
pub struct MisBiasFigure {
    pub g: Mobius,
    pub grid: Grid,
    pub cells: Vec<Cell>,
    pub limit: f64,
}

impl Figure for MisBiasFigure {
    fn size(&self) -> (u32, u32) {
        (1060, 470)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let (maps, bar) = root.split_horizontally(960);
        let halves = maps.split_evenly((1, 2));
        let line = Series::new(
            "",
            INK,
            Style::Dashed,
            vec![
                (0.0, 0.0),
                (
                    self.grid.sigma_max / NEGATIVE_5_PERCENT,
                    self.grid.sigma_max,
                ),
            ],
        );
        let g = &self.g;
        let pole = (g.v0 as f64 / g.v1 as f64).ln();
        let mut overlays = vec![line];
        if pole > 0.0 && pole < self.grid.tau_max {
            overlays.push(Series::new(
                "",
                GREY,
                Style::Line,
                vec![(pole, 0.0), (pole, self.grid.sigma_max)],
            ));
        }
        let panel = |title: &str, f: &dyn Fn(&Cell) -> f64| HeatPanel {
            title: title.to_string(),
            x_label: "optical depth τ".to_string(),
            y_label: "σ of each estimate".to_string(),
            x: (0.0, self.grid.tau_max),
            y: (0.0, self.grid.sigma_max),
            nx: self.grid.nx,
            ny: self.grid.ny,
            values: self.cells.iter().map(f).collect(),
            limit: self.limit,
            overlays: overlays.clone(),
        };
        panel("bias of jackknife Re g(mean X + iS) (Eq. 12)", &|c| {
            c.jackknife_bias
        })
        .draw(&halves[0])?;
        panel("bias of naive g(mean X)", &|c| c.naive_bias).draw(&halves[1])?;
        colorbar(&bar, self.limit, "bias")
    }
}

/// Options of `host study mis-bias` (the CLI's flags, checked by `run`).
#[derive(Debug, Clone)]
pub struct MisBiasOptions {
    /// u0,u1,v0,v1 of g(tau) = (u0 e^-tau + u1) / (v0 e^-tau + v1) (Eq. 11): four finite
    /// numbers in [-10^6, 10^6]; v0 and v1 not both 0.
    pub g: Vec<f32>,
    /// Largest tau of the grid, in (0, 20].
    pub tau_max: f64,
    /// Largest sigma of the grid, in (0, 10].
    pub sigma_max: f64,
    /// Grid cells along tau, 1 to 1024.
    pub nx: usize,
    /// Grid cells along sigma, 1 to 1024.
    pub ny: usize,
    /// Trials per cell, 2 to 10^9.
    pub trials: u64,
    /// Bias at which the colour saturates, in (0, 10^6].
    pub limit: f64,
    /// Seed, JSON and plot files, progress bar.
    pub out: Output,
}

/// Runs `host study mis-bias`: measures, prints the table, writes the JSON and the plot.
pub fn run(a: &MisBiasOptions) -> Result<()> {
    check_trials(a.trials)?;
    let [u0, u1, v0, v1] = a.g[..] else {
        bail!("--g takes four numbers u0,u1,v0,v1")
    };
    if v0 == 0.0 && v1 == 0.0 {
        bail!("--g: v0 and v1 are both 0, so g(tau) has no finite value anywhere");
    }
    if a.nx == 0 || a.ny == 0 {
        bail!("mis-bias needs --nx >= 1 and --ny >= 1");
    }
    let g = Mobius { u0, u1, v0, v1 };
    let grid = Grid {
        tau_max: a.tau_max,
        sigma_max: a.sigma_max,
        nx: a.nx,
        ny: a.ny,
    };
    let bar = progress((a.nx * a.ny) as u64, "mis-bias", a.out.quiet);
    let cells = measure(&g, &grid, a.trials, a.out.seed, &bar);
    bar.finish_and_clear();
    let below: Vec<BelowLine> = [1.0, 2.0, f64::INFINITY]
        .iter()
        .map(|&cap| below_line(&cells, cap))
        .collect();
    println!(
        "g = ({u0} e^-tau + {u1}) / ({v0} e^-tau + {v1}); {}x{} cells, {} trials each",
        a.nx, a.ny, a.trials
    );
    println!(
        "cells below sigma = 1.645 tau: |bias| max and mean (each cell has Monte Carlo noise)"
    );
    for b in &below {
        println!(
            "  sigma <= {:>4}: {:>4} cells, jackknife {:.5} / {:.5}, naive {:.5} / {:.5}",
            b.sigma_cap,
            b.cells,
            b.jackknife_max_abs_bias,
            b.jackknife_mean_abs_bias,
            b.naive_max_abs_bias,
            b.naive_mean_abs_bias
        );
    }
    println!(
        "{:>6} {:>6} {:>9} {:>22} {:>22}",
        "tau", "sigma", "g(tau)", "jackknife bias +- s.e.", "naive bias +- s.e."
    );
    for &(tau, sigma) in &[(0.5, 0.25), (1.0, 0.5), (2.0, 1.0), (3.0, 1.0), (1.0, 2.0)] {
        let c = cell(&g, tau, sigma, a.trials.max(100_000), a.out.seed);
        println!(
            "{:>6.2} {:>6.2} {:>9.5} {:>+12.6} +- {:<7.6} {:>+12.6} +- {:<7.6}",
            tau, sigma, c.exact, c.jackknife_bias, c.jackknife_se, c.naive_bias, c.naive_se
        );
    }
    #[derive(Serialize)]
    struct Json<'a> {
        g: [f32; 4],
        grid: Grid,
        trials: u64,
        below_line: &'a [BelowLine],
        cells: &'a [Cell],
    }
    let json = Json {
        g: [u0, u1, v0, v1],
        grid,
        trials: a.trials,
        below_line: &below,
        cells: &cells,
    };
    a.out.write(
        "mis_bias",
        &json,
        &MisBiasFigure {
            g,
            grid,
            cells: cells.clone(),
            limit: a.limit,
        },
    )
}
