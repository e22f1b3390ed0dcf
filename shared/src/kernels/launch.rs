//! Buffer and push-constant layouts shared by the kernels, the CPU backend and the GPU host.
//!
//! All structs are `#[repr(C)]` Pod with explicit padding; `tests` pin their sizes.

use bytemuck::{Pod, Zeroable};

/// Header of every kernel's push constants: which slice of the ids one dispatch covers.
///
/// The host splits large launches into several dispatches (workgroup-count limits, driver
/// watchdogs); invocation `gid` of a dispatch handles id `offset + gid`, if below `count`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Launch {
    /// First id covered by this dispatch.
    pub offset: u32,
    /// Total number of ids in the launch (ids >= count do nothing).
    pub count: u32,
    /// User seed, for kernels that draw random numbers.
    pub seed: u32,
    pub _pad: u32,
}

impl Launch {
    /// The id an invocation handles, or `None` past the end of the launch.
    #[inline]
    pub fn id(&self, gid: u32) -> Option<usize> {
        let id = self.offset.wrapping_add(gid);
        if gid < self.count && id < self.count {
            Some(id as usize)
        } else {
            None
        }
    }
}

/// Threads per workgroup of every 1-D kernel (`#[spirv(compute(threads(64)))]`).
pub const WORKGROUP_SIZE: u32 = 64;
