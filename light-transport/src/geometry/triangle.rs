//! Triangles: intersection (Möller–Trumbore in f64 with a relative tolerance on the edges),
//! uniform area sampling and its inverse, and the differential geometry of a point: the
//! parameterisation by texture coordinates (pbrt's default `(0,0), (1,0), (1,1)` when a mesh has
//! none), the interpolated shading normal `N = b0 n0 + b1 n1 + b2 n2` normalised, and the
//! derivatives of position and of the *normalised* shading normal,
//! `∂n_s/∂u = (∂N/∂u − n_s (n_s · ∂N/∂u)) / |N|`.

use super::SurfacePoint;
use crate::math::DVec3;

/// `Triangle::shading` of a triangle without vertex normals.
pub const NO_SHADING: u32 = u32::MAX;

/// Per-vertex shading data of a triangle: unit normals (on the side of its geometric normal) and
/// optional tangents.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleShading {
    /// Vertex normals.
    pub n: [DVec3; 3],
    /// Vertex tangents (pbrt `"S"`).
    pub s: Option<[DVec3; 3]>,
}

/// A triangle with optional per-vertex texture coordinates and shading data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Vertices.
    pub p: [DVec3; 3],
    /// Texture coordinates per vertex, in f32 as pbrt keeps them: a triangle is then 104 bytes
    /// instead of 128, which a mesh of a million triangles notices (the benchmarks' terrain:
    /// 25 MB of its peak). Interpolation and derivatives are computed in f64.
    pub uv: [[f32; 2]; 3],
    /// Flip the geometric normal.
    pub flip: bool,
    /// Index of its [`TriangleShading`] in the scene's table ([`NO_SHADING`]: flat).
    pub shading: u32,
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

    /// The flat surface point at barycentrics `(b1, b2)` (geometric normal only).
    pub fn point(&self, b1: f64, b2: f64, primitive: u32) -> SurfacePoint {
        self.point_shaded(b1, b2, primitive, None)
    }

    /// Position and geometric normal at barycentrics `(b1, b2)`: [`Triangle::point`]'s, without
    /// the rest of the surface point.
    #[inline]
    pub fn position(&self, b1: f64, b2: f64) -> (DVec3, DVec3) {
        let b0 = 1.0 - b1 - b2;
        (
            self.p[0] * b0 + self.p[1] * b1 + self.p[2] * b2,
            self.normal(),
        )
    }

    /// The surface point at barycentrics `(b1, b2)` with the triangle's shading data.
    pub fn point_shaded(
        &self,
        b1: f64,
        b2: f64,
        primitive: u32,
        shading: Option<&TriangleShading>,
    ) -> SurfacePoint {
        let (p, n) = self.position(b1, b2);
        let b0 = 1.0 - b1 - b2;
        let t = self.uv.map(|[u, v]| [f64::from(u), f64::from(v)]);
        let uv = [
            t[0][0] * b0 + t[1][0] * b1 + t[2][0] * b2,
            t[0][1] * b0 + t[1][1] * b1 + t[2][1] * b2,
        ];
        let (e1, e2) = (self.p[1] - self.p[0], self.p[2] - self.p[0]);
        // d(b1, b2)/d(u, v): the inverse of the uv edge matrix (barycentrics themselves where the
        // texture coordinates are degenerate).
        let (du1, dv1) = (t[1][0] - t[0][0], t[1][1] - t[0][1]);
        let (du2, dv2) = (t[2][0] - t[0][0], t[2][1] - t[0][1]);
        let det = du1 * dv2 - dv1 * du2;
        let by_uv = |a: DVec3, b: DVec3| -> (DVec3, DVec3) {
            if det.abs() > 1e-12 * (du1.abs() + dv1.abs()) * (du2.abs() + dv2.abs()) && det != 0.0 {
                ((a * dv2 - b * dv1) / det, (b * du1 - a * du2) / det)
            } else {
                (a, b)
            }
        };
        let (dpdu, dpdv) = by_uv(e1, e2);
        let mut point = SurfacePoint {
            p,
            n,
            ns: n,
            uv,
            tangent: dpdu.try_normalize().unwrap_or_else(|| e1.normalize()),
            dpdu,
            dpdv,
            dndu: DVec3::ZERO,
            dndv: DVec3::ZERO,
            primitive,
        };
        let Some(sh) = shading else {
            return point;
        };
        let big_n = sh.n[0] * b0 + sh.n[1] * b1 + sh.n[2] * b2;
        let len = big_n.length();
        if !(len > 1e-12 && len.is_finite()) {
            return point;
        }
        let ns = big_n / len;
        // The shading normal stays on the geometric normal's side (which decides emission and the
        // sides of dielectrics); meshes are wound so that this holds but at extreme normals.
        let sign = if ns.dot(n) < 0.0 { -1.0 } else { 1.0 };
        let (dnu, dnv) = by_uv(sh.n[1] - sh.n[0], sh.n[2] - sh.n[0]);
        let unit = |d: DVec3| (d - ns * ns.dot(d)) / len;
        point.ns = ns * sign;
        point.dndu = unit(dnu) * sign;
        point.dndv = unit(dnv) * sign;
        if let Some(t) = sh.s {
            let s = t[0] * b0 + t[1] * b1 + t[2] * b2;
            if let Some(s) = s.try_normalize() {
                point.tangent = s;
            }
        }
        point
    }

    /// Uniform area sampling: barycentrics from two numbers (the square-root warp
    /// `b1 = 1 − √u0`, `b2 = u1 √u0`), bijective on the unit square's interior.
    pub fn sample(&self, u: [f64; 2], primitive: u32) -> SurfacePoint {
        let (b1, b2) = Self::sample_barycentrics(u);
        self.point(b1, b2, primitive)
    }

    /// Position and normal of [`Triangle::sample`]'s point.
    pub fn sample_position(&self, u: [f64; 2]) -> (DVec3, DVec3) {
        let (b1, b2) = Self::sample_barycentrics(u);
        self.position(b1, b2)
    }

    /// The barycentrics `(b1, b2)` uniform area sampling maps `u` to.
    #[inline]
    fn sample_barycentrics(u: [f64; 2]) -> (f64, f64) {
        let s = u[0].sqrt();
        (1.0 - s, u[1] * s)
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
            shading: NO_SHADING,
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
