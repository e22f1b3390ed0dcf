//! Buffer and push-constant layouts shared by the kernels, the CPU backend and the GPU host.
//!
//! All structs are `#[repr(C)]` Pod with explicit padding; `tests` pin their sizes.

use bytemuck::{Pod, Zeroable};

/// Header of every kernel's push constants: which slice of the ids one dispatch covers.
///
/// The host splits large launches into several dispatches (workgroup-count limits, driver
/// watchdogs); each id in `offset..count` is handled by exactly one invocation of the dispatch,
/// whole workgroups of consecutive ids ([`Launch::id`]). Which workgroup handles which ids is
/// the device's plan (`interleave`); no result depends on it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Launch {
    /// First id covered by this dispatch.
    pub offset: u32,
    /// End of the ids covered by this dispatch (ids >= count do nothing).
    pub count: u32,
    /// User seed, for kernels that draw random numbers.
    pub seed: u32,
    /// The threads a software device runs the dispatch's workgroups on, as contiguous ranges,
    /// one per thread ([`interleaved_group`]); 0 or 1 on a GPU: workgroup w handles the w-th
    /// run of ids.
    pub interleave: u32,
}

impl Launch {
    /// The id an invocation handles, or `None` past the end of the dispatch: workgroup
    /// `gid / WORKGROUP_SIZE` handles the [`interleaved_group`]-th run of `WORKGROUP_SIZE`
    /// consecutive ids.
    #[inline]
    pub fn id(&self, gid: u32) -> Option<usize> {
        let n = self.count.wrapping_sub(self.offset);
        let groups = n.div_ceil(WORKGROUP_SIZE);
        let w = interleaved_group(gid / WORKGROUP_SIZE, groups, self.interleave);
        let local = w
            .wrapping_mul(WORKGROUP_SIZE)
            .wrapping_add(gid % WORKGROUP_SIZE);
        let id = self.offset.wrapping_add(local);
        if local < self.count && id < self.count {
            Some(id as usize)
        } else {
            None
        }
    }
}

/// The run of ids workgroup `w` of a dispatch of `groups` workgroups handles, where the device
/// runs the workgroups as `parts` contiguous ranges of `groups / parts`, one per thread (how
/// lavapipe runs a dispatch; the `groups % parts` left over run one by one): the k-th
/// workgroup of range p handles run `k * parts + p`, so the threads work side by side on
/// neighbouring ids (equal work, shared cache lines) instead of on distant parts of the image.
/// A permutation of `0..groups`; the identity for `parts` <= 1 and on the left-over
/// workgroups.
#[inline]
pub fn interleaved_group(w: u32, groups: u32, parts: u32) -> u32 {
    let per = if parts > 1 { groups / parts } else { 0 };
    if per == 0 || w >= per * parts {
        return w;
    }
    (w % per) * parts + w / per
}

/// Threads per workgroup of every 1-D kernel (`#[spirv(compute(threads(64)))]`).
pub const WORKGROUP_SIZE: u32 = 64;

/// Bindings (descriptor set 0) of every kernel, by name: storage buffers, uniform blocks and
/// texel buffers. rust-gpu's
/// `#[spirv(binding = N)]` takes integer literals only, so `kernels/src/lib.rs` spells the
/// numbers out next to these names; the host checks each named binding's element size against
/// the compiled module at compile time (`vulkan-backend/src/kernels.rs`).
pub mod bindings {
    /// `transmittance_pair_cs`, `math_values_cs` and `equiangular_cs`: output i from input i.
    pub mod map {
        /// The inputs, one per id.
        pub const INPUT: usize = 0;
        /// The outputs, one per id.
        pub const OUTPUT: usize = 1;
        /// Number of bindings.
        pub const COUNT: usize = 2;
    }

    /// `rng_draws_cs`: generator outputs per id.
    pub mod rng_draws {
        /// The outputs, one per id.
        pub const OUTPUT: usize = 0;
        /// Number of bindings.
        pub const COUNT: usize = 1;
    }

    /// `transmittance_cs` and `scattering_cs`: one pass of a primary-ray image.
    pub mod render {
        /// One `RenderParams`.
        pub const PARAMS: usize = 0;
        /// One `GridDesc`.
        pub const DESC: usize = 1;
        /// The packed voxels (`u32` words).
        pub const VOXELS: usize = 2;
        /// The bricks (`Brick`).
        pub const BRICKS: usize = 3;
        /// The point lights (`PointLight`).
        pub const LIGHTS: usize = 4;
        /// One `PixelSums` per pixel of the tile, read and written.
        pub const SUMS: usize = 5;
        /// Pages 1 .. 7 of the voxel pool (`VOXELS` is page 0; see `volume::pages`).
        pub const VOXEL_PAGES: usize = 6;
        /// The voxel pool's page 0 as a uniform texel buffer of `u32` words (`volume::texels`).
        pub const POOL_TEXELS: usize = 13;
        /// The brick table as a uniform texel buffer of `u32` words.
        pub const BRICK_TEXELS: usize = 14;
        /// Number of bindings.
        pub const COUNT: usize = 15;
    }

    /// `direct_cs`: one stage of a `direct` image: the bindings of `transmittance_cs`, the lights', then
    /// the samples' states.
    pub mod direct {
        /// One `RenderParams` (as `transmittance_cs`).
        pub const PARAMS: usize = 0;
        /// One `GridDesc`.
        pub const DESC: usize = 1;
        /// The packed voxels (`u32` words).
        pub const VOXELS: usize = 2;
        /// The bricks (`Brick`).
        pub const BRICKS: usize = 3;
        /// The point lights (`PointLight`).
        pub const LIGHTS: usize = 4;
        /// One `PixelSums` per pixel of the tile, read and written.
        pub const SUMS: usize = 5;
        /// One `Lighting` (map shape, sun, albedo, pmf over light kinds).
        pub const LIGHTING: usize = 6;
        /// The environment map's texels and CDFs (`f32`; one unused value without a map).
        pub const ENV: usize = 7;
        /// One `DirectState` per pixel of the tile, read and written.
        pub const STATES: usize = 8;
        /// The sun's moment shadow map (`u32` words; one unused word with shadow rays).
        pub const SHADOW_MAP: usize = 9;
        /// Pages 1 .. 7 of the voxel pool (`VOXELS` is page 0; see `volume::pages`).
        pub const VOXEL_PAGES: usize = 10;
        /// The voxel pool's page 0 as a uniform texel buffer of `u32` words (`volume::texels`).
        pub const POOL_TEXELS: usize = 17;
        /// The brick table as a uniform texel buffer of `u32` words.
        pub const BRICK_TEXELS: usize = 18;
        /// Number of bindings.
        pub const COUNT: usize = 19;
    }

    /// `msm_build_cs`: the raw moments of each texel of the sun's moment shadow map.
    pub mod msm_build {
        /// One `RenderParams` (its world-to-index transform).
        pub const PARAMS: usize = 0;
        /// One `GridDesc`.
        pub const DESC: usize = 1;
        /// The packed voxels (`u32` words).
        pub const VOXELS: usize = 2;
        /// The bricks (`Brick`).
        pub const BRICKS: usize = 3;
        /// One `Lighting` (the map's frame).
        pub const LIGHTING: usize = 4;
        /// b_1 .. b_6 per texel (`f32`), written.
        pub const RAW: usize = 5;
        /// Pages 1 .. 7 of the voxel pool (`VOXELS` is page 0; see `volume::pages`).
        pub const VOXEL_PAGES: usize = 6;
        /// The voxel pool's page 0 as a uniform texel buffer of `u32` words (`volume::texels`).
        pub const POOL_TEXELS: usize = 13;
        /// The brick table as a uniform texel buffer of `u32` words.
        pub const BRICK_TEXELS: usize = 14;
        /// Number of bindings.
        pub const COUNT: usize = 15;
    }

    /// `msm_store_cs`: each texel prefiltered and stored in the map's format.
    pub mod msm_store {
        /// One `Lighting` (the map's frame and storage).
        pub const LIGHTING: usize = 0;
        /// b_1 .. b_6 per texel (`f32`), read.
        pub const RAW: usize = 1;
        /// The stored map (`u32` words), written.
        pub const MAP: usize = 2;
        /// Number of bindings.
        pub const COUNT: usize = 3;
    }

    /// `path_cs`: one step of a `path` image: the same layout as `direct_cs`, with `PathState`s
    /// as the states.
    pub mod path {
        pub use super::direct::*;
    }

    /// `restir_cs`: one stage of a `restir` image: the same layout as `direct_cs`, with
    /// `RestirState`s as the states.
    pub mod restir {
        pub use super::direct::*;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every id of a dispatch is handled by exactly one invocation, for any split of the
    /// workgroups into ranges, whole or partial last workgroup, and the ranges handle
    /// neighbouring runs: range p's k-th workgroup the run k * parts + p.
    #[test]
    fn every_id_once_for_every_interleave() {
        for (offset, n) in [
            (0u32, 4096u32),
            (10, 290),
            (128, 64 * 7 + 5),
            (5, 1),
            (0, 0),
        ] {
            for parts in [0u32, 1, 2, 3, 4, 7, 16, 32, 64] {
                let launch = Launch {
                    offset,
                    count: offset + n,
                    interleave: parts,
                    ..Launch::default()
                };
                let groups = n.div_ceil(WORKGROUP_SIZE);
                let mut seen = vec![0u32; n as usize];
                for gid in 0..groups * WORKGROUP_SIZE {
                    if let Some(id) = launch.id(gid) {
                        assert!(id >= offset as usize && id < (offset + n) as usize);
                        seen[id - offset as usize] += 1;
                    }
                }
                assert!(
                    seen.iter().all(|&c| c == 1),
                    "offset {offset}, {n} ids, {parts} parts: {seen:?}"
                );
                let per = if parts > 1 { groups / parts } else { 0 };
                for w in 0..groups {
                    let expect = if per > 0 && w < per * parts {
                        (w % per) * parts + w / per
                    } else {
                        w
                    };
                    assert_eq!(interleaved_group(w, groups, parts), expect);
                }
            }
        }
    }

    /// Without an interleave, invocation gid handles id offset + gid, as a plain dispatch.
    #[test]
    fn no_interleave_is_the_plain_mapping() {
        let launch = Launch {
            offset: 100,
            count: 1000,
            ..Launch::default()
        };
        for gid in 0..1024 {
            let want = (gid + 100 < 1000).then_some(gid as usize + 100);
            assert_eq!(launch.id(gid), want);
        }
        // Two threads: the first range's workgroups take the even runs, the second's the odd.
        let two = Launch {
            offset: 0,
            count: 4 * 64,
            interleave: 2,
            ..Launch::default()
        };
        let runs: Vec<usize> = (0..4).map(|w| two.id(w * 64).unwrap() / 64).collect();
        assert_eq!(runs, [0, 2, 1, 3]);
    }
}
