//! The viewer's camera: an eye orbiting a target (orbit, pan, dolly with the mouse) or flying
//! with it (WASD), held as the two points `host render` takes (`--camera`, `--look-at`), in
//! f32 as a scene file stores them, so that a saved view renders the same rays.

/// Eye and target in world space, and the vertical field of view in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    pub eye: [f32; 3],
    pub target: [f32; 3],
    pub fov_deg: f32,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn len(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

fn f64s(a: [f32; 3]) -> [f64; 3] {
    a.map(f64::from)
}

fn f32s(a: [f64; 3]) -> [f32; 3] {
    a.map(|v| v as f32)
}

impl OrbitCamera {
    /// The offset of the eye from the target as (distance, yaw, pitch): yaw about +y from +z,
    /// pitch above the horizontal plane (the renderer's world is y-up).
    fn spherical(&self) -> (f64, f64, f64) {
        let d = sub(f64s(self.eye), f64s(self.target));
        let r = len(d).max(1e-6);
        let pitch = (d[1] / r).clamp(-1.0, 1.0).asin();
        let yaw = d[0].atan2(d[2]);
        (r, yaw, pitch)
    }

    fn set_spherical(&mut self, r: f64, yaw: f64, pitch: f64) {
        let t = f64s(self.target);
        let (sy, cy) = yaw.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        self.eye = f32s([t[0] + r * cp * sy, t[1] + r * sp, t[2] + r * cp * cy]);
    }

    /// Turns the eye about the target by `dx`, `dy` radians (yaw, pitch); the pitch stays
    /// short of the poles, where the y-up camera has no right vector.
    pub fn orbit(&mut self, dx: f64, dy: f64) {
        let (r, yaw, pitch) = self.spherical();
        let limit = 89f64.to_radians();
        self.set_spherical(r, yaw - dx, (pitch + dy).clamp(-limit, limit));
    }

    /// Moves the eye toward the target by the factor `f` of its distance (f < 1: closer).
    pub fn dolly(&mut self, f: f64) {
        let (r, yaw, pitch) = self.spherical();
        self.set_spherical((r * f).max(1e-3), yaw, pitch);
    }

    /// The camera's unit forward, right and up vectors (as `make_camera` builds them).
    fn frame(&self) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let f = sub(f64s(self.target), f64s(self.eye));
        let l = len(f).max(1e-12);
        let f = f.map(|v| v / l);
        let mut r = [-f[2], 0.0, f[0]];
        let lr = len(r);
        if lr < 1e-9 {
            r = [1.0, 0.0, 0.0];
        } else {
            r = r.map(|v| v / lr);
        }
        let u = [
            r[1] * f[2] - r[2] * f[1],
            r[2] * f[0] - r[0] * f[2],
            r[0] * f[1] - r[1] * f[0],
        ];
        (f, r, u)
    }

    /// Moves eye and target together by `right`, `up` and `forward` times the eye's distance
    /// from the target (pan with the mouse, fly with the keys).
    pub fn translate(&mut self, right: f64, up: f64, forward: f64) {
        let (r_len, _, _) = self.spherical();
        let (f, r, u) = self.frame();
        let d: [f64; 3] =
            std::array::from_fn(|i| (r[i] * right + u[i] * up + f[i] * forward) * r_len);
        self.eye = f32s(std::array::from_fn(|i| f64::from(self.eye[i]) + d[i]));
        self.target = f32s(std::array::from_fn(|i| f64::from(self.target[i]) + d[i]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> OrbitCamera {
        OrbitCamera {
            eye: [0.0, 0.0, 10.0],
            target: [0.0, 0.0, 0.0],
            fov_deg: 40.0,
        }
    }

    /// Orbiting keeps the distance to the target; a full turn comes back.
    #[test]
    fn orbit_keeps_the_distance_and_turns_back() {
        let mut c = cam();
        c.orbit(0.3, 0.2);
        let d = len(sub(f64s(c.eye), f64s(c.target)));
        assert!((d - 10.0).abs() < 1e-4, "{d}");
        c.orbit(-0.3, -0.2);
        for i in 0..3 {
            assert!((c.eye[i] - cam().eye[i]).abs() < 1e-4, "{:?}", c.eye);
        }
    }

    /// The pitch stops short of the pole.
    #[test]
    fn orbit_stops_short_of_the_pole() {
        let mut c = cam();
        c.orbit(0.0, 10.0);
        let (_, _, pitch) = c.spherical();
        assert!(pitch < 89.5f64.to_radians(), "{pitch}");
    }

    /// Dolly scales the distance; translating moves eye and target by the same vector.
    #[test]
    fn dolly_and_translate() {
        let mut c = cam();
        c.dolly(0.5);
        assert!((c.eye[2] - 5.0).abs() < 1e-5, "{:?}", c.eye);
        let before = c;
        c.translate(0.1, 0.0, 0.0);
        let de: Vec<f32> = (0..3).map(|i| c.eye[i] - before.eye[i]).collect();
        let dt: Vec<f32> = (0..3).map(|i| c.target[i] - before.target[i]).collect();
        assert_eq!(de, dt);
        assert!(de[0].abs() > 0.4, "{de:?}");
    }
}
