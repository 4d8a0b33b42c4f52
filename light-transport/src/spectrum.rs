//! RGB radiometric quantities in f64.

use std::ops::{Add, AddAssign, Div, Index, Mul, MulAssign, Sub};

/// A linear RGB triple (radiance, reflectance, throughput, …).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rgb(pub [f64; 3]);

impl Rgb {
    /// Black.
    pub const BLACK: Rgb = Rgb([0.0; 3]);
    /// White (1, 1, 1).
    pub const WHITE: Rgb = Rgb([1.0; 3]);

    /// `(r, g, b)`.
    pub const fn new(r: f64, g: f64, b: f64) -> Self {
        Rgb([r, g, b])
    }

    /// `(v, v, v)`.
    pub const fn splat(v: f64) -> Self {
        Rgb([v; 3])
    }

    /// Largest component (the scalar importance of charted MLT, paper §3.4).
    pub fn max_component(&self) -> f64 {
        self.0[0].max(self.0[1]).max(self.0[2])
    }

    /// Rec. 709 luminance.
    pub fn luminance(&self) -> f64 {
        0.2126 * self.0[0] + 0.7152 * self.0[1] + 0.0722 * self.0[2]
    }

    /// Mean of the components.
    pub fn average(&self) -> f64 {
        (self.0[0] + self.0[1] + self.0[2]) / 3.0
    }

    /// Whether every component is zero.
    pub fn is_black(&self) -> bool {
        self.0 == [0.0; 3]
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        self.0.iter().all(|v| v.is_finite())
    }

    /// Component-wise map.
    pub fn map(self, f: impl Fn(f64) -> f64) -> Rgb {
        Rgb(self.0.map(f))
    }

    /// Component-wise `sqrt`.
    pub fn sqrt(self) -> Rgb {
        self.map(f64::sqrt)
    }
}

impl Add for Rgb {
    type Output = Rgb;
    fn add(self, o: Rgb) -> Rgb {
        Rgb([self.0[0] + o.0[0], self.0[1] + o.0[1], self.0[2] + o.0[2]])
    }
}
impl AddAssign for Rgb {
    fn add_assign(&mut self, o: Rgb) {
        *self = *self + o;
    }
}
impl Sub for Rgb {
    type Output = Rgb;
    fn sub(self, o: Rgb) -> Rgb {
        Rgb([self.0[0] - o.0[0], self.0[1] - o.0[1], self.0[2] - o.0[2]])
    }
}
impl Mul for Rgb {
    type Output = Rgb;
    fn mul(self, o: Rgb) -> Rgb {
        Rgb([self.0[0] * o.0[0], self.0[1] * o.0[1], self.0[2] * o.0[2]])
    }
}
impl MulAssign for Rgb {
    fn mul_assign(&mut self, o: Rgb) {
        *self = *self * o;
    }
}
impl Mul<f64> for Rgb {
    type Output = Rgb;
    fn mul(self, s: f64) -> Rgb {
        self.map(|v| v * s)
    }
}
impl MulAssign<f64> for Rgb {
    fn mul_assign(&mut self, s: f64) {
        *self = *self * s;
    }
}
impl Div<f64> for Rgb {
    type Output = Rgb;
    fn div(self, s: f64) -> Rgb {
        self.map(|v| v / s)
    }
}
impl Index<usize> for Rgb {
    type Output = f64;
    fn index(&self, i: usize) -> &f64 {
        &self.0[i]
    }
}
