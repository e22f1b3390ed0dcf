//! The extra layers a render can write into its EXR beside the image (`--layers`): per-pixel
//! statistics from the sums every sample adds, all linear, one channel each.

use crate::output::LayerValues;
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
    /// The medium's albedo seen through the pixel (RGB): the albedo times the camera rays'
    /// opacity, albedo x (1 - T) with T as in `CameraTransmittance`; with the radiance, the
    /// colour and albedo inputs of a denoiser. Integrator renders only.
    Albedo,
    /// The mean distance from the camera of the camera rays' first collision in the medium
    /// (world units), over the samples that collide (0 where none does): a pass of delta
    /// tracking along the same rays; for an integrator render, where a path's first vertex
    /// lies.
    Depth,
}

impl Layer {
    /// The layer's name in the EXR.
    pub fn name(self) -> &'static str {
        match self {
            Layer::StdErr => "stderr",
            Layer::Samples => "samples",
            Layer::Lookups => "lookups",
            Layer::CameraTransmittance => "camera-transmittance",
            Layer::Albedo => "albedo",
            Layer::Depth => "depth",
        }
    }

    /// Whether the layer reads the camera rays' transmittance render of an integrator render.
    pub fn needs_camera(self) -> bool {
        matches!(self, Layer::CameraTransmittance | Layer::Albedo)
    }

    /// The layer's values, row-major, from the render `r`.
    pub fn values(self, r: &LayerInputs) -> LayerValues {
        if self == Layer::Depth {
            let depth = r.depth.unwrap_or(&[]);
            return LayerValues::Y(
                depth
                    .iter()
                    .map(|p| {
                        let hit = p.rgb_mean.g;
                        if hit > 0.0 {
                            p.rgb_mean.r / hit
                        } else {
                            0.0
                        }
                    })
                    .collect(),
            );
        }
        let (spp, albedo) = (r.spp, r.albedo);
        let pixels = match (self.needs_camera(), r.camera) {
            (true, Some(camera)) => camera,
            _ => r.pixels,
        };
        if self == Layer::Albedo {
            return LayerValues::Rgb(
                pixels
                    .iter()
                    .map(|p| albedo.map(|a| a * (1.0 - p.t_mean)))
                    .collect(),
            );
        }
        LayerValues::Y(self.scalars(pixels, spp))
    }

    /// The values of a one-channel layer.
    fn scalars(self, pixels: &[PixelOut], spp: u32) -> Vec<f32> {
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
                Layer::CameraTransmittance | Layer::Albedo | Layer::Depth => p.t_mean,
            })
            .collect()
    }
}

/// What the layers are made of: the render's pixels and samples per pixel, the camera rays'
/// transmittance render of an integrator render (None: `pixels` is a transmittance render), the
/// first-collision pass (`depth`), and the medium's albedo.
pub struct LayerInputs<'a> {
    pub pixels: &'a [PixelOut],
    pub spp: u32,
    pub camera: Option<&'a [PixelOut]>,
    pub depth: Option<&'a [PixelOut]>,
    pub albedo: [f32; 3],
}

/// The sampler of a render whose command line names none: sobol (stratified, less noise per
/// sample), or independent where `layers` ask for a standard error (which needs independent
/// samples of each pixel).
pub fn default_sampler(layers: &[Layer]) -> shared::params::Sampler {
    if layers.contains(&Layer::StdErr) {
        shared::params::Sampler::Independent
    } else {
        shared::params::Sampler::Sobol
    }
}

/// Refuses layers the render cannot give: a standard error needs two independent samples per
/// pixel, an albedo a medium that scatters (an integrator render).
pub fn check(
    layers: &[Layer],
    spp: u32,
    integrator: bool,
    sampler: shared::params::Sampler,
) -> anyhow::Result<()> {
    for (k, layer) in layers.iter().enumerate() {
        anyhow::ensure!(
            !layers[..k].contains(layer),
            "--layers: {} is named twice; name each layer once",
            layer.name()
        );
    }
    anyhow::ensure!(
        !(layers.contains(&Layer::StdErr) && spp < 2),
        "--layers stderr needs at least 2 samples per pixel (the standard error of one sample \
         is undefined); raise --spp or drop stderr"
    );
    anyhow::ensure!(
        !(layers.contains(&Layer::StdErr) && sampler != shared::params::Sampler::Independent),
        "--layers stderr needs --sampler independent: stratified (sobol) samples of a pixel \
         are not independent, so their sample variance does not give the mean's standard error"
    );
    anyhow::ensure!(
        !(layers.contains(&Layer::Albedo) && !integrator),
        "--layers albedo needs --integrator: a transmittance render has no scattering albedo; \
         drop albedo or render radiance"
    );
    Ok(())
}
