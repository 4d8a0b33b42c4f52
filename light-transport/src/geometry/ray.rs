//! Rays and robust ray origins.

use super::{NO_PRIMITIVE, SurfacePoint};
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
    /// The primitive the ray leaves ([`Ray::leaving`]), which cannot hit it if it is a triangle;
    /// [`NO_PRIMITIVE`] for a ray that leaves none.
    pub leaves: u32,
}

impl Ray {
    /// An unbounded ray.
    pub fn new(o: DVec3, d: DVec3) -> Self {
        Self {
            o,
            d,
            t_max: f64::INFINITY,
            leaves: NO_PRIMITIVE,
        }
    }

    /// The unbounded ray leaving the surface at `point` in direction `w`: its origin offset along
    /// the geometric normal to the side `w` points to ([`offset_origin`]). The ray starts off the
    /// plane of the point's triangle and moves away from it (or along it), so it cannot hit that
    /// triangle, and the BVH does not test it (`Bvh::closest_hit_leaving`; a sphere is still
    /// tested, since a ray into it leaves through it).
    #[inline]
    pub fn leaving(point: &SurfacePoint, w: DVec3) -> Self {
        Self {
            leaves: point.primitive,
            ..Self::new(offset_origin(point.p, point.n, w), w)
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

/// One end of a segment on a surface (`Scene::visible`): the geometric normal the end is offset
/// along, toward the other end, and the primitive it lies on. A segment whose offset ends both lie
/// on one side of an end's triangle's plane cannot cross that triangle, which is then not tested
/// (`Bvh::occluded_between`); `Scene::visible` checks the sides, since the other end may lie
/// within the offset of the plane (two points on one triangle), and then tests the triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceEnd {
    /// Unit geometric normal.
    pub n: DVec3,
    /// The primitive the end lies on.
    pub primitive: u32,
}

impl SurfaceEnd {
    /// The end at `point`.
    #[inline]
    pub fn of(point: &SurfacePoint) -> Self {
        Self {
            n: point.n,
            primitive: point.primitive,
        }
    }
}
