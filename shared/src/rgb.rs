//! Linear RGB radiance and albedo (Rec. 709 primaries), with explicit, unfused arithmetic.

use bytemuck::{Pod, Zeroable};
use core::ops::{Add, Mul};

/// A linear RGB triple.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Rgb {
    pub r: f32,
    pub g: f32,
    pub b: f32,
}

impl Rgb {
    /// Black.
    pub const ZERO: Rgb = Rgb::new(0.0, 0.0, 0.0);

    #[inline]
    pub const fn new(r: f32, g: f32, b: f32) -> Self {
        Rgb { r, g, b }
    }

    /// (v, v, v).
    #[inline]
    pub const fn splat(v: f32) -> Self {
        Rgb { r: v, g: v, b: v }
    }

    /// Componentwise product.
    #[inline]
    pub fn mul_rgb(self, o: Rgb) -> Rgb {
        Rgb::new(self.r * o.r, self.g * o.g, self.b * o.b)
    }

    /// Rec. 709 luminance Y = 0.2126 R + 0.7152 G + 0.0722 B, summed in that order.
    #[inline]
    pub fn luminance(self) -> f32 {
        0.2126 * self.r + 0.7152 * self.g + 0.0722 * self.b
    }

    /// True when every component is 0 (or not greater than 0).
    #[inline]
    pub fn is_black(self) -> bool {
        !(self.r > 0.0) && !(self.g > 0.0) && !(self.b > 0.0)
    }
}

impl Add for Rgb {
    type Output = Rgb;
    #[inline]
    fn add(self, o: Rgb) -> Rgb {
        Rgb::new(self.r + o.r, self.g + o.g, self.b + o.b)
    }
}

impl Mul<f32> for Rgb {
    type Output = Rgb;
    #[inline]
    fn mul(self, k: f32) -> Rgb {
        Rgb::new(self.r * k, self.g * k, self.b * k)
    }
}
