//! Vectors (glam `DVec3`), orthonormal frames and spherical helpers.

pub use glam::{DMat4, DVec2, DVec3};

/// An orthonormal frame `(s, t, n)`; local coordinates have the normal along `+z`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// First tangent.
    pub s: DVec3,
    /// Second tangent.
    pub t: DVec3,
    /// Normal.
    pub n: DVec3,
}

impl Frame {
    /// A frame around the unit normal `n` (Duff et al. 2017, branchless and continuous almost
    /// everywhere).
    pub fn from_normal(n: DVec3) -> Self {
        let sign = 1f64.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = DVec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { s, t, n }
    }

    /// A frame with normal `n` and first tangent along the projection of `dpdu` (for anisotropy).
    pub fn from_normal_tangent(n: DVec3, dpdu: DVec3) -> Self {
        let s = dpdu - n * n.dot(dpdu);
        if s.length_squared() < 1e-20 {
            return Self::from_normal(n);
        }
        let s = s.normalize();
        Self {
            s,
            t: n.cross(s),
            n,
        }
    }

    /// World → local.
    pub fn to_local(&self, v: DVec3) -> DVec3 {
        DVec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local → world.
    pub fn to_world(&self, v: DVec3) -> DVec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// `cos θ` of a local direction.
#[inline]
pub fn cos_theta(w: DVec3) -> f64 {
    w.z
}

/// The direction of spherical angles `(θ, φ)` in local coordinates.
#[inline]
pub fn spherical_direction(sin_theta: f64, cos_theta: f64, phi: f64) -> DVec3 {
    DVec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
}

/// `φ ∈ [0, 2π)` of a local direction.
#[inline]
pub fn phi(w: DVec3) -> f64 {
    let p = w.y.atan2(w.x);
    if p < 0.0 {
        p + 2.0 * std::f64::consts::PI
    } else {
        p
    }
}

/// Clamp a number to `[0, 1)` (the primary-sample-space interval) after rounding.
#[inline]
pub fn clamp_unit(v: f64) -> f64 {
    v.clamp(0.0, 1.0 - f64::EPSILON / 2.0)
}

/// Mirror `w` about `n`.
#[inline]
pub fn reflect(w: DVec3, n: DVec3) -> DVec3 {
    -w + n * (2.0 * w.dot(n))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_for_every_normal() {
        for n in [
            DVec3::Z,
            -DVec3::Z,
            DVec3::X,
            DVec3::new(0.3, -0.5, 0.8).normalize(),
            DVec3::new(1e-9, 0.0, -1.0).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-12 && (f.t.length() - 1.0).abs() < 1e-12);
            assert!(
                f.s.dot(f.t).abs() < 1e-12 && f.s.dot(n).abs() < 1e-12 && f.t.dot(n).abs() < 1e-12
            );
            let v = DVec3::new(0.2, 0.7, -0.4);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-12);
            assert!((f.s.cross(f.t) - n).length() < 1e-12, "right-handed");
        }
    }
}
