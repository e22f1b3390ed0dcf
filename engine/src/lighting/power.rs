//! The power alias table over the point lights (Walker 1977; Vose 1991's stable construction):
//! what `shared::sampling::lights::sample_power` draws from.

use shared::sampling::lights::PointLight;

/// Fills `inv_pmf`, `alias_prob` and `alias` of every light for selection proportional to its
/// intensity (the tint has luminance 1). Computed in f64: with equal intensities every column
/// keeps its own light and 1 / pmf is exactly the light count, so the draw is the uniform one.
/// Lights of zero intensity are never drawn; if all are zero the table is uniform (their share
/// of the pmf over light kinds is then 0 and it is never read).
pub fn build_power_table(lights: &mut [PointLight]) {
    let n = lights.len();
    if n == 0 {
        return;
    }
    let w: Vec<f64> = lights.iter().map(|l| l.intensity.max(0.0) as f64).collect();
    let total: f64 = w.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        for (k, l) in lights.iter_mut().enumerate() {
            l.inv_pmf = n as f32;
            l.alias_prob = 1.0;
            l.alias = k as u32;
        }
        return;
    }
    // Scaled weights: mean 1.
    let mut scaled: Vec<f64> = w.iter().map(|x| x * n as f64 / total).collect();
    let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&k| scaled[k] < 1.0);
    let mut prob = vec![1.0f64; n];
    let mut alias: Vec<u32> = (0..n as u32).collect();
    while let (Some(s), Some(&g)) = (small.pop(), large.last()) {
        prob[s] = scaled[s];
        alias[s] = g as u32;
        scaled[g] = (scaled[g] + scaled[s]) - 1.0;
        if scaled[g] < 1.0 {
            large.pop();
            small.push(g);
        }
    }
    // What is left (round-off) keeps its own column.
    for (k, l) in lights.iter_mut().enumerate() {
        l.inv_pmf = if w[k] > 0.0 {
            (total / w[k]) as f32
        } else {
            f32::INFINITY
        };
        l.alias_prob = prob[k] as f32;
        l.alias = alias[k];
    }
}

/// The probability with which the table draws each light, by summing over its columns (for tests
/// and the JSON).
pub fn table_pmf(lights: &[PointLight]) -> Vec<f64> {
    let n = lights.len();
    let mut p = vec![0.0f64; n];
    for (k, l) in lights.iter().enumerate() {
        let keep = (l.alias_prob as f64).clamp(0.0, 1.0);
        p[k] += keep / n as f64;
        let a = (l.alias as usize).min(n - 1);
        p[a] += (1.0 - keep) / n as f64;
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::geometry::V3;
    use shared::sampling::lights::sample_power;

    fn lights(intensities: &[f32]) -> Vec<PointLight> {
        let mut l: Vec<PointLight> = intensities
            .iter()
            .map(|&i| PointLight::new(V3::new(0.0, 0.0, 0.0), i))
            .collect();
        build_power_table(&mut l);
        l
    }

    #[test]
    fn table_draws_by_power() {
        let i = [1.0, 1000.0, 0.0, 3.5, 0.01, 42.0, 7.0];
        let l = lights(&i);
        let total: f64 = i.iter().map(|&x| x as f64).sum();
        for (k, p) in table_pmf(&l).iter().enumerate() {
            let want = i[k] as f64 / total;
            assert!((p - want).abs() < 1e-6, "light {k}: {p} vs {want}");
            if i[k] > 0.0 {
                let inv = l[k].inv_pmf as f64;
                assert!((inv * want - 1.0).abs() < 1e-6, "1/pmf of light {k}");
            }
        }
        // And the shared draw on a fine grid of (u0, u1) reproduces the pmf.
        let g = 512;
        let mut count = vec![0u32; i.len()];
        for a in 0..g {
            for b in 0..g {
                let (u0, u1) = ((a as f32 + 0.5) / g as f32, (b as f32 + 0.5) / g as f32);
                let (k, inv) = sample_power(&l, l.len() as u32, u0, u1);
                assert_eq!(inv, l[k as usize].inv_pmf);
                count[k as usize] += 1;
            }
        }
        for k in 0..i.len() {
            let f = count[k] as f64 / (g * g) as f64;
            let want = i[k] as f64 / total;
            assert!(
                (f - want).abs() < 3.0 / g as f64,
                "light {k}: {f} vs {want}"
            );
        }
        assert_eq!(count[2], 0, "a light without power is never drawn");
    }

    #[test]
    fn equal_intensities_are_the_uniform_draw() {
        for n in [1usize, 2, 3, 7, 16, 100] {
            let l = lights(&vec![0.37; n]);
            for (k, x) in l.iter().enumerate() {
                assert_eq!(x.inv_pmf, n as f32);
                assert_eq!(x.alias_prob, 1.0);
                assert_eq!(x.alias, k as u32);
            }
            for j in 0..1000 {
                let u0 = j as f32 / 1000.0;
                let k = ((u0 * n as f32) as u32).min(n as u32 - 1);
                assert_eq!(sample_power(&l, n as u32, u0, 0.999).0, k);
            }
        }
    }
}
