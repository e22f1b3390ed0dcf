//! What the window shows: the render tone-mapped as its PNG preview is ([`Preview`]), the
//! split view's two images left and right of its line, and the HUD's lines of text drawn in
//! the public-domain 8x8 bitmap font (no GUI toolkit: the viewer's controls are keys and the
//! mouse, the HUD only reports).

use engine::render_job::preview::Preview;
use font8x8::UnicodeFonts;
use shared::kernels::render::PixelOut;

/// An RGBA8 frame of `width` x `height` pixels, rows top to bottom.
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<u8>,
}

impl Frame {
    /// The frame of `pixels` (row-major, `width` x `height`) through `tone`; where `right` is
    /// given (the split view), the pixels right of column `split` come from it instead.
    pub fn of(
        width: u32,
        height: u32,
        pixels: &[PixelOut],
        right: Option<(&[PixelOut], u32)>,
        tone: Preview,
    ) -> Frame {
        let mut rgba = Vec::with_capacity(pixels.len() * 4);
        for (k, p) in pixels.iter().enumerate() {
            let x = k as u32 % width.max(1);
            let src = match right {
                Some((r, split)) if x >= split => &r[k],
                _ => p,
            };
            let [r, g, b] = tone.rgb8(src);
            rgba.extend_from_slice(&[r, g, b, 255]);
        }
        let mut f = Frame {
            width,
            height,
            rgba,
        };
        if let Some((_, split)) = right {
            f.vertical_line(split);
        }
        f
    }

    /// This frame enlarged to `width` x `height` by repeating each pixel (a preview's frame
    /// shown at the window's size); pixels past this frame's right or bottom edge repeat its
    /// last column or row.
    pub fn enlarged(&self, width: u32, height: u32) -> Frame {
        if (width, height) == (self.width, self.height) {
            return Frame {
                width,
                height,
                rgba: self.rgba.clone(),
            };
        }
        let mut rgba = Vec::with_capacity(width as usize * height as usize * 4);
        for y in 0..height {
            let sy = (u64::from(y) * u64::from(self.height) / u64::from(height.max(1))) as u32;
            for x in 0..width {
                let sx = (u64::from(x) * u64::from(self.width) / u64::from(width.max(1))) as u32;
                let i =
                    ((sy.min(self.height - 1) * self.width + sx.min(self.width - 1)) * 4) as usize;
                rgba.extend_from_slice(&self.rgba[i..i + 4]);
            }
        }
        Frame {
            width,
            height,
            rgba,
        }
    }

    /// The split line: one column, light grey.
    fn vertical_line(&mut self, x: u32) {
        if x >= self.width {
            return;
        }
        for y in 0..self.height {
            let i = ((y * self.width + x) * 4) as usize;
            self.rgba[i..i + 3].copy_from_slice(&[200, 200, 200]);
        }
    }

    /// Draws `lines` of text from the top-left corner on a dark band, `scale` screen pixels per
    /// font pixel. Characters the font lacks are drawn as '?'.
    pub fn text(&mut self, lines: &[String], scale: u32) {
        let scale = scale.max(1);
        let line_h = 10 * scale;
        let band_h = (lines.len() as u32 * line_h + 2 * scale).min(self.height);
        let widest = lines.iter().map(|l| l.chars().count()).max().unwrap_or(0) as u32;
        let band_w = ((widest * 8 + 4) * scale).min(self.width);
        for y in 0..band_h {
            for x in 0..band_w {
                let i = ((y * self.width + x) * 4) as usize;
                for c in &mut self.rgba[i..i + 3] {
                    *c /= 3;
                }
            }
        }
        for (row, line) in lines.iter().enumerate() {
            let y0 = 2 * scale + row as u32 * line_h;
            for (col, ch) in line.chars().enumerate() {
                let glyph = font8x8::BASIC_FONTS
                    .get(ch)
                    .or_else(|| font8x8::BASIC_FONTS.get('?'))
                    .unwrap_or([0; 8]);
                let x0 = (2 + col as u32 * 8) * scale;
                for (gy, bits) in glyph.iter().enumerate() {
                    for gx in 0..8 {
                        if bits >> gx & 1 == 0 {
                            continue;
                        }
                        for sy in 0..scale {
                            for sx in 0..scale {
                                let (x, y) = (x0 + gx * scale + sx, y0 + gy as u32 * scale + sy);
                                if x < self.width && y < self.height {
                                    let i = ((y * self.width + x) * 4) as usize;
                                    self.rgba[i..i + 3].copy_from_slice(&[255, 240, 160]);
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn px(t: f32) -> PixelOut {
        PixelOut {
            t_mean: t,
            ..Default::default()
        }
    }

    /// The split view takes the columns right of the line from the second image, the line
    /// itself drawn grey.
    #[test]
    fn split_view_takes_the_right_columns_from_the_second_image() {
        let left = vec![px(0.0); 8];
        let right = vec![px(1.0); 8];
        let f = Frame::of(4, 2, &left, Some((&right, 2)), Preview::Transmittance);
        let col = |x: usize, y: usize| f.rgba[(y * 4 + x) * 4];
        assert_eq!((col(0, 0), col(1, 1)), (0, 0));
        assert_eq!(col(2, 0), 200);
        assert_eq!((col(3, 0), col(3, 1)), (255, 255));
    }

    /// Enlarging repeats each pixel over its block.
    #[test]
    fn enlarging_repeats_pixels() {
        let f = Frame {
            width: 2,
            height: 1,
            rgba: vec![1, 1, 1, 255, 9, 9, 9, 255],
        };
        let big = f.enlarged(4, 2);
        let reds: Vec<u8> = big.rgba.chunks(4).map(|p| p[0]).collect();
        assert_eq!(reds, [1, 1, 9, 9, 1, 1, 9, 9]);
    }

    /// Text lands in the band at the top-left and nowhere else.
    #[test]
    fn text_is_drawn_top_left() {
        let pixels = vec![px(1.0); 64 * 32];
        let mut f = Frame::of(64, 32, &pixels, None, Preview::Transmittance);
        f.text(&["A".into()], 1);
        let lit = f
            .rgba
            .chunks(4)
            .enumerate()
            .filter(|(_, p)| p[..3] == [255, 240, 160])
            .map(|(k, _)| (k % 64, k / 64))
            .collect::<Vec<_>>();
        assert!(!lit.is_empty());
        assert!(lit.iter().all(|&(x, y)| x < 12 && y < 12), "{lit:?}");
        // Outside the band the image is untouched.
        assert_eq!(f.rgba[(31 * 64 + 63) * 4], 255);
    }
}
