//! The extra layers a render can write into its EXR beside the image (`--layers`): per-pixel
//! statistics from the sums every sample adds, all linear, one channel each.

use shared::kernels::render::PixelOut;

/// One extra EXR layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layer {
    /// Standard error of the pixel's mean (of the transmittance, or of the radiance's
    /// luminance): sqrt((mean of squares - squared mean) / (spp - 1)); needs spp >= 2.
    StdErr,
    /// Samples of the pixel (spp).
    Samples,
    /// Mean high-resolution lookups per sample.
    Lookups,
    /// Transmittance of the pixel's camera rays through the volume (1 - alpha), by the render's
    /// estimator: the image itself for a transmittance render; for an integrator render, a
    /// second render of the same camera rays (same seed, same pixel jitter) without the
    /// integrator.
    CameraTransmittance,
}

impl Layer {
    /// The layer's name in the EXR.
    pub fn name(self) -> &'static str {
        match self {
            Layer::StdErr => "stderr",
            Layer::Samples => "samples",
            Layer::Lookups => "lookups",
            Layer::CameraTransmittance => "camera-transmittance",
        }
    }

    /// The layer's values, row-major; `camera` is the camera rays' transmittance render of an
    /// integrator render (None: `pixels` is a transmittance render).
    pub fn values(self, pixels: &[PixelOut], spp: u32, camera: Option<&[PixelOut]>) -> Vec<f32> {
        let pixels = match (self, camera) {
            (Layer::CameraTransmittance, Some(camera)) => camera,
            _ => pixels,
        };
        pixels
            .iter()
            .map(|p| match self {
                Layer::StdErr => {
                    let (m, m2) = (p.t_mean as f64, p.t2_mean as f64);
                    let n = spp.max(2) as f64;
                    ((m2 - m * m).max(0.0) / (n - 1.0)).sqrt() as f32
                }
                Layer::Samples => spp as f32,
                Layer::Lookups => (p.samples as f64 / spp.max(1) as f64) as f32,
                Layer::CameraTransmittance => p.t_mean,
            })
            .collect()
    }
}

/// Refuses layers the render cannot give: a standard error needs two samples per pixel.
pub fn check(layers: &[Layer], spp: u32) -> anyhow::Result<()> {
    anyhow::ensure!(
        !(layers.contains(&Layer::StdErr) && spp < 2),
        "--layers stderr needs at least 2 samples per pixel (the standard error of one sample \
         is undefined); raise --spp or drop stderr"
    );
    Ok(())
}
