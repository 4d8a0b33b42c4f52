//! Rays and robust ray origins.

use crate::math::DVec3;

/// A ray `o + t d`, `t ∈ (0, t_max)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub o: DVec3,
    /// Unit direction.
    pub d: DVec3,
    /// Upper bound of the parameter.
    pub t_max: f64,
}

impl Ray {
    /// An unbounded ray.
    pub fn new(o: DVec3, d: DVec3) -> Self {
        Self {
            o,
            d,
            t_max: f64::INFINITY,
        }
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f64) -> DVec3 {
        self.o + self.d * t
    }
}

/// Offset a surface point along its geometric normal toward the side `w` points to, so that a ray
/// leaving in direction `w` does not hit the surface it starts on. The offset scales with the
/// magnitude of the coordinates (f64 rounding of the intersection) plus a small absolute term.
#[inline]
pub fn offset_origin(p: DVec3, n: DVec3, w: DVec3) -> DVec3 {
    let scale = p.abs().max_element().max(1.0);
    let eps = 1e-9 * scale;
    if w.dot(n) >= 0.0 {
        p + n * eps
    } else {
        p - n * eps
    }
}
