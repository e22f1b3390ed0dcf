//! Super-voxel reads per camera ray: what adaptive super-voxels cost besides the N lookups,
//! measured on the CPU by one traversal of each pixel-centre camera ray (Alg. 2 takes one such
//! traversal, Alg. 1 a second up to its last sample, delta and ratio tracking one up to their
//! last collision), for the grid as built and for its bricks alone.

use crate::scene::bricks::PackedVolume;
use rayon::prelude::*;
use shared::geometry::{to_index_space, V3};
use shared::params::RenderParams;
use shared::volume::dda::{clip_to_box, GridDda};
use shared::volume::supervoxels::SuperVoxelDda;

/// Mean iterations of one traversal per camera ray that meets the grid.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReadsPerRay {
    /// Super-voxels (bricks, skipped spans and cells of subdivided bricks).
    pub supervoxels: f64,
    /// Bricks and skipped spans only (the fixed grid's traversal of the same bricks).
    pub bricks: f64,
}

/// [`ReadsPerRay`] over the `params.width` x `params.height` pixel-centre rays of its camera.
pub fn reads_per_ray(packed: &PackedVolume, params: &RenderParams) -> ReadsPerRay {
    let vol = packed.view();
    let d = packed.desc.dims;
    let hi = V3::new(d[0] as f32, d[1] as f32, d[2] as f32);
    let (w, h) = (params.width, params.height);
    let (rays, cells, bricks) = (0..w * h)
        .into_par_iter()
        .map(|id| {
            let world = params.camera.world_ray(id % w, id / w, 0.5, 0.5, w, h);
            let ray = to_index_space(&world, &params.world_to_index);
            let (t0, t1) = clip_to_box(&ray, hi, 0.0, f32::INFINITY);
            if !(t0 < t1) {
                return (0u64, 0u64, 0u64);
            }
            let mut sv = SuperVoxelDda::new(&packed.desc, &ray, t0, t1);
            let mut n = 0u64;
            while !sv.done() {
                sv.step(&vol);
                n += 1;
            }
            let mut b = GridDda::bricks(&packed.desc, &ray, t0, t1);
            let mut m = 0u64;
            while !b.done() {
                b.step_brick(&vol);
                m += 1;
            }
            (1, n, m)
        })
        .reduce(|| (0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
    let per = |v: u64| {
        if rays == 0 {
            0.0
        } else {
            v as f64 / rays as f64
        }
    };
    ReadsPerRay {
        supervoxels: per(cells),
        bricks: per(bricks),
    }
}
