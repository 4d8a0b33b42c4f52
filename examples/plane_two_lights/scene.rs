//! The simplified light transport scene of the charted-MLT paper (§7.1): an orthographic top view
//! of the ground plane `z = 0`, `(x, y) ∈ [0,1]²`, lit by two unit-square area lights standing on
//! its edges and facing each other:
//!
//! * light 1 on the plane `y = 0` (normal `+y`), emission rising exponentially along `x` and
//!   changing colour from red to blue, partly blocked by a thin black vertical strip in front of
//!   its brightest part;
//! * light 2 on the plane `y = 1` (normal `−y`), uniformly green, covered by a black mask with one
//!   tiny square hole (a mask on the light itself, so that every ground point sees exactly the hole).
//!
//! A path is a ground point `g` and a light point `l`; its contribution to the pixel of `g` is
//! `f = L_e(l) · (1/π) · G(g, l) · V(g, l)` (white Lambertian ground), measured against area on the
//! ground times area on the lights.

use std::f64::consts::PI;

/// Exponential rate of light 1's intensity along `x`.
pub const RATE: f64 = 3.0;
/// Radiance scale of light 2 (it is seen only through the hole).
pub const GREEN: f64 = 120.0;
/// The strip in front of light 1: plane `y = STRIP_Y`, `x ∈ STRIP_X`, `z ∈ [0, 1]`.
pub const STRIP_Y: f64 = 0.08;
pub const STRIP_X: (f64, f64) = (0.84, 0.88);
/// The hole in the mask over light 2: half-size `HOLE` at `(x, z) = (0.5, 0.5)`.
pub const HOLE: f64 = 0.015;

/// A path: ground point and a point on light 1 or 2 (coordinates `(x, z)` on the light's plane).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Path {
    pub g: [f64; 2],
    pub light: u8,
    pub l: [f64; 2],
}

impl Path {
    /// The light point in 3D.
    pub fn light_point(&self) -> [f64; 3] {
        let y = if self.light == 1 { 0.0 } else { 1.0 };
        [self.l[0], y, self.l[1]]
    }

    /// `(r², cos θ_g, cos θ_l)` of the connection.
    pub fn geometry(&self) -> (f64, f64, f64) {
        let p = self.light_point();
        let d = [p[0] - self.g[0], p[1] - self.g[1], p[2]];
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let r = r2.sqrt();
        let cos_g = d[2] / r;
        let cos_l = if self.light == 1 { -d[1] / r } else { d[1] / r };
        (r2, cos_g, cos_l)
    }

    /// Whether the segment from the ground point to the light point is unoccluded.
    pub fn visible(&self) -> bool {
        let p = self.light_point();
        let crossing = |plane_y: f64| -> Option<(f64, f64)> {
            let t = (plane_y - self.g[1]) / (p[1] - self.g[1]);
            (t > 0.0 && t < 1.0).then(|| (self.g[0] + t * (p[0] - self.g[0]), t * p[2]))
        };
        if self.light == 1
            && let Some((x, z)) = crossing(STRIP_Y)
            && (STRIP_X.0..STRIP_X.1).contains(&x)
            && (0.0..1.0).contains(&z)
        {
            return false;
        }
        if self.light == 2 {
            return (self.l[0] - 0.5).abs() < HOLE && (self.l[1] - 0.5).abs() < HOLE;
        }
        true
    }

    /// Emitted radiance (RGB) at the light point.
    pub fn emission(&self) -> [f64; 3] {
        if self.light == 1 {
            let x = self.l[0];
            let i = (RATE * x).exp() / ((RATE.exp() - 1.0) / RATE);
            [
                i * (1.0 - 0.8 * x),
                i * (0.25 + 0.5 * x * (1.0 - x)),
                i * (0.15 + 0.85 * x),
            ]
        } else {
            [0.0, GREEN, 0.0]
        }
    }

    /// The path contribution `f` (RGB).
    pub fn contribution(&self) -> [f64; 3] {
        let (r2, cg, cl) = self.geometry();
        if cg <= 0.0 || cl <= 0.0 || !self.visible() {
            return [0.0; 3];
        }
        let k = cg * cl / (r2 * PI);
        self.emission().map(|e| e * k)
    }
}

/// The scalar importance the chains sample: the largest RGB component (paper §3.4).
pub fn importance(path: &Path) -> f64 {
    let c = path.contribution();
    c[0].max(c[1]).max(c[2])
}

/// Power of light 1 in the sense used to choose lights: `∫ I(x) dx dz` (= 1 by normalisation).
pub fn power1() -> f64 {
    1.0
}

/// Power of light 2: its radiance scale times its area.
pub fn power2() -> f64 {
    GREEN
}

/// The part of light 2 that is visible (from every ground point): centre `(x, z)` and half-size.
pub fn visible_square(_g: &[f64; 2]) -> ([f64; 2], f64) {
    ([0.5, 0.5], HOLE)
}
