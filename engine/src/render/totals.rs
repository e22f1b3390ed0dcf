//! A pixel's exact totals over sample blocks: what a render adds block after block, what a shard
//! file stores and what `host merge` adds up.

use crate::render::exact::ExactSum;
use anyhow::Result;
use shared::kernels::render::PixelSums;
use shared::rgb::Rgb;

/// The exact sums of one pixel over whole sample blocks (`shared::kernels::render::SAMPLE_BLOCK`):
/// each block's f32 [`PixelSums`] added without rounding, the counts in 64 bits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PixelTotals {
    pub t: ExactSum,
    pub t2: ExactSum,
    pub rgb: [ExactSum; 3],
    pub samples: u64,
    pub capped: u64,
    pub outside: u64,
    pub fallback: u64,
}

impl PixelTotals {
    /// Adds one block's sums.
    pub fn add_block(&mut self, s: &PixelSums) {
        self.t.add_f32(s.t_sum);
        self.t2.add_f32(s.t2_sum);
        self.rgb[0].add_f32(s.rgb_sum.r);
        self.rgb[1].add_f32(s.rgb_sum.g);
        self.rgb[2].add_f32(s.rgb_sum.b);
        self.samples += u64::from(s.samples);
        self.capped += u64::from(s.capped);
        self.outside += u64::from(s.outside);
        self.fallback += u64::from(s.fallback);
    }

    /// Adds another total of the same pixel (a shard's).
    pub fn add(&mut self, o: &PixelTotals) {
        self.t.add(&o.t);
        self.t2.add(&o.t2);
        for (a, b) in self.rgb.iter_mut().zip(&o.rgb) {
            a.add(b);
        }
        self.samples += o.samples;
        self.capped += o.capped;
        self.outside += o.outside;
        self.fallback += o.fallback;
    }

    /// The totals rounded to f32 sums (for `finish_pixel`); a count beyond 32 bits is refused.
    /// One block's totals give back its sums bit for bit.
    pub fn to_sums(&self) -> Result<PixelSums> {
        let count = |c: u64, what: &str| {
            u32::try_from(c).map_err(|_| {
                anyhow::anyhow!(
                    "a pixel's {what} count ({c}) exceeds 32 bits; render fewer samples per pixel"
                )
            })
        };
        Ok(PixelSums {
            t_sum: self.t.to_f32(),
            t2_sum: self.t2.to_f32(),
            samples: count(self.samples, "density lookup")?,
            capped: count(self.capped, "capped-sample")?,
            outside: count(self.outside, "out-of-regime sample")?,
            fallback: count(self.fallback, "fallback")?,
            rgb_sum: Rgb::new(
                self.rgb[0].to_f32(),
                self.rgb[1].to_f32(),
                self.rgb[2].to_f32(),
            ),
        })
    }

    /// Appends the totals to `out` (the five sums, then the four counts little-endian).
    pub fn write(&self, out: &mut Vec<u8>) {
        for s in [&self.t, &self.t2, &self.rgb[0], &self.rgb[1], &self.rgb[2]] {
            s.write(out);
        }
        for c in [self.samples, self.capped, self.outside, self.fallback] {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }

    /// Reads totals written by [`PixelTotals::write`] from the front of `bytes`, advancing it.
    pub fn read(bytes: &mut &[u8]) -> Option<PixelTotals> {
        let mut sums = [ExactSum::default(); 5];
        for s in &mut sums {
            *s = ExactSum::read(bytes)?;
        }
        let mut counts = [0u64; 4];
        for c in &mut counts {
            let (head, rest) = bytes.split_first_chunk::<8>()?;
            *c = u64::from_le_bytes(*head);
            *bytes = rest;
        }
        let [t, t2, r, g, b] = sums;
        let [samples, capped, outside, fallback] = counts;
        Some(PixelTotals {
            t,
            t2,
            rgb: [r, g, b],
            samples,
            capped,
            outside,
            fallback,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sums(t: f32, r: f32, samples: u32) -> PixelSums {
        PixelSums {
            t_sum: t,
            t2_sum: t * t,
            samples,
            capped: 1,
            outside: 2,
            fallback: 3,
            rgb_sum: Rgb::new(r, -r, 0.5 * r),
        }
    }

    /// One block's totals are its sums, bit for bit (a render of one block keeps its bytes).
    #[test]
    fn one_block_is_its_sums() {
        for s in [
            sums(0.3, 1.7, 9),
            sums(-1e-30, 3e20, 0),
            PixelSums::default(),
        ] {
            let mut t = PixelTotals::default();
            t.add_block(&s);
            assert_eq!(t.to_sums().unwrap(), s);
        }
    }

    /// Blocks added one by one equal shards of them merged, and the stored form reads back.
    #[test]
    fn shards_merge_to_the_whole_and_round_trip() {
        let blocks: Vec<PixelSums> = (0..12)
            .map(|k| sums(0.1 * k as f32 + 1e-9, 3.0f32.powi(k - 6), k as u32))
            .collect();
        let mut whole = PixelTotals::default();
        blocks.iter().for_each(|b| whole.add_block(b));
        let mut merged = PixelTotals::default();
        for part in blocks.chunks(5).rev() {
            let mut shard = PixelTotals::default();
            part.iter().for_each(|b| shard.add_block(b));
            let mut bytes = Vec::new();
            shard.write(&mut bytes);
            let back = PixelTotals::read(&mut bytes.as_slice()).unwrap();
            assert_eq!(back, shard);
            merged.add(&back);
        }
        assert_eq!(merged, whole);
        assert_eq!(merged.samples, 66);
    }

    /// A count beyond 32 bits is refused, not wrapped.
    #[test]
    fn count_overflow_is_refused() {
        let t = PixelTotals {
            samples: 1 << 32,
            ..Default::default()
        };
        let e = t.to_sums().unwrap_err().to_string();
        assert!(e.contains("exceeds 32 bits"), "{e}");
    }
}
