//! `--lights random:N[,seed]`: N point lights scattered in and around the volume, of varied
//! colour and of intensities over three orders of magnitude (many-light scenes, issue 19).

use anyhow::{ensure, Result};
use shared::geometry::V3;
use shared::rgb::Rgb;
use shared::sampling::lights::PointLight;

/// Most point lights of a scene (48 bytes each: 48 MiB at the limit).
pub const MAX_POINT_LIGHTS: usize = 1 << 20;

/// `random:N[,seed]` as given on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RandomLights {
    pub count: u32,
    pub seed: u64,
}

impl std::fmt::Display for RandomLights {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "random:{},{}", self.count, self.seed)
    }
}

/// Parses `random:N[,seed]` (seed default 1).
pub fn parse_random_lights(s: &str) -> Result<RandomLights, String> {
    let err = || {
        format!(
            "expected random:N[,seed] with 1 <= N <= {MAX_POINT_LIGHTS} (e.g. random:256 or \
             random:4096,7), got {s:?}"
        )
    };
    let rest = s.trim().strip_prefix("random:").ok_or_else(err)?;
    let mut parts = rest.split(',');
    let count: u32 = parts
        .next()
        .and_then(|p| p.trim().parse().ok())
        .ok_or_else(err)?;
    let seed: u64 = match parts.next() {
        Some(p) => p.trim().parse().map_err(|_| err())?,
        None => 1,
    };
    if parts.next().is_some() || count == 0 || count as usize > MAX_POINT_LIGHTS {
        return Err(err());
    }
    Ok(RandomLights { count, seed })
}

/// SplitMix64 (Steele et al. 2014): the scatter's generator, so a seed gives the same lights
/// everywhere.
struct SplitMix(u64);

impl SplitMix {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The lights of `spec` in the box [lo, hi] widened by 10 % per side: positions uniform,
/// intensities log-uniform over [1e-3, 1] scaled so that they sum to 2.3 size^2 (the two default
/// lights' total; size = mean extent), tints random with luminance 1.
pub fn random_lights(spec: RandomLights, lo: [f64; 3], hi: [f64; 3]) -> Result<Vec<PointLight>> {
    ensure!(
        spec.count as usize <= MAX_POINT_LIGHTS,
        "--lights: at most {MAX_POINT_LIGHTS} lights"
    );
    let mut rng = SplitMix(spec.seed ^ 0x6a09_e667_f3bc_c909);
    let size = (0..3).map(|a| hi[a] - lo[a]).sum::<f64>() / 3.0;
    let raw: Vec<([f64; 3], f64, [f64; 3])> = (0..spec.count)
        .map(|_| {
            let p = [0, 1, 2].map(|a| {
                let margin = 0.1 * (hi[a] - lo[a]);
                lo[a] - margin + rng.next_f64() * (hi[a] - lo[a] + 2.0 * margin)
            });
            let i = 10f64.powf(-3.0 * rng.next_f64());
            let c = [0, 1, 2].map(|_| 0.1 + 0.9 * rng.next_f64());
            (p, i, c)
        })
        .collect();
    let total: f64 = raw.iter().map(|r| r.1).sum();
    let scale = 2.3 * size * size / total;
    let lights: Vec<PointLight> = raw
        .iter()
        .map(|(p, i, c)| {
            let lum = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
            PointLight {
                tint: Rgb::new(
                    (c[0] / lum) as f32,
                    (c[1] / lum) as f32,
                    (c[2] / lum) as f32,
                ),
                ..PointLight::new(
                    V3::new(p[0] as f32, p[1] as f32, p[2] as f32),
                    (i * scale) as f32,
                )
            }
        })
        .collect();
    ensure!(
        lights
            .iter()
            .all(|l| l.intensity.is_finite() && l.position.x.is_finite()),
        "--lights {spec}: the volume's bounds give lights beyond f32"
    );
    Ok(lights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_refuses() {
        assert_eq!(
            parse_random_lights("random:256").unwrap(),
            RandomLights {
                count: 256,
                seed: 1
            }
        );
        assert_eq!(parse_random_lights("random:4096,7").unwrap().seed, 7);
        for bad in [
            "random:0",
            "random:",
            "rand:5",
            "random:5,x",
            "random:5,1,2",
            "random:-3",
            "random:99999999",
        ] {
            let e = parse_random_lights(bad).unwrap_err();
            assert!(e.contains("random:N"), "{bad}: {e}");
        }
    }

    #[test]
    fn seeded_scatter() {
        let spec = RandomLights {
            count: 500,
            seed: 3,
        };
        let a = random_lights(spec, [0.0; 3], [2.0, 1.0, 1.0]).unwrap();
        assert_eq!(a, random_lights(spec, [0.0; 3], [2.0, 1.0, 1.0]).unwrap());
        let b = random_lights(RandomLights { seed: 4, ..spec }, [0.0; 3], [2.0, 1.0, 1.0]);
        assert_ne!(a, b.unwrap());
        let total: f64 = a.iter().map(|l| l.intensity as f64).sum();
        let size = 4.0 / 3.0;
        assert!((total / (2.3 * size * size) - 1.0).abs() < 1e-5);
        let (min, max) = a.iter().fold((f32::MAX, 0f32), |(lo, hi), l| {
            (lo.min(l.intensity), hi.max(l.intensity))
        });
        assert!(max / min > 100.0 && max / min <= 1000.0, "{min} {max}");
        for l in &a {
            assert!((l.tint.luminance() - 1.0).abs() < 1e-5);
            assert!(l.position.x >= -0.2 && l.position.x <= 2.2);
        }
    }
}
