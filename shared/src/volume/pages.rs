//! The voxel pool in pages: kernels bind it as up to [`MAX_PAGES`] storage buffers of at most
//! 2^[`GPU_PAGE_LOG2`] words each (Vulkan guarantees storage buffers of 128 MiB, no more), and
//! the CPU sees it as one page. No brick's run of voxels crosses a page boundary, so a voxel's
//! page and offset come from its pool index alone.

/// Pages a kernel binds.
pub const MAX_PAGES: usize = 8;
/// log2 of the words per page the pool is laid out in: 2^25 words = 128 MiB, the
/// `maxStorageBufferRange` every Vulkan device supports.
pub const GPU_PAGE_LOG2: u32 = 25;
/// log2 of the words per page of a view whose page 0 is the whole pool (2^31 words: every pool
/// index fits).
pub const ONE_PAGE_LOG2: u32 = 31;

/// The pool's pages: f16 voxels two per u32 word; page `p` holds words
/// `p << page_log2 ..` of the pool.
#[derive(Clone, Copy)]
pub struct Pages<'a> {
    pub p0: &'a [u32],
    pub p1: &'a [u32],
    pub p2: &'a [u32],
    pub p3: &'a [u32],
    pub p4: &'a [u32],
    pub p5: &'a [u32],
    pub p6: &'a [u32],
    pub p7: &'a [u32],
    /// Whether `p0` is the whole pool (a kernel variant that binds one page; the CPU).
    pub single: bool,
}

impl<'a> Pages<'a> {
    /// The whole pool as page 0 (read with [`ONE_PAGE_LOG2`]).
    pub fn one(words: &'a [u32]) -> Self {
        Pages {
            p0: words,
            p1: &[],
            p2: &[],
            p3: &[],
            p4: &[],
            p5: &[],
            p6: &[],
            p7: &[],
            single: true,
        }
    }

    /// Word `w` of the pool, in pages of 2^`page_log2` words.
    #[inline]
    pub fn word(&self, page_log2: u32, w: u32) -> u32 {
        if self.single {
            return self.p0[w as usize];
        }
        let at = (w & ((1u32 << page_log2) - 1)) as usize;
        match w >> page_log2 {
            0 => self.p0[at],
            1 => self.p1[at],
            2 => self.p2[at],
            3 => self.p3[at],
            4 => self.p4[at],
            5 => self.p5[at],
            6 => self.p6[at],
            _ => self.p7[at],
        }
    }

    /// The f16 bits at pool index `index` (two per word, low half first).
    #[inline]
    pub fn half(&self, page_log2: u32, index: u32) -> u32 {
        (self.word(page_log2, index >> 1) >> ((index & 1) * 16)) & 0xffff
    }
}
