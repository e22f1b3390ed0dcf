//! The camera and the volume's place in the world: world bounds of the grid and of its occupied
//! voxels, the world-to-index transform, the volume's up axis and the pinhole camera framing it.

use crate::volume::{Affine, VolumeData};
use anyhow::Result;
use shared::camera::Camera;
use shared::geometry::{Affine3x4, V3};

/// Axis-aligned world-space bounds of the volume's grid box [0, dims].
pub fn world_bounds(vol: &dyn VolumeData) -> ([f64; 3], [f64; 3]) {
    index_box_to_world(vol, [0; 3], vol.dims())
}

/// Axis-aligned world-space bounds of the voxels with non-zero density (the whole grid if none),
/// so the default camera frames what is visible rather than the grid's padding.
pub fn occupied_world_bounds(vol: &dyn VolumeData) -> ([f64; 3], [f64; 3]) {
    match vol.occupied_box() {
        Some((lo, hi)) => index_box_to_world(vol, lo, hi),
        None => world_bounds(vol),
    }
}

/// World bounds of the index-space box [lo, hi].
fn index_box_to_world(
    vol: &dyn VolumeData,
    lo_i: [u32; 3],
    hi_i: [u32; 3],
) -> ([f64; 3], [f64; 3]) {
    let m = vol.index_to_world().0;
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for c in 0..8 {
        let p = [0, 1, 2].map(|a| {
            if c >> a & 1 == 1 {
                hi_i[a] as f64
            } else {
                lo_i[a] as f64
            }
        });
        for r in 0..3 {
            let w = m[r][0] as f64 * p[0]
                + m[r][1] as f64 * p[1]
                + m[r][2] as f64 * p[2]
                + m[r][3] as f64;
            lo[r] = lo[r].min(w);
            hi[r] = hi[r].max(w);
        }
    }
    (lo, hi)
}

/// Inverse of an index-to-world affine map, computed in f64; errors if it is singular.
pub fn world_to_index(a: &Affine) -> Result<Affine3x4> {
    let m = a.0.map(|r| r.map(|v| v as f64));
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    anyhow::ensure!(
        det.abs() > 1e-30 && det.is_finite(),
        "the volume's index-to-world transform is singular"
    );
    let inv = [
        [
            (m[1][1] * m[2][2] - m[1][2] * m[2][1]) / det,
            (m[0][2] * m[2][1] - m[0][1] * m[2][2]) / det,
            (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / det,
        ],
        [
            (m[1][2] * m[2][0] - m[1][0] * m[2][2]) / det,
            (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / det,
            (m[0][2] * m[1][0] - m[0][0] * m[1][2]) / det,
        ],
        [
            (m[1][0] * m[2][1] - m[1][1] * m[2][0]) / det,
            (m[0][1] * m[2][0] - m[0][0] * m[2][1]) / det,
            (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / det,
        ],
    ];
    let t = [m[0][3], m[1][3], m[2][3]];
    let rows = [0, 1, 2].map(|r| {
        let tr = -(inv[r][0] * t[0] + inv[r][1] * t[1] + inv[r][2] * t[2]);
        [
            inv[r][0] as f32,
            inv[r][1] as f32,
            inv[r][2] as f32,
            tr as f32,
        ]
    });
    Ok(Affine3x4 { rows })
}

/// Where the camera is and what it sees.
#[derive(Clone, Copy, Debug)]
pub struct CameraSpec {
    /// Eye position in world space; `None` = in front of the volume, slightly above.
    pub position: Option<[f32; 3]>,
    /// Point looked at; `None` = the volume's center.
    pub look_at: Option<[f32; 3]>,
    /// Vertical field of view in degrees.
    pub fov_deg: f32,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}
fn v3(a: [f64; 3]) -> V3 {
    V3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

/// Which axis of a volume file points up. The renderer's world is y-up (camera framing, the
/// sky, the ground); `--up z` (Blender, Houdini caches) and `--up x` rotate the volume so that
/// its up axis becomes +y, right-handed and exactly (a signed permutation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum UpAxis {
    X,
    #[default]
    Y,
    Z,
}

impl UpAxis {
    /// The rotation taking this axis to +y, as rows: z-up (x, y, z) -> (x, z, -y); x-up
    /// (x, y, z) -> (-y, x, z).
    pub fn rotation(self) -> [[f32; 3]; 3] {
        match self {
            UpAxis::Y => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            UpAxis::Z => [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]],
            UpAxis::X => [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
        }
    }

    /// `m` (index -> world of the file) followed by [`UpAxis::rotation`]; exact.
    pub fn apply(self, m: &crate::volume::Affine) -> crate::volume::Affine {
        let r = self.rotation();
        let mut out = [[0.0f32; 4]; 3];
        for (i, row) in out.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                // One nonzero term per sum (a signed permutation): no rounding.
                *v = (0..3).map(|k| r[i][k] * m.0[k][j]).sum();
            }
        }
        crate::volume::Affine(out)
    }
}

/// A pinhole camera for a `w` x `h` image; by default it frames the whole volume (y is up).
pub fn make_camera(
    spec: &CameraSpec,
    bounds: ([f64; 3], [f64; 3]),
    w: u32,
    h: u32,
) -> Result<Camera> {
    let (lo, hi) = bounds;
    let center = [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]));
    let radius = 0.5 * sub(hi, lo).iter().map(|v| v * v).sum::<f64>().sqrt();
    let fov = (spec.fov_deg as f64).to_radians();
    anyhow::ensure!(
        fov > 0.0 && fov < std::f64::consts::PI,
        "--fov must be in (0, 180) degrees"
    );
    let target = spec.look_at.map(|p| p.map(|v| v as f64)).unwrap_or(center);
    let eye = match spec.position {
        Some(p) => p.map(|v| v as f64),
        None => {
            // 0.8: the bounding sphere is loose; its corners are rarely occupied.
            let dist = 0.8 * radius / (0.5 * fov).sin();
            let dir = normalize([0.35, 0.25, -1.0]);
            [0, 1, 2].map(|a| center[a] + dir[a] * dist)
        }
    };
    let fwd = sub(target, eye);
    anyhow::ensure!(
        fwd.iter().any(|v| *v != 0.0),
        "--camera and --look-at must differ"
    );
    let fwd = normalize(fwd);
    let mut right = cross(fwd, [0.0, 1.0, 0.0]);
    if right.iter().map(|v| v * v).sum::<f64>() < 1e-12 {
        right = cross(fwd, [0.0, 0.0, 1.0]);
    }
    let right = normalize(right);
    let up = cross(right, fwd);
    let th = (0.5 * fov).tan();
    let aspect = w as f64 / h as f64;
    Ok(Camera {
        origin: v3(eye),
        forward: v3(fwd),
        right: v3(right.map(|v| v * th * aspect)),
        up: v3(up.map(|v| v * th)),
        ..Default::default()
    })
}

#[cfg(test)]
mod up_tests {
    use super::UpAxis;
    use crate::volume::Affine;

    /// Each rotation is orthonormal with determinant 1 and takes its axis to +y.
    #[test]
    fn up_rotations_are_proper_and_take_their_axis_up() {
        for (up, axis) in [(UpAxis::X, 0), (UpAxis::Y, 1), (UpAxis::Z, 2)] {
            let r = up.rotation();
            let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
                - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
                + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
            assert_eq!(det, 1.0, "{up:?}");
            for i in 0..3 {
                for j in 0..3 {
                    let dot: f32 = (0..3).map(|k| r[i][k] * r[j][k]).sum();
                    assert_eq!(dot, if i == j { 1.0 } else { 0.0 }, "{up:?}");
                }
            }
            let image: Vec<f32> = (0..3).map(|i| r[i][axis]).collect();
            assert_eq!(image, [0.0, 1.0, 0.0], "{up:?} takes its axis to {image:?}");
        }
    }

    /// A z-up volume's voxel (0, 0, 5) of size 2 at translation (1, 2, 3) lands at world
    /// (1, 13, -2): its height becomes y, exactly.
    #[test]
    fn z_up_moves_a_voxel_exactly() {
        let m = UpAxis::Z.apply(&Affine::scale_translate([2.0; 3], [1.0, 2.0, 3.0]));
        let p = [0.0f32, 0.0, 5.0];
        let w: Vec<f32> = (0..3)
            .map(|i| (0..3).map(|k| m.0[i][k] * p[k]).sum::<f32>() + m.0[i][3])
            .collect();
        assert_eq!(w, [1.0, 13.0, -2.0]);
    }
}
