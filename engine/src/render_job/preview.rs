//! How a render's pixels look in its PNG preview and in `host view`'s window: one tone map for
//! both, so the window shows what the PNG holds.

use shared::kernels::render::PixelOut;
use shared::params::Integrator;

/// The preview's tone map of a render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Preview {
    /// Transmittance: T in [0, 1], sRGB, grey.
    Transmittance,
    /// Single scattering: exposure, then Reinhard x / (1 + x) so highlights do not clip, sRGB,
    /// grey (the luminance channel).
    Reinhard(f32),
    /// RGB radiance (`direct`, `path`, `restir`): exposure, clamped to [0, 1], sRGB per channel.
    Rgb(f32),
}

impl Preview {
    /// The preview of a render with `integrator` at `exposure`.
    pub fn of(integrator: Option<Integrator>, exposure: f32) -> Self {
        match integrator {
            None => Preview::Transmittance,
            Some(i) if i.is_lit() => Preview::Rgb(exposure),
            Some(_) => Preview::Reinhard(exposure),
        }
    }

    /// The linear grey value (in [0, 1] before clamping) of a grey preview's pixel of value
    /// `t` (the RGB preview: `t` times the exposure).
    pub fn grey(self, t: f32) -> f32 {
        match self {
            Preview::Transmittance => t,
            Preview::Reinhard(e) => {
                let x = t * e;
                x / (1.0 + x)
            }
            Preview::Rgb(e) => t * e,
        }
    }

    /// The sRGB bytes of pixel `p`.
    pub fn rgb8(self, p: &PixelOut) -> [u8; 3] {
        use crate::output::srgb8;
        match self {
            Preview::Rgb(e) => [p.rgb_mean.r, p.rgb_mean.g, p.rgb_mean.b].map(|v| srgb8(v * e)),
            grey => [srgb8(grey.grey(p.t_mean)); 3],
        }
    }
}
