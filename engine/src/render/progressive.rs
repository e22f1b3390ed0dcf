//! Progressive rendering: a render's samples added a few at a time, each frame continuing the
//! pixels' sums where the last one stopped, so that after N samples the pixels are the bytes of
//! a render of N samples per pixel, however the samples were cut into frames (`host view`).

use crate::lighting::SceneLights;
use crate::render::totals::PixelTotals;
use crate::render::{finish_totals, Resident};
use anyhow::Result;
use shared::kernels::render::{finish_pixel, starts_block, PixelOut, PixelSums, SAMPLE_BLOCK};
use shared::params::RenderParams;

/// The running state of one progressive render: the sums of the current sample block and the
/// exact totals of the finished ones (the same split as [`crate::render::render_totals`]).
#[derive(Default)]
pub struct Progressive {
    /// Running sums of the current block (row-major; empty before the first frame).
    block: Vec<PixelSums>,
    /// Exact totals of the finished blocks (empty until the first block is finished).
    totals: Vec<PixelTotals>,
    /// Samples per pixel rendered so far.
    samples: u32,
}

impl Progressive {
    /// A render with no samples yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Samples per pixel rendered so far.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// Renders the next `count` samples of every pixel (fewer where the current sample block
    /// ends first, so that a frame never crosses a block), continuing the block's sums; returns
    /// how many were rendered. `params` must be those of the earlier frames (its `spp` is not
    /// read: the samples are this render's next ones).
    pub fn advance(
        &mut self,
        resident: &Resident,
        params: &RenderParams,
        lights: &SceneLights,
        count: u32,
    ) -> Result<u32> {
        let s0 = self.samples;
        let block_end = (s0 / SAMPLE_BLOCK + 1).saturating_mul(SAMPLE_BLOCK);
        let s1 = s0.saturating_add(count.max(1)).min(block_end);
        anyhow::ensure!(s1 > s0, "a progressive render holds at most {} samples", s0);
        let start = (!starts_block(s0)).then_some(self.block.as_slice());
        self.block = crate::render::render_frame(resident, params, lights, s0..s1, start)?;
        self.samples = s1;
        if starts_block(s1) {
            if self.totals.is_empty() {
                self.totals = vec![PixelTotals::default(); self.block.len()];
            }
            for (t, s) in self.totals.iter_mut().zip(&self.block) {
                t.add_block(s);
            }
        }
        Ok(s1 - s0)
    }

    /// The pixels of the samples so far, as a render of that many samples per pixel gives them
    /// (empty before the first frame).
    pub fn pixels(&self) -> Result<Vec<PixelOut>> {
        let spp = self.samples;
        if self.totals.is_empty() {
            return Ok(self.block.iter().map(|s| finish_pixel(*s, spp)).collect());
        }
        if starts_block(spp) {
            return finish_totals(&self.totals, spp);
        }
        let mut totals = self.totals.clone();
        for (t, s) in totals.iter_mut().zip(&self.block) {
            t.add_block(s);
        }
        finish_totals(&totals, spp)
    }
}
