//! Triangles: intersection (Möller–Trumbore in f64 with a relative tolerance on the edges),
//! uniform area sampling and its inverse.

use super::SurfacePoint;
use crate::math::DVec3;

/// A triangle with optional per-vertex texture coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Vertices.
    pub p: [DVec3; 3],
    /// Texture coordinates per vertex.
    pub uv: [[f64; 2]; 3],
    /// Flip the geometric normal.
    pub flip: bool,
}

impl Triangle {
    /// Unit geometric normal `(p1 − p0) × (p2 − p0)` (flipped if requested).
    pub fn normal(&self) -> DVec3 {
        let n = (self.p[1] - self.p[0])
            .cross(self.p[2] - self.p[0])
            .normalize();
        if self.flip { -n } else { n }
    }

    /// Area.
    pub fn area(&self) -> f64 {
        0.5 * (self.p[1] - self.p[0])
            .cross(self.p[2] - self.p[0])
            .length()
    }

    /// Intersection parameter and barycentrics `(b1, b2)` of a ray, if it hits within `(0, t_max)`.
    #[inline]
    pub fn intersect(&self, o: DVec3, d: DVec3, t_max: f64) -> Option<(f64, f64, f64)> {
        let e1 = self.p[1] - self.p[0];
        let e2 = self.p[2] - self.p[0];
        let pv = d.cross(e2);
        let det = e1.dot(pv);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv = 1.0 / det;
        let tv = o - self.p[0];
        let b1 = tv.dot(pv) * inv;
        if !(0.0..=1.0).contains(&b1) {
            return None;
        }
        let qv = tv.cross(e1);
        let b2 = d.dot(qv) * inv;
        if b2 < 0.0 || b1 + b2 > 1.0 {
            return None;
        }
        let t = e2.dot(qv) * inv;
        (t > 0.0 && t < t_max).then_some((t, b1, b2))
    }

    /// The surface point at barycentrics `(b1, b2)`.
    pub fn point(&self, b1: f64, b2: f64, primitive: u32) -> SurfacePoint {
        let b0 = 1.0 - b1 - b2;
        let p = self.p[0] * b0 + self.p[1] * b1 + self.p[2] * b2;
        let uv = [
            self.uv[0][0] * b0 + self.uv[1][0] * b1 + self.uv[2][0] * b2,
            self.uv[0][1] * b0 + self.uv[1][1] * b1 + self.uv[2][1] * b2,
        ];
        SurfacePoint {
            p,
            n: self.normal(),
            uv,
            dpdu: self.dpdu(),
            primitive,
        }
    }

    fn dpdu(&self) -> DVec3 {
        let (d1, d2) = (self.p[1] - self.p[0], self.p[2] - self.p[0]);
        let (du1, dv1) = (self.uv[1][0] - self.uv[0][0], self.uv[1][1] - self.uv[0][1]);
        let (du2, dv2) = (self.uv[2][0] - self.uv[0][0], self.uv[2][1] - self.uv[0][1]);
        let det = du1 * dv2 - dv1 * du2;
        if det.abs() < 1e-12 {
            return d1.normalize_or_zero();
        }
        ((d1 * dv2 - d2 * dv1) / det).normalize_or_zero()
    }

    /// Uniform area sampling: barycentrics from two numbers (the square-root warp
    /// `b1 = 1 − √u0`, `b2 = u1 √u0`), bijective on the unit square's interior.
    pub fn sample(&self, u: [f64; 2], primitive: u32) -> SurfacePoint {
        let s = u[0].sqrt();
        self.point(1.0 - s, u[1] * s, primitive)
    }

    /// The numbers that [`Triangle::sample`] maps to the point with barycentrics `(b1, b2)`.
    pub fn invert(&self, b1: f64, b2: f64) -> [f64; 2] {
        let s = 1.0 - b1;
        let u0 = s * s;
        let u1 = if s > 0.0 { b2 / s } else { 0.0 };
        [crate::math::clamp_unit(u0), crate::math::clamp_unit(u1)]
    }

    /// Barycentrics `(b1, b2)` of a point on the triangle's plane.
    pub fn barycentrics(&self, p: DVec3) -> (f64, f64) {
        let (e1, e2, v) = (self.p[1] - self.p[0], self.p[2] - self.p[0], p - self.p[0]);
        let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let (dv1, dv2) = (v.dot(e1), v.dot(e2));
        let det = d11 * d22 - d12 * d12;
        let b1 = (d22 * dv1 - d12 * dv2) / det;
        let b2 = (d11 * dv2 - d12 * dv1) / det;
        (b1, b2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> Triangle {
        Triangle {
            p: [DVec3::ZERO, DVec3::X, DVec3::Y],
            uv: [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
            flip: false,
        }
    }

    #[test]
    fn hits_and_misses() {
        let t = tri();
        let (d, _, _) = t
            .intersect(DVec3::new(0.2, 0.2, 1.0), -DVec3::Z, f64::INFINITY)
            .unwrap();
        assert!((d - 1.0).abs() < 1e-15);
        assert!(
            t.intersect(DVec3::new(0.8, 0.8, 1.0), -DVec3::Z, f64::INFINITY)
                .is_none()
        );
        assert!(
            t.intersect(DVec3::new(0.2, 0.2, 1.0), DVec3::Z, f64::INFINITY)
                .is_none()
        );
        assert!(
            t.intersect(DVec3::new(0.2, 0.2, 1.0), -DVec3::Z, 0.5)
                .is_none()
        );
    }

    #[test]
    fn sampling_inverts() {
        let t = tri();
        for u in [[0.1, 0.9], [0.5, 0.5], [0.99, 0.01]] {
            let p = t.sample(u, 0);
            let (b1, b2) = t.barycentrics(p.p);
            let v = t.invert(b1, b2);
            assert!(
                (v[0] - u[0]).abs() < 1e-12 && (v[1] - u[1]).abs() < 1e-12,
                "{u:?} -> {v:?}"
            );
        }
    }
}
