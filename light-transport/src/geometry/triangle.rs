//! Triangles: intersection (Möller–Trumbore in f64 with a relative tolerance on the edges),
//! uniform area sampling and its inverse, and the differential geometry of a point: the
//! parameterisation by texture coordinates (pbrt's default `(0,0), (1,0), (1,1)` when a mesh has
//! none), the interpolated shading normal `N = b0 n0 + b1 n1 + b2 n2` normalised, and the
//! derivatives of position and of the *normalised* shading normal,
//! `∂n_s/∂u = (∂N/∂u − n_s (n_s · ∂N/∂u)) / |N|`.

use super::{Derivatives, SurfacePoint};
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

/// What [`Triangle::frame`] gives: the parts of a triangle's surface points that do not depend on
/// the point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TriangleFrame {
    /// Unit geometric normal ([`Triangle::normal`]).
    pub n: DVec3,
    /// Unit tangent along `∂p/∂u` (along the first edge where the texture coordinates are
    /// degenerate).
    pub tangent: DVec3,
}

impl TriangleFrame {
    /// Zero normal and tangent (no triangle's).
    pub const ZERO: Self = Self {
        n: DVec3::ZERO,
        tangent: DVec3::ZERO,
    };
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

/// Relative margin of [`Triangle::intersect`]'s division-free rejection: far above the few
/// units in the last place (about `10⁻¹⁶`) that the exact test's division and products can move
/// a barycentric, far below any barycentric that matters.
const PREFILTER: f64 = 1e-9;

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
        let tv = o - self.p[0];
        let u = tv.dot(pv);
        // Most tested triangles are missed. Numerators clearly outside `[0, det]` reject a
        // triangle before the division, only where the tests below reject it too: their margin
        // (`PREFILTER`, relative) exceeds the rounding of `1 / det`, the products and the sum,
        // so the hits and their numbers are bit for bit those of the tests alone.
        let (a, s) = (det.abs(), det.signum());
        let (lo, hi) = (-PREFILTER * a, a * (1.0 + PREFILTER));
        let us = u * s;
        if us < lo || us > hi {
            return None;
        }
        let qv = tv.cross(e1);
        let v = d.dot(qv);
        let vs = v * s;
        if vs < lo || us + vs > hi {
            return None;
        }
        let inv = 1.0 / det;
        let b1 = u * inv;
        if !(0.0..=1.0).contains(&b1) {
            return None;
        }
        let b2 = v * inv;
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
        (self.at(b1, b2), self.normal())
    }

    /// The position at barycentrics `(b1, b2)`.
    #[inline]
    pub fn at(&self, b1: f64, b2: f64) -> DVec3 {
        let b0 = 1.0 - b1 - b2;
        self.p[0] * b0 + self.p[1] * b1 + self.p[2] * b2
    }

    /// The parts of its surface points that a triangle shares at every point: the unit geometric
    /// normal and the unit tangent along `∂p/∂u`.
    pub fn frame(&self) -> TriangleFrame {
        let (e1, e2) = (self.p[1] - self.p[0], self.p[2] - self.p[0]);
        let dpdu = UvInverse::of(self.uv_f64()).first(e1, e2);
        TriangleFrame {
            n: self.normal(),
            tangent: dpdu.try_normalize().unwrap_or_else(|| e1.normalize()),
        }
    }

    /// The surface point at barycentrics `(b1, b2)` with the triangle's shading data (without its
    /// [`Derivatives`]: [`Triangle::derivatives`]).
    pub fn point_shaded(
        &self,
        b1: f64,
        b2: f64,
        primitive: u32,
        shading: Option<&TriangleShading>,
    ) -> SurfacePoint {
        self.point_framed(b1, b2, primitive, shading, &self.frame())
    }

    /// [`Triangle::point_shaded`] with the triangle's [`Triangle::frame`] given (the BVH caches
    /// recent ones per thread, so a hit seldom recomputes it).
    #[inline]
    pub fn point_framed(
        &self,
        b1: f64,
        b2: f64,
        primitive: u32,
        shading: Option<&TriangleShading>,
        frame: &TriangleFrame,
    ) -> SurfacePoint {
        let b0 = 1.0 - b1 - b2;
        let p = self.at(b1, b2);
        let n = frame.n;
        let mut point = SurfacePoint {
            p,
            n,
            ns: n,
            tangent: frame.tangent,
            local: [b1, b2],
            primitive,
        };
        let Some((sh, ns, _, sign)) = shading.and_then(|sh| Self::shading_normal(sh, b1, b2, n))
        else {
            return point;
        };
        point.ns = ns * sign;
        if let Some(t) = sh.s {
            let s = t[0] * b0 + t[1] * b1 + t[2] * b2;
            if let Some(s) = s.try_normalize() {
                point.tangent = s;
            }
        }
        point
    }

    /// The differential geometry of the point [`Triangle::point_shaded`] gives at `(b1, b2)` with
    /// the same `shading`.
    pub fn derivatives(&self, b1: f64, b2: f64, shading: Option<&TriangleShading>) -> Derivatives {
        let inverse = UvInverse::of(self.uv_f64());
        let (e1, e2) = (self.p[1] - self.p[0], self.p[2] - self.p[0]);
        let (dpdu, dpdv) = inverse.apply(e1, e2);
        let mut d = Derivatives {
            dpdu,
            dpdv,
            ..Derivatives::default()
        };
        let Some((sh, ns, len, sign)) =
            shading.and_then(|sh| Self::shading_normal(sh, b1, b2, self.normal()))
        else {
            return d;
        };
        let (dnu, dnv) = inverse.apply(sh.n[1] - sh.n[0], sh.n[2] - sh.n[0]);
        let unit = |d: DVec3| (d - ns * ns.dot(d)) / len;
        d.dndu = unit(dnu) * sign;
        d.dndv = unit(dnv) * sign;
        d
    }

    /// The interpolated vertex normal at `(b1, b2)`: `shading`, the unit normal `N/|N|`, `|N|`,
    /// and the sign that puts it on the side of the geometric normal `n` (meshes are wound so that
    /// it is 1 but at extreme normals; the geometric side decides emission and the sides of
    /// dielectrics). `None` where `N` vanishes.
    #[inline]
    fn shading_normal(
        sh: &TriangleShading,
        b1: f64,
        b2: f64,
        n: DVec3,
    ) -> Option<(&TriangleShading, DVec3, f64, f64)> {
        let b0 = 1.0 - b1 - b2;
        let big_n = sh.n[0] * b0 + sh.n[1] * b1 + sh.n[2] * b2;
        let len = big_n.length();
        if !(len > 1e-12 && len.is_finite()) {
            return None;
        }
        let ns = big_n / len;
        let sign = if ns.dot(n) < 0.0 { -1.0 } else { 1.0 };
        Some((sh, ns, len, sign))
    }

    /// Texture coordinates per vertex, in f64.
    #[inline]
    fn uv_f64(&self) -> [[f64; 2]; 3] {
        self.uv.map(|[u, v]| [f64::from(u), f64::from(v)])
    }

    /// The texture coordinates of the point with barycentrics `(b1, b2)`: its vertices'
    /// interpolated in f64.
    #[inline]
    pub fn texture_coordinates(&self, b1: f64, b2: f64) -> [f64; 2] {
        let b0 = 1.0 - b1 - b2;
        let t = self.uv_f64();
        [
            t[0][0] * b0 + t[1][0] * b1 + t[2][0] * b2,
            t[0][1] * b0 + t[1][1] * b1 + t[2][1] * b2,
        ]
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
    pub fn sample_barycentrics(u: [f64; 2]) -> (f64, f64) {
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

/// `∂(b1, b2)/∂(u, v)`, the inverse of a triangle's matrix of texture-coordinate edges, applied to
/// a pair of edge vectors `(a, b)` (`∂/∂b1`, `∂/∂b2` of a linear function) to give its
/// derivatives along `u` and `v`. Where the texture coordinates are degenerate the barycentrics
/// themselves are the parameterisation, and the pair comes back as it is.
struct UvInverse {
    du1: f64,
    dv1: f64,
    du2: f64,
    dv2: f64,
    det: f64,
}

impl UvInverse {
    #[inline]
    fn of(t: [[f64; 2]; 3]) -> Self {
        let (du1, dv1) = (t[1][0] - t[0][0], t[1][1] - t[0][1]);
        let (du2, dv2) = (t[2][0] - t[0][0], t[2][1] - t[0][1]);
        let det = du1 * dv2 - dv1 * du2;
        Self {
            du1,
            dv1,
            du2,
            dv2,
            det,
        }
    }

    #[inline]
    fn invertible(&self) -> bool {
        self.det.abs()
            > 1e-12 * (self.du1.abs() + self.dv1.abs()) * (self.du2.abs() + self.dv2.abs())
            && self.det != 0.0
    }

    /// The derivative along `u` alone.
    #[inline]
    fn first(&self, a: DVec3, b: DVec3) -> DVec3 {
        if self.invertible() {
            (a * self.dv2 - b * self.dv1) / self.det
        } else {
            a
        }
    }

    /// The derivatives along `u` and `v`.
    #[inline]
    fn apply(&self, a: DVec3, b: DVec3) -> (DVec3, DVec3) {
        if self.invertible() {
            (
                (a * self.dv2 - b * self.dv1) / self.det,
                (b * self.du1 - a * self.du2) / self.det,
            )
        } else {
            (a, b)
        }
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

    /// [`Triangle::intersect`] without its division-free rejection: the test as it was.
    fn intersect_with_division(
        t: &Triangle,
        o: DVec3,
        d: DVec3,
        t_max: f64,
    ) -> Option<(f64, f64, f64)> {
        let e1 = t.p[1] - t.p[0];
        let e2 = t.p[2] - t.p[0];
        let pv = d.cross(e2);
        let det = e1.dot(pv);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv = 1.0 / det;
        let tv = o - t.p[0];
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

    /// The division-free rejection changes no answer: rays aimed at triangles' edges and corners
    /// (barycentrics 0, 1 and `b1 + b2 = 1`, moved by a few units in the last place), at every
    /// scale from 10⁻⁷ to 10⁵ and on slivers, from origins on the plane or near it and to ends
    /// within a few units in the last place of the hit, give the hits and the numbers of the test
    /// with the division first, bit for bit. It fails with a margin of 0 or 10⁻¹⁷.
    #[test]
    fn division_free_rejection_changes_no_answer() {
        use mcmc_core::rng::{stream, uniform};
        let mut rng = stream(17, 3);
        let mut r = || uniform(&mut rng);
        let (mut hits, mut edge_hits) = (0, 0);
        for case in 0..400_000 {
            let scale = 10f64.powf(-7.0 + 12.0 * r());
            let mut p = [0.0; 9].map(|_| (r() - 0.5) * scale);
            if case % 4 == 0 {
                // A sliver: the third vertex nearly on the first edge.
                for k in 0..3 {
                    p[6 + k] = p[k] + (p[3 + k] - p[k]) * r() + (r() - 0.5) * scale * 1e-9;
                }
            }
            let tri = Triangle {
                p: [
                    DVec3::new(p[0], p[1], p[2]),
                    DVec3::new(p[3], p[4], p[5]),
                    DVec3::new(p[6], p[7], p[8]),
                ],
                ..tri()
            };
            // Barycentrics of the aim point: on an edge, at a corner or inside.
            let x = r();
            let (b1, b2) = match case % 6 {
                0 => (x, 1.0 - x),
                1 => (0.0, x),
                2 => (x, 0.0),
                3 => (1.0, 0.0),
                4 => (0.0, 1.0),
                _ => (x, (1.0 - x) * r()),
            };
            let aim = tri.p[0] * (1.0 - b1 - b2) + tri.p[1] * b1 + tri.p[2] * b2;
            let mut o = aim + DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * scale * 4.0;
            let mut d = (aim - o).normalize();
            // Move the direction by a few units in the last place.
            let ulps = |v: f64, k: i64| f64::from_bits((v.to_bits() as i64 + k) as u64);
            let k = (r() * 9.0) as i64 - 4;
            d.x = ulps(d.x, k);
            if case % 7 == 0 {
                // An origin on the triangle's plane, or within 10⁻¹⁵ of it on either side.
                o = aim + d * (r() - 0.5) * scale * 1e-15 * (case % 2) as f64;
            }
            // No end, an end anywhere, or an end within a few units in the last place of the hit.
            let t_max = match (case / 6) % 3 {
                0 => f64::INFINITY,
                1 => scale * 4.0 * r(),
                _ => intersect_with_division(&tri, o, d, f64::INFINITY)
                    .map_or(1.0, |(t, _, _)| ulps(t, (r() * 9.0) as i64 - 4)),
            };
            let want = intersect_with_division(&tri, o, d, t_max);
            let got = tri.intersect(o, d, t_max);
            let bits = |h: Option<(f64, f64, f64)>| h.map(|(a, b, c)| [a, b, c].map(f64::to_bits));
            assert_eq!(
                bits(got),
                bits(want),
                "case {case}: {tri:?} {o} {d} {t_max}"
            );
            if let Some((_, b1, b2)) = got {
                hits += 1;
                if b1 == 0.0 || b2 == 0.0 || b1 + b2 == 1.0 || b1 == 1.0 {
                    edge_hits += 1;
                }
            }
        }
        // The cases reach the edges: many hits, a good share exactly on an edge.
        assert!(
            hits > 100_000 && edge_hits > 10_000,
            "{hits} hits, {edge_hits} on edges"
        );
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
