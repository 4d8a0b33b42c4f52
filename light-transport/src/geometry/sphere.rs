//! Spheres: intersection in f64, uniform area sampling (`z = 1 − 2 u0`, `φ = 2π u1`) and its
//! inverse.

use super::{Derivatives, SurfacePoint};
use crate::math::DVec3;
use std::f64::consts::PI;

/// A sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: DVec3,
    /// Radius.
    pub radius: f64,
    /// Normals point inwards.
    pub flip: bool,
}

impl Sphere {
    /// Area.
    pub fn area(&self) -> f64 {
        4.0 * PI * self.radius * self.radius
    }

    /// Nearest intersection parameter in `(0, t_max)`.
    #[inline]
    pub fn intersect(&self, o: DVec3, d: DVec3, t_max: f64) -> Option<f64> {
        let oc = o - self.center;
        let b = oc.dot(d);
        // Numerically stable discriminant (Hearn & Baker): |oc − b d|² instead of b² − c.
        let perp = oc - d * b;
        let disc = self.radius * self.radius - perp.length_squared();
        if disc < 0.0 {
            return None;
        }
        let sq = disc.sqrt();
        let q = if b > 0.0 { -b - sq } else { -b + sq };
        let c = oc.length_squared() - self.radius * self.radius;
        let (t0, t1) = {
            let a = q;
            let b2 = c / q;
            if a < b2 { (a, b2) } else { (b2, a) }
        };
        if t0 > 0.0 && t0 < t_max {
            Some(t0)
        } else if t1 > 0.0 && t1 < t_max {
            Some(t1)
        } else {
            None
        }
    }

    /// The texture coordinates `(φ/2π, θ/π)` of a point whose `local` coordinates are
    /// `(φ, cos θ)` ([`Sphere::local`]).
    #[inline]
    pub fn texture_coordinates(local: [f64; 2]) -> [f64; 2] {
        [local[0] / (2.0 * PI), local[1].acos() / PI]
    }

    /// The coordinates `(φ, cos θ)` of the point of [`Sphere::point`] with (oriented) normal `n`,
    /// from which its texture coordinates and derivatives follow. Computed on demand rather than
    /// stored in the point's `local`: `φ` takes an `atan2` (2% of path tracing the Cornell box),
    /// and only textures and manifold walks read it.
    #[inline]
    pub fn local(&self, n: DVec3) -> [f64; 2] {
        let n = n * self.sign();
        [crate::math::phi(n), n.z.clamp(-1.0, 1.0)]
    }

    /// The surface point at world position `p` (projected onto the sphere), parameterised by
    /// `u = φ/2π`, `v = θ/π` (`θ` from `+z`; [`Sphere::texture_coordinates`] of
    /// [`Sphere::local`]); its tangent is along `∂p/∂u = 2π (−y, x, 0)` (relative to the centre).
    /// Its derivatives: [`Sphere::derivatives`]. Its `local` is zero: a sphere's point is
    /// described by its normal.
    pub fn point(&self, p: DVec3, primitive: u32) -> SurfacePoint {
        let (p, n) = self.project(p);
        let dpdu = Self::dpdu(n * self.radius);
        let n = n * self.sign();
        SurfacePoint {
            p,
            n,
            ns: n,
            tangent: dpdu
                .try_normalize()
                .unwrap_or_else(|| crate::math::Frame::from_normal(n).s),
            local: [0.0; 2],
            primitive,
        }
    }

    /// The exact differential geometry of [`Sphere::point`]'s point with (oriented) normal `n` and
    /// azimuth `phi` (`local(n)[0]`): `∂p/∂u = 2π (−y, x, 0)`,
    /// `∂p/∂v = π (z cos φ, z sin φ, −r sin θ)` relative to the centre, and `∂n/∂u = ±∂p/∂u / r`,
    /// `∂n/∂v = ±∂p/∂v / r` (the normal is the scaled position).
    pub fn derivatives(&self, n: DVec3, phi: f64) -> Derivatives {
        let sign = self.sign();
        let n = n * sign;
        let cos_theta = n.z.clamp(-1.0, 1.0);
        let q = n * self.radius;
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let dpdu = Self::dpdu(q);
        let dpdv = DVec3::new(q.z * phi.cos(), q.z * phi.sin(), -self.radius * sin_theta) * PI;
        Derivatives {
            dpdu,
            dpdv,
            dndu: dpdu * (sign / self.radius),
            dndv: dpdv * (sign / self.radius),
        }
    }

    /// `∂p/∂u` at the point `q` relative to the centre.
    #[inline]
    fn dpdu(q: DVec3) -> DVec3 {
        DVec3::new(-q.y, q.x, 0.0) * (2.0 * PI)
    }

    /// 1, or −1 where normals point inwards.
    #[inline]
    fn sign(&self) -> f64 {
        if self.flip { -1.0 } else { 1.0 }
    }

    /// `p` moved onto the sphere along its outward normal, and that normal (unflipped).
    #[inline]
    fn project(&self, p: DVec3) -> (DVec3, DVec3) {
        let n = (p - self.center).normalize();
        (self.center + n * self.radius, n)
    }

    /// Uniform area sampling.
    pub fn sample(&self, u: [f64; 2], primitive: u32) -> SurfacePoint {
        self.point(self.sample_raw(u), primitive)
    }

    /// Position and normal of [`Sphere::sample`]'s point, without the rest of the surface point
    /// (its texture coordinates and derivatives take trigonometry).
    pub fn sample_position(&self, u: [f64; 2]) -> (DVec3, DVec3) {
        let (p, n) = self.project(self.sample_raw(u));
        (p, n * self.sign())
    }

    /// The point uniform area sampling maps `u` to, before [`Sphere::point`] projects it.
    #[inline]
    fn sample_raw(&self, u: [f64; 2]) -> DVec3 {
        let z = 1.0 - 2.0 * u[0];
        let r = (1.0 - z * z).max(0.0).sqrt();
        let (cos_p, sin_p) = crate::math::turn(u[1]);
        self.center + DVec3::new(r * cos_p, r * sin_p, z) * self.radius
    }

    /// The numbers [`Sphere::sample`] maps to the point `p` on the sphere.
    pub fn invert(&self, p: DVec3) -> [f64; 2] {
        let n = (p - self.center) / self.radius;
        [
            crate::math::clamp_unit((1.0 - n.z) / 2.0),
            crate::math::clamp_unit(crate::math::phi(n) / (2.0 * PI)),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn intersections_from_outside_and_inside() {
        let s = Sphere {
            center: DVec3::new(0.0, 0.0, 5.0),
            radius: 1.0,
            flip: false,
        };
        assert!((s.intersect(DVec3::ZERO, DVec3::Z, f64::INFINITY).unwrap() - 4.0).abs() < 1e-12);
        assert!(
            (s.intersect(DVec3::new(0.0, 0.0, 5.0), DVec3::Z, f64::INFINITY)
                .unwrap()
                - 1.0)
                .abs()
                < 1e-12
        );
        assert!(s.intersect(DVec3::ZERO, DVec3::X, f64::INFINITY).is_none());
        // Far away and tiny: the stable discriminant still finds it.
        let far = Sphere {
            center: DVec3::new(0.0, 0.0, 1e6),
            radius: 1e-3,
            flip: false,
        };
        assert!(
            far.intersect(DVec3::ZERO, DVec3::Z, f64::INFINITY)
                .is_some()
        );
    }

    #[test]
    fn sampling_inverts() {
        let s = Sphere {
            center: DVec3::new(1.0, 2.0, 3.0),
            radius: 0.5,
            flip: false,
        };
        for u in [[0.1, 0.9], [0.5, 0.25], [0.97, 0.03]] {
            let p = s.sample(u, 0);
            let v = s.invert(p.p);
            assert!((v[0] - u[0]).abs() < 1e-12 && (v[1] - u[1]).abs() < 1e-12);
        }
    }
}
