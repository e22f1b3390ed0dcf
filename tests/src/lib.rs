//! Helpers for the integration tests: opening the lavapipe GPU, comparing buffers bit for bit,
//! building test volumes and their cameras.

use bytemuck::Pod;
use engine::backend::gpu::Gpu;
use engine::scene::camera::{make_camera, world_bounds, world_to_index, CameraSpec};
use engine::volume::{Affine, DenseVolume};
use shared::params::RenderParams;
use std::fmt::Debug;
use std::sync::{Arc, OnceLock};

/// The Vulkan GPU, or a panic that says how to get one (these tests must run, not skip). One
/// device per test binary, shared by its tests, so each kernel's pipeline is built once per
/// binary: lavapipe takes 15-30 s to build a large kernel's pipeline (about 100 s with an empty
/// shader cache, as on a fresh CI machine).
pub fn gpu() -> Arc<Gpu> {
    static GPU: OnceLock<Arc<Gpu>> = OnceLock::new();
    GPU.get_or_init(|| match Gpu::new() {
        Ok(g) => Arc::new(g),
        Err(e) => panic!(
            "GPU-vs-CPU tests need a Vulkan device: {e}. Install lavapipe with \
             `sudo apt-get install -y mesa-vulkan-drivers libvulkan1` (./scripts/test.sh does this)."
        ),
    })
    .clone()
}

/// Asserts that two output buffers are byte-identical; on mismatch prints the first rows that
/// differ with their input, both values and both values' bytes, and the mismatch count.
pub fn assert_bytes_equal<I: Debug, O: Pod + Debug>(
    what: &str,
    inputs: &[I],
    gpu: &[O],
    cpu: &[O],
) {
    assert_eq!(gpu.len(), cpu.len(), "{what}: output lengths differ");
    let size = std::mem::size_of::<O>();
    let g: &[u8] = bytemuck::cast_slice(gpu);
    let c: &[u8] = bytemuck::cast_slice(cpu);
    if g == c {
        return;
    }
    let bad: Vec<usize> = (0..gpu.len())
        .filter(|&i| g[i * size..(i + 1) * size] != c[i * size..(i + 1) * size])
        .collect();
    if let Ok(f) = std::env::var("JK_DUMP_MISMATCH") {
        let lines: Vec<String> = bad
            .iter()
            .map(|&i| format!("{:?}", inputs.get(i)))
            .collect();
        std::fs::write(f, lines.join("\n")).unwrap();
    }
    let mut msg = format!(
        "{what}: {} of {} outputs differ between GPU and CPU\n",
        bad.len(),
        gpu.len()
    );
    for &i in bad.iter().take(10) {
        msg += &format!(
            "  [{i}] input {:?}\n      gpu {:?} bytes {:02x?}\n      cpu {:?} bytes {:02x?}\n",
            inputs.get(i),
            gpu[i],
            &g[i * size..(i + 1) * size],
            cpu[i],
            &c[i * size..(i + 1) * size]
        );
    }
    panic!("{msg}");
}

/// Mean and standard error of the mean of `xs` (sample variance with n - 1).
pub fn mean_se(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let m = xs.iter().sum::<f64>() / n;
    let v = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (v / n).sqrt())
}

/// The two point lights of the single-scattering tests, inside the [-1, 1]^3 test volumes.
pub fn test_lights() -> Vec<shared::sampling::lights::PointLight> {
    use shared::geometry::V3;
    use shared::sampling::lights::PointLight;
    vec![
        PointLight::new(V3::new(-0.3, 0.1, 0.0), 1.0),
        PointLight::new(V3::new(0.4, -0.2, 0.3), 0.5),
    ]
}

/// A test volume of `dims` voxels with density `f(x, y, z)` (x fastest) and the given map.
pub fn volume(
    name: &str,
    dims: [u32; 3],
    index_to_world: Affine,
    f: impl Fn(u32, u32, u32) -> f32,
) -> DenseVolume {
    let mut v = Vec::with_capacity((dims[0] * dims[1] * dims[2]) as usize);
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                v.push(f(x, y, z));
            }
        }
    }
    DenseVolume::new(name, dims, v, index_to_world).unwrap()
}

/// The index-to-world map of an n^3 grid spanning [-1, 1]^3.
pub fn unit_cube(n: u32) -> Affine {
    Affine::scale_translate([2.0 / n as f32; 3], [-1.0; 3])
}

/// Render parameters of a w x h image of `vol` from the default camera (40 degree field of
/// view); every other parameter is its default.
pub fn camera_params(vol: &DenseVolume, w: u32, h: u32) -> RenderParams {
    let spec = CameraSpec {
        position: None,
        look_at: None,
        fov_deg: 40.0,
    };
    RenderParams {
        camera: make_camera(&spec, world_bounds(vol), w, h).unwrap(),
        world_to_index: world_to_index(&vol.index_to_world).unwrap(),
        width: w,
        height: h,
        ..Default::default()
    }
}

/// A lumpy n^3 volume in [-1, 1]^3: blobs of `cell`^3 voxels, two in three occupied (hashed),
/// each with density 0.5 to 2.5 (deterministic).
pub fn lumpy_blobs(n: u32, cell: u32) -> DenseVolume {
    use shared::rng::{pcg_hash, unit_f32};
    volume("lumpy", [n; 3], unit_cube(n), |x, y, z| {
        let c = pcg_hash(x / cell + 101 * (y / cell) + 10007 * (z / cell));
        let fine = unit_f32(pcg_hash(x + n * (y + n * z)));
        if c.is_multiple_of(3) {
            0.0
        } else {
            0.5 + 2.0 * fine * unit_f32(c)
        }
    })
}

/// A 24^3 volume in [-1, 1]^3 with empty blocks, thin wisps and dense cores (the density
/// sweep's and the loop-budget tests' volume).
pub fn lumpy_cells() -> DenseVolume {
    use shared::rng::{pcg_hash, unit_f32};
    let n = 24u32;
    volume("lumpy", [n; 3], unit_cube(n), |x, y, z| {
        let cell = pcg_hash(x / 4 + 101 * (y / 4) + 10007 * (z / 4));
        let fine = unit_f32(pcg_hash(x + n * (y + n * z)));
        match cell % 4 {
            0 => 0.0,
            1 => 0.02 * fine,
            _ => 0.25 + fine,
        }
    })
}

/// `count` random lights around [-1, 1]^3 (seed 9), plus the sky and its sun if `sky`;
/// resampled for `restir` if `restir`.
pub fn many_lights(count: u32, sky: bool, restir: bool) -> engine::lighting::SceneLights {
    use engine::lighting::random::{random_lights, RandomLights};
    use engine::lighting::{build, EnvSource, LightingOptions, SunSpec};
    let points = random_lights(RandomLights { count, seed: 9 }, [-1.0; 3], [1.0; 3]).unwrap();
    let mut s = build(
        &LightingOptions {
            env: if sky { EnvSource::Sky } else { EnvSource::None },
            env_scale: 1.0,
            env_rotate_deg: 0.0,
            sun: sky.then_some(SunSpec {
                dir: [0.3, 1.0, -0.2],
                irradiance: Some(2.0),
                radius_deg: 3.0,
            }),
            points,
            albedo: [0.9, 0.7, 0.5],
        },
        [0.0; 3],
        1.7,
    )
    .unwrap();
    if restir {
        s.resample_points();
    }
    s
}

/// The white furnace's lights: albedo 1 and a constant white map (radiance 1 from every
/// direction, no sun or point light), around [-1, 1]^3: every pixel's expected radiance is 1.
pub fn white_furnace() -> engine::lighting::SceneLights {
    use engine::lighting::env::EnvMap;
    use engine::lighting::{build, EnvSource, LightingOptions};
    let mut l = build(
        &LightingOptions {
            env: EnvSource::None,
            env_scale: 1.0,
            env_rotate_deg: 0.0,
            sun: None,
            points: vec![],
            albedo: [1.0; 3],
        },
        [0.0; 3],
        1.7,
    )
    .unwrap();
    let map = EnvMap::constant([1.0, 1.0, 1.0]);
    let (data, _) = map.clone().data(1.0).unwrap();
    l.env = data;
    l.lighting.env = shared::sampling::env::EnvDesc {
        width: map.width,
        height: map.height,
        cos_rotation: 1.0,
        sin_rotation: 0.0,
    };
    l.lighting.p_env = 1.0;
    l
}
