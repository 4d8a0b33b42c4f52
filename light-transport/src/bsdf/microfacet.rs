//! The anisotropic GGX (Trowbridge–Reitz) microfacet distribution (Walter et al. 2007, eq. 33;
//! anisotropic form of Heitz 2014 "Understanding the masking-shadowing function", eq. 85), the
//! Smith masking function `G1 = 1/(1 + Λ)` and the **height-correlated** masking-shadowing
//! `G2 = 1/(1 + Λ(wo) + Λ(wi))` (Heitz 2014 eq. 99; pbrt-v3/v4's choice), and sampling of the
//! distribution of visible normals with its exact inverse.
//!
//! # Visible-normal sampling (Heitz 2018, "Sampling the GGX distribution of visible normals")
//!
//! The forward map `(u0, u1) ↦ m` used here:
//!
//! 1. stretch `wo` into the hemisphere configuration, `v = normalize(α_x wo.x, α_y wo.y, wo.z)`;
//! 2. basis `T1 = normalize(−v.y, v.x, 0)` (`(1, 0, 0)` when `v = z`), `T2 = v × T1`;
//! 3. a point of the unit disk in polar form, `φ = 2π u0`, `r = √u1`, `(p1, p2) = r (cos φ, sin φ)`
//!    (note: `u0` drives the angle, as in the charted-MLT paper's appendix, eq. 34);
//! 4. warp onto the projected hemisphere, `s = (1 + v.z)/2`, `p2 ← (1 − s)√(1 − p1²) + s p2`;
//! 5. lift, `m_h = p1 T1 + p2 T2 + √(1 − p1² − p2²) v`, and unstretch,
//!    `m = normalize(α_x m_h.x, α_y m_h.y, m_h.z)`.
//!
//! Its density is the visible-normal distribution `D_wo(m) = G1(wo) max(0, wo·m) D(m) / wo.z`.
//! The map is a bijection from the unit square onto the visible upper-hemisphere normals
//! `{m : m.z > 0, wo·m > 0}` (stretching preserves the sign of dot products, and the warped
//! half-disk `{p2 ≥ −v.z √(1 − p1²)}` is exactly where `m_h.z ≥ 0`), so the inverse is exact:
//! `m_h = normalize(m.x/α_x, m.y/α_y, m.z)`, `p1 = m_h·T1`, `p2 = (m_h·T2 − (1 − s)√(1 − p1²))/s`,
//! `u0 = atan2(p2, p1)/2π mod 1`, `u1 = p1² + p2²`.

use super::lobes::positive;
use crate::math::{DVec3, clamp_unit};
use std::f64::consts::PI;

/// Smallest roughness kept as a rough lobe (smaller positive values are clamped to it; a
/// roughness of exactly zero makes the lobe specular).
pub const MIN_ALPHA: f64 = 1e-7;

/// Anisotropic GGX with roughness `α_x` along the frame's first tangent and `α_y` along the second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    /// Roughness along `s`.
    pub alpha_x: f64,
    /// Roughness along `t`.
    pub alpha_y: f64,
}

impl Ggx {
    /// A distribution with both roughnesses clamped to at least [`MIN_ALPHA`].
    pub fn new(alpha_x: f64, alpha_y: f64) -> Self {
        Self {
            alpha_x: alpha_x.max(MIN_ALPHA),
            alpha_y: alpha_y.max(MIN_ALPHA),
        }
    }

    /// The normal distribution `D(m)` (zero for `m.z ≤ 0`), `m` a unit vector.
    pub fn d(&self, m: DVec3) -> f64 {
        if !positive(m.z) {
            return 0.0;
        }
        let x = m.x / self.alpha_x;
        let y = m.y / self.alpha_y;
        let t = x * x + y * y + m.z * m.z;
        let d = 1.0 / (PI * self.alpha_x * self.alpha_y * t * t);
        if d.is_finite() { d } else { 0.0 }
    }

    /// Smith's `Λ(w)` (even in `w.z`; infinite for horizontal `w`).
    pub fn lambda(&self, w: DVec3) -> f64 {
        let z2 = w.z * w.z;
        if z2 == 0.0 {
            return f64::INFINITY;
        }
        let a2 = (self.alpha_x * w.x).powi(2) + (self.alpha_y * w.y).powi(2);
        0.5 * ((1.0 + a2 / z2).sqrt() - 1.0)
    }

    /// Masking `G1(w) = 1/(1 + Λ(w))`.
    pub fn g1(&self, w: DVec3) -> f64 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing `G2(wo, wi) = 1/(1 + Λ(wo) + Λ(wi))`.
    pub fn g2(&self, wo: DVec3, wi: DVec3) -> f64 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Visible-normal density `D_wo(m) = G1(wo) max(0, wo·m) D(m) / wo.z` for `wo.z > 0`.
    pub fn visible_pdf(&self, wo: DVec3, m: DVec3) -> f64 {
        if !positive(wo.z) {
            return 0.0;
        }
        let c = wo.dot(m);
        if !positive(c) {
            return 0.0;
        }
        let p = self.g1(wo) * c * self.d(m) / wo.z;
        if p.is_finite() { p } else { 0.0 }
    }

    /// Stretched view direction and the basis `(T1, T2)` of the projected disk.
    fn basis(&self, wo: DVec3) -> (DVec3, DVec3, DVec3) {
        let v = DVec3::new(self.alpha_x * wo.x, self.alpha_y * wo.y, wo.z).normalize();
        let lensq = v.x * v.x + v.y * v.y;
        let t1 = if lensq > 0.0 {
            DVec3::new(-v.y, v.x, 0.0) / lensq.sqrt()
        } else {
            DVec3::X
        };
        let t2 = v.cross(t1);
        (v, t1, t2)
    }

    /// Sample a visible normal for `wo` (`wo.z > 0`) from `u = (u0, u1)`; `None` when the sample
    /// degenerates to a horizontal normal (a set of measure zero).
    pub fn sample_visible(&self, wo: DVec3, u: [f64; 2]) -> Option<DVec3> {
        if !positive(wo.z) {
            return None;
        }
        let (v, t1, t2) = self.basis(wo);
        let r = u[1].clamp(0.0, 1.0).sqrt();
        let (cos_p, sin_p) = crate::math::turn(u[0]);
        let p1 = r * cos_p;
        let p2 = r * sin_p;
        let s = 0.5 * (1.0 + v.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
        let lift = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        let mh = t1 * p1 + t2 * p2 + v * lift;
        let m = DVec3::new(self.alpha_x * mh.x, self.alpha_y * mh.y, mh.z.max(0.0));
        let len2 = m.length_squared();
        if !positive(len2) || !len2.is_finite() {
            return None;
        }
        let m = m / len2.sqrt();
        (m.z > 0.0).then_some(m)
    }

    /// The exact inverse of [`Ggx::sample_visible`]: the numbers `(u0, u1)` that produce the
    /// visible normal `m`; `None` when `m` is not visible from `wo` (`m.z ≤ 0` or `wo·m ≤ 0`).
    pub fn invert_visible(&self, wo: DVec3, m: DVec3) -> Option<[f64; 2]> {
        if !positive(wo.z) || !positive(m.z) || !positive(wo.dot(m)) {
            return None;
        }
        let (v, t1, t2) = self.basis(wo);
        let mh = DVec3::new(m.x / self.alpha_x, m.y / self.alpha_y, m.z);
        let len2 = mh.length_squared();
        if !positive(len2) || !len2.is_finite() {
            return None;
        }
        let mh = mh / len2.sqrt();
        let p1 = mh.dot(t1).clamp(-1.0, 1.0);
        let s = 0.5 * (1.0 + v.z);
        let p2 = (mh.dot(t2) - (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt()) / s;
        let u1 = (p1 * p1 + p2 * p2).min(1.0);
        let mut u0 = p2.atan2(p1) / (2.0 * PI);
        if u0 < 0.0 {
            u0 += 1.0;
        }
        Some([clamp_unit(u0), clamp_unit(u1)])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn visible_normal_inverse_round_trips() {
        let ggx = Ggx::new(0.3, 0.05);
        let wo = DVec3::new(0.5, -0.3, 0.2).normalize();
        for i in 0..50 {
            for j in 0..50 {
                let u = [(i as f64 + 0.5) / 50.0, (j as f64 + 0.5) / 50.0];
                let m = ggx.sample_visible(wo, u).expect("interior sample");
                let v = ggx.invert_visible(wo, m).expect("visible");
                let m2 = ggx.sample_visible(wo, v).expect("interior sample");
                assert!((m - m2).length() < 1e-10, "{u:?} {v:?}");
                let du = (u[0] - v[0]).abs().min(1.0 - (u[0] - v[0]).abs());
                assert!(du < 1e-8 && (u[1] - v[1]).abs() < 1e-8, "{u:?} {v:?}");
            }
        }
    }
}
