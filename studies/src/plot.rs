//! Plots of the studies with `plotters`: PNG (bitmap backend, encoded by `image`) or SVG, chosen
//! by the file extension. Text uses a font compiled into the binary (Ubuntu Light from
//! `epaint_default_fonts`, rasterised by ab_glyph), so no system font library is needed.

use anyhow::{anyhow, bail, Result};
use plotters::coord::ranged1d::{Ranged, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

pub use plotters::chart::SeriesLabelPosition as Legend;
pub use plotters::style::RGBColor;

/// The font family every text of the plots uses.
pub const FONT: &str = "sans-serif";

/// Colours of the series (matplotlib's tab10).
pub const BLUE: RGBColor = RGBColor(31, 119, 180);
pub const ORANGE: RGBColor = RGBColor(255, 127, 14);
pub const GREEN: RGBColor = RGBColor(44, 160, 44);
pub const RED: RGBColor = RGBColor(214, 39, 40);
pub const PURPLE: RGBColor = RGBColor(148, 103, 189);
pub const GREY: RGBColor = RGBColor(127, 127, 127);
pub const INK: RGBColor = RGBColor(0, 0, 0);

/// plotters errors are generic over the backend; the studies only report them.
pub trait Drawn<T> {
    fn drawn(self) -> Result<T>;
}

impl<T, E: std::fmt::Debug> Drawn<T> for std::result::Result<T, E> {
    fn drawn(self) -> Result<T> {
        self.map_err(|e| anyhow!("plotting: {e:?}"))
    }
}

/// A figure that can draw itself on any backend.
pub trait Figure {
    fn size(&self) -> (u32, u32);
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>;
}

fn register_font() -> Result<()> {
    static ONCE: Once = Once::new();
    let mut result = Ok(());
    ONCE.call_once(|| {
        result = plotters::style::register_font(
            FONT,
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        )
        .map_err(|_| anyhow!("the embedded font does not parse"));
    });
    result
}

/// Refuses a plot path that is neither `.png` nor `.svg` (checked before any work).
pub fn check_format(path: &Path) -> Result<()> {
    match extension(path).as_str() {
        "png" | "svg" => Ok(()),
        _ => bail!("{}: plots are .png or .svg", path.display()),
    }
}

/// The lower-case extension of `path` ("" without one).
fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

/// Draws `figure` into `path`: `.png` or `.svg`.
pub fn save(path: &Path, figure: &impl Figure) -> Result<()> {
    check_format(path)?;
    register_font()?;
    output::ensure_parent(path)?;
    let (w, h) = figure.size();
    let ext = extension(path);
    match ext.as_str() {
        "png" => {
            let mut buf = vec![0u8; w as usize * h as usize * 3];
            {
                let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
                root.fill(&WHITE).drawn()?;
                figure.draw(&root)?;
                root.present().drawn()?;
            }
            write_png(path, &buf, w, h)
        }
        "svg" => {
            let mut text = String::new();
            {
                let root = SVGBackend::with_string(&mut text, (w, h)).into_drawing_area();
                root.fill(&WHITE).drawn()?;
                figure.draw(&root)?;
                root.present().drawn()?;
            }
            output::write_text(path, &text)
        }
        _ => bail!("{}: plots are .png or .svg", path.display()),
    }
}

/// Encodes RGB8 pixels as a PNG with the strongest compression (the docs embed these).
fn write_png(path: &Path, rgb: &[u8], w: u32, h: u32) -> Result<()> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    use image::ImageEncoder;
    // Encoded in memory, then one checked write (`output::write_bytes`).
    let mut png = Vec::new();
    PngEncoder::new_with_quality(&mut png, CompressionType::Best, FilterType::Adaptive)
        .write_image(rgb, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| anyhow::anyhow!("encoding {}: {e}", path.display()))?;
    output::write_bytes(path, &png)
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug)]
pub enum Style {
    Line,
    Dashed,
    /// Circles of this radius in pixels.
    Markers(u32),
    /// Filled bars of this width (in x units) centred on each point, from y = 0.
    Bars(f64),
}

/// A labelled list of points.
#[derive(Clone, Debug)]
pub struct Series {
    pub label: Option<String>,
    pub color: RGBColor,
    pub style: Style,
    pub points: Vec<(f64, f64)>,
}

impl Series {
    pub fn new(label: &str, color: RGBColor, style: Style, points: Vec<(f64, f64)>) -> Self {
        let label = (!label.is_empty()).then(|| label.to_string());
        Series {
            label,
            color,
            style,
            points,
        }
    }
}

/// One chart of x-y series; either axis may be logarithmic.
#[derive(Clone, Debug)]
pub struct LinePanel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub x: (f64, f64),
    pub y: (f64, f64),
    pub log_x: bool,
    pub log_y: bool,
    pub legend: Legend,
    pub series: Vec<Series>,
    /// Category names shown at x = 0, 1, 2, ... instead of numbers (empty: numbers).
    pub x_ticks: Vec<String>,
}

impl LinePanel {
    pub fn new(title: &str, x_label: &str, y_label: &str, x: (f64, f64), y: (f64, f64)) -> Self {
        LinePanel {
            title: title.to_string(),
            x_label: x_label.to_string(),
            y_label: y_label.to_string(),
            x,
            y,
            log_x: false,
            log_y: false,
            legend: Legend::UpperLeft,
            series: Vec::new(),
            x_ticks: Vec::new(),
        }
    }

    /// Draws the panel into `area`.
    pub fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> Result<()> {
        self.check_ranges()?;
        let mut builder = ChartBuilder::on(area);
        builder
            .caption(&self.title, (FONT, 18))
            .margin(8)
            .x_label_area_size(38)
            .y_label_area_size(58);
        let (x, y) = (self.x.0..self.x.1, self.y.0..self.y.1);
        match (self.log_x, self.log_y) {
            (false, false) => self.fill(&mut builder.build_cartesian_2d(x, y).drawn()?),
            (true, false) => self.fill(&mut builder.build_cartesian_2d(x.log_scale(), y).drawn()?),
            (false, true) => self.fill(&mut builder.build_cartesian_2d(x, y.log_scale()).drawn()?),
            (true, true) => self.fill(
                &mut builder
                    .build_cartesian_2d(x.log_scale(), y.log_scale())
                    .drawn()?,
            ),
        }
    }

    /// Refuses axis ranges plotters cannot draw (it panics or loops on them): non-finite,
    /// empty, or not positive on a log axis.
    fn check_ranges(&self) -> Result<()> {
        for (axis, (lo, hi), log) in [("x", self.x, self.log_x), ("y", self.y, self.log_y)] {
            let ok = lo.is_finite() && hi.is_finite() && lo < hi && (!log || lo > 0.0);
            if !ok {
                bail!(
                    "cannot plot {:?}: its {axis} range [{lo}, {hi}] is empty or not finite{} \
                     (the data are constant, zero or not finite)",
                    self.title,
                    if log {
                        " or not positive on a log axis"
                    } else {
                        ""
                    }
                );
            }
        }
        Ok(())
    }

    fn fill<'a, DB, X, Y>(&self, chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>) -> Result<()>
    where
        DB: DrawingBackend + 'a,
        X: Ranged<ValueType = f64> + ValueFormatter<f64>,
        Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        let ticks = &self.x_ticks;
        let category = |v: &f64| {
            let i = v.round();
            let on_tick = (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < ticks.len();
            if on_tick {
                ticks[i as usize].clone()
            } else {
                String::new()
            }
        };
        let mut mesh = chart.configure_mesh();
        mesh.x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .label_style((FONT, 13))
            .axis_desc_style((FONT, 15))
            .light_line_style(WHITE);
        let number = |v: &f64| tick_label(*v);
        mesh.y_label_formatter(&number);
        if ticks.is_empty() {
            mesh.x_label_formatter(&number);
        } else {
            mesh.x_labels(ticks.len() + 1).x_label_formatter(&category);
        }
        mesh.draw().drawn()?;
        let mut labelled = false;
        let (y0, y1) = self.y;
        for s in &self.series {
            let color = s.color;
            // Lines are clamped into the y range (plotters does not clip), dots outside dropped.
            let clamped: Vec<(f64, f64)> = match s.style {
                Style::Markers(_) => s
                    .points
                    .iter()
                    .copied()
                    .filter(|p| p.1 >= y0 && p.1 <= y1)
                    .collect(),
                _ => s
                    .points
                    .iter()
                    .map(|&(x, y)| (x, y.clamp(y0, y1)))
                    .collect(),
            };
            let points = clamped.into_iter();
            let anno = match s.style {
                Style::Line => chart.draw_series(LineSeries::new(points, color.stroke_width(2))),
                Style::Dashed => {
                    chart.draw_series(DashedLineSeries::new(points, 6, 4, color.stroke_width(2)))
                }
                Style::Markers(r) => {
                    chart.draw_series(points.map(move |p| Circle::new(p, r, color.filled())))
                }
                Style::Bars(w) => chart.draw_series(points.map(move |(x, y)| {
                    Rectangle::new(
                        [(x - 0.5 * w, 0.0), (x + 0.5 * w, y)],
                        color.mix(0.55).filled(),
                    )
                })),
            }
            .drawn()?;
            if let Some(label) = &s.label {
                labelled = true;
                let style = s.style;
                anno.label(label.as_str())
                    .legend(move |(x, y)| match style {
                        Style::Markers(r) => Circle::new((x + 9, y), r, color.filled()).into_dyn(),
                        Style::Bars(_) => {
                            Rectangle::new([(x, y - 5), (x + 18, y + 5)], color.mix(0.55).filled())
                                .into_dyn()
                        }
                        _ => PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                            .into_dyn(),
                    });
            }
        }
        if labelled {
            chart
                .configure_series_labels()
                .position(self.legend.clone())
                .label_font((FONT, 13))
                .background_style(WHITE.mix(0.85))
                .border_style(GREY)
                .draw()
                .drawn()?;
        }
        Ok(())
    }
}

/// An axis tick label: the value rounded to six significant digits, plain from 0.001 to below
/// 10^5 and in scientific notation (`1e-5`, `2.5e6`) outside.
pub fn tick_label(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let r: f64 = format!("{v:.5e}").parse().unwrap_or(v);
    if (1e-3..1e5).contains(&r.abs()) {
        format!("{r}")
    } else {
        format!("{r:e}")
    }
}

/// Blue (negative) - white (0) - red (positive), saturating at +-limit.
pub fn diverging(v: f64, limit: f64) -> RGBColor {
    let a = (v / limit).clamp(-1.0, 1.0);
    let (end, w) = if a < 0.0 {
        ((33.0, 102.0, 172.0), -a)
    } else {
        ((178.0, 24.0, 43.0), a)
    };
    let mix = |e: f64| (255.0 + (e - 255.0) * w).round() as u8;
    RGBColor(mix(end.0), mix(end.1), mix(end.2))
}

/// A heat map on a regular grid (value of cell (ix, iy) at index iy * nx + ix), with overlays.
#[derive(Clone, Debug)]
pub struct HeatPanel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub x: (f64, f64),
    pub y: (f64, f64),
    pub nx: usize,
    pub ny: usize,
    pub values: Vec<f64>,
    pub limit: f64,
    pub overlays: Vec<Series>,
}

impl HeatPanel {
    pub fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> Result<()> {
        let mut chart = ChartBuilder::on(area)
            .caption(&self.title, (FONT, 18))
            .margin(8)
            .x_label_area_size(38)
            .y_label_area_size(48)
            .build_cartesian_2d(self.x.0..self.x.1, self.y.0..self.y.1)
            .drawn()?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .label_style((FONT, 13))
            .axis_desc_style((FONT, 15))
            .draw()
            .drawn()?;
        let (dx, dy) = (
            (self.x.1 - self.x.0) / self.nx as f64,
            (self.y.1 - self.y.0) / self.ny as f64,
        );
        chart
            .draw_series((0..self.nx * self.ny).map(|i| {
                let (ix, iy) = ((i % self.nx) as f64, (i / self.nx) as f64);
                let (x0, y0) = (self.x.0 + ix * dx, self.y.0 + iy * dy);
                let color = diverging(self.values[i], self.limit);
                Rectangle::new([(x0, y0), (x0 + dx, y0 + dy)], color.filled())
            }))
            .drawn()?;
        for s in &self.overlays {
            let style = s.color.stroke_width(2);
            match s.style {
                Style::Dashed => {
                    chart
                        .draw_series(DashedLineSeries::new(s.points.clone(), 8, 5, style))
                        .drawn()?;
                }
                _ => {
                    chart
                        .draw_series(LineSeries::new(s.points.clone(), style))
                        .drawn()?;
                }
            }
        }
        Ok(())
    }
}

/// A vertical colour bar for [`diverging`] from -limit to +limit.
pub fn colorbar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    limit: f64,
    label: &str,
) -> Result<()> {
    let mut chart = ChartBuilder::on(area)
        .margin_top(34)
        .margin_bottom(46)
        .margin_right(6)
        .y_label_area_size(52)
        .build_cartesian_2d(0.0..1.0, -limit..limit)
        .drawn()?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(label)
        .label_style((FONT, 12))
        .axis_desc_style((FONT, 14))
        .draw()
        .drawn()?;
    let steps = 100;
    chart
        .draw_series((0..steps).map(|i| {
            let y0 = -limit + 2.0 * limit * i as f64 / steps as f64;
            let y1 = y0 + 2.0 * limit / steps as f64;
            Rectangle::new(
                [(0.0, y0), (1.0, y1)],
                diverging(0.5 * (y0 + y1), limit).filled(),
            )
        }))
        .drawn()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::tick_label;

    /// Tick labels are rounded and short (issue 43: a log axis showed "999999e-5").
    #[test]
    fn tick_labels_are_rounded_and_short() {
        assert_eq!(tick_label(1e-5 * (1.0 - 1e-12)), "1e-5");
        assert_eq!(tick_label(0.30000000000000004), "0.3");
        assert_eq!(tick_label(0.001), "0.001");
        assert_eq!(tick_label(100.0), "100");
        assert_eq!(tick_label(2.5e6), "2.5e6");
        assert_eq!(tick_label(-0.0001), "-1e-4");
        assert_eq!(tick_label(0.0), "0");
    }
}
