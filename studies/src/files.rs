//! The output flags of every study and the files they name.

use anyhow::Result;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// `--seed`, `--json`, `--plot`, `--quiet` of every study.
#[derive(Debug, Clone)]
pub struct Output {
    /// Seed of the random numbers, 0 to 2^64 - 1; results are bit-identical for any thread count.
    pub seed: u64,
    /// Also write the numbers as JSON to this file.
    pub json: Option<PathBuf>,
    /// Plot file, `.png` or `.svg` [default: out/study_<name>.png].
    pub plot: Option<PathBuf>,
    /// Hide the progress bar.
    pub quiet: bool,
}

impl Output {
    /// Checks before the study runs that `--json` and the plot (or, by default, `out/`) are
    /// distinct, writable, and not the file `profile` (a `--profile` CSV, by any name).
    pub fn check(&self, profile: Option<&Path>) -> Result<()> {
        let mut plan = output::OutputPlan::new();
        if let Some(profile) = profile {
            plan.input("--profile", profile);
        }
        if let Some(json) = &self.json {
            plan.file("--json", json);
        }
        match &self.plot {
            Some(plot) => {
                super::plot::check_format(plot)?;
                plan.file("--plot", plot)
            }
            None => plan.dir("the default plot directory", Path::new("out")),
        };
        plan.check()
    }

    /// Writes the JSON (if asked for) and the plot, and says where they went.
    pub fn write<T: Serialize>(
        &self,
        name: &str,
        report: &T,
        figure: &impl super::plot::Figure,
    ) -> Result<()> {
        // The plot first: a JSON never stands beside a plot that could not be drawn.
        let default = PathBuf::from(format!("out/study_{name}.png"));
        let plot: &Path = self.plot.as_deref().unwrap_or(&default);
        super::plot::save(plot, figure)?;
        println!("wrote {}", plot.display());
        if let Some(path) = &self.json {
            output::ensure_parent(path)?;
            output::write_json(path, report)?;
            println!("wrote {}", path.display());
        }
        Ok(())
    }
}
