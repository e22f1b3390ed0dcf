//! The voxel pool and the brick table as uniform texel buffers of `u32` words: the kernels'
//! [`Texels`], read where specialization constant 9 is 1 (`shared::volume::texels`).

use shared::volume::texels::Texels;
#[cfg(target_arch = "spirv")]
use spirv_std::glam::UVec4;

/// A uniform texel buffer of `u32` words (`VK_FORMAT_R32_UINT`).
pub type WordTexels = spirv_std::Image!(buffer, type = u32, sampled);

/// The two tables as texel buffers, and whether the pipeline reads them.
#[derive(Clone, Copy)]
pub struct TexelTables<'a> {
    pub pool: &'a WordTexels,
    pub bricks: &'a WordTexels,
    pub bound: bool,
}

/// Word `i` of `image`: one OpImageFetch. spirv-std's `fetch` adds a Lod operand, which buffer
/// images may not take, and a NonUniform decoration, which makes Mesa loop over the lanes.
#[cfg(target_arch = "spirv")]
#[inline]
fn fetch(image: &WordTexels, i: u32) -> u32 {
    let coordinate = i as i32;
    let mut result = UVec4::ZERO;
    // SAFETY: an OpImageFetch of a sampled buffer image at an integer coordinate; out of
    // range it returns 0 (robust buffer access) or is undefined, and every index the view
    // reads lies inside its table.
    unsafe {
        core::arch::asm! {
            "%image = OpLoad _ {image}",
            "%coordinate = OpLoad _ {coordinate}",
            "%result = OpImageFetch typeof*{result} %image %coordinate",
            "OpStore {result} %result",
            image = in(reg) image,
            coordinate = in(reg) &coordinate,
            result = in(reg) &mut result,
        }
    }
    result.x
}

/// Natively (the kernels crate compiles as an rlib for the host) there are no images.
#[cfg(not(target_arch = "spirv"))]
fn fetch(_image: &WordTexels, _i: u32) -> u32 {
    unreachable!("texel buffers exist on the GPU only")
}

impl Texels for TexelTables<'_> {
    #[inline]
    fn bound(&self) -> bool {
        self.bound
    }

    #[inline]
    fn pool_word(&self, w: u32) -> u32 {
        fetch(self.pool, w)
    }

    #[inline]
    fn brick_word(&self, w: u32) -> u32 {
        fetch(self.bricks, w)
    }
}
