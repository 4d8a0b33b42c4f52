//! The rough dielectric interface of Walter et al. 2007 ("Microfacet models for refraction through
//! rough surfaces", eqs. 20–21 with the generalised half vector of eq. 16), GGX with
//! height-correlated Smith `G2`, sampled with visible normals (Heitz 2018) as in pbrt-v4's
//! `DielectricBxDF`. `η` is chosen by the side of `wo`; in the oriented frame (`wo.z > 0`) with
//! `η = η_i/η_o`:
//!
//! * reflection (`wi` on `wo`'s side), `h = normalize(wo + wi)`:
//!   `f = Kr F(wo·h) D(h) G2 / (4 |cos θo| |cos θi|)`;
//! * transmission, `m = ±normalize(wo + η wi)` with `m.z > 0`, `wo·m > 0`, `wi·m < 0`:
//!   `f = Kt (1 − F(wo·m)) D(m) G2 |wi·m| |wo·m| η² / (|cos θo| |cos θi| (wo·m + η wi·m)²) · s`
//!   with `s = 1/η²` in radiance mode and `1` in importance mode (pbrt-v3/v4 convention).
//!
//! Sampling draws `m ~ D_wo` from `(u0, u1)`, then chooses reflection when `u_sub < P_R(m)`,
//! `P_R = F·avg(Kr) / (F·avg(Kr) + (1 − F)·avg(Kt))`, `F = F(wo·m)` (the Fresnel choice at the
//! sampled microfacet). Densities: `P_R(h) D_wo(h) / (4 wo·h)` for reflection and
//! `(1 − P_R(m)) D_wo(m) η² |wi·m| / (wo·m + η wi·m)²` for transmission. The inverse recovers the
//! microfacet normal (half vector or generalised half vector), inverts the visible-normal map and
//! draws `u_sub` uniformly in `[0, P_R)` or `[P_R, 1)`.

use super::TransportMode;
use super::dielectric::{orient, reflect_probability, transmission_scale};
use super::fresnel::{dielectric, refract};
use super::lobes::{LobeSample, negative, positive, uniform_in};
use super::microfacet::Ggx;
use crate::math::{DVec3, reflect};
use crate::spectrum::Rgb;
use mcmc_core::ChainRng;

/// Rough dielectric boundary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughDielectric {
    /// Distribution.
    pub ggx: Ggx,
    /// Index of refraction inside over outside (≠ 1).
    pub eta: f64,
    /// Reflection tint.
    pub kr: Rgb,
    /// Transmission tint.
    pub kt: Rgb,
}

/// The microfacet configuration of a pair of oriented directions.
enum Pair {
    Reflection(DVec3),
    Transmission(DVec3),
}

fn normalized(v: DVec3) -> Option<DVec3> {
    let len2 = v.length_squared();
    (len2 > 0.0 && len2.is_finite()).then(|| v / len2.sqrt())
}

/// Classify `(wo, wi)` (oriented, `wo.z > 0`) and find its microfacet normal.
fn pair(wo: DVec3, wi: DVec3, eta: f64) -> Option<Pair> {
    if !positive(wo.z) || wi.z == 0.0 || !wi.z.is_finite() {
        return None;
    }
    if wi.z > 0.0 {
        return normalized(wo + wi).map(Pair::Reflection);
    }
    let m = normalized(wo + wi * eta)?;
    let m = if m.z < 0.0 { -m } else { m };
    (m.z > 0.0 && wo.dot(m) > 0.0 && wi.dot(m) < 0.0).then_some(Pair::Transmission(m))
}

/// Half vector of a pair for a dielectric of index `eta` (inside over outside), oriented so its
/// `z` is positive in `wo`'s frame (the caller's frame is restored).
pub fn microfacet_normal(wo: DVec3, wi: DVec3, eta: f64) -> Option<DVec3> {
    let (wo, sign, eta) = orient(wo, eta);
    let wi = DVec3::new(wi.x, wi.y, wi.z * sign);
    let m = match pair(wo, wi, eta)? {
        Pair::Reflection(m) | Pair::Transmission(m) => m,
    };
    Some(DVec3::new(m.x, m.y, m.z * sign))
}

impl RoughDielectric {
    fn p_reflect(&self, cos: f64, eta: f64) -> Option<(f64, f64)> {
        let f = dielectric(cos, eta);
        Some((f, reflect_probability(f, self.kr, self.kt)?))
    }

    /// `f(wo, wi)` in `mode`.
    pub fn eval(&self, wo: DVec3, wi: DVec3, mode: TransportMode) -> Rgb {
        let (wo, sign, eta) = orient(wo, self.eta);
        let wi = DVec3::new(wi.x, wi.y, wi.z * sign);
        let Some(p) = pair(wo, wi, eta) else {
            return Rgb::BLACK;
        };
        let g = self.ggx.g2(wo, wi);
        let value = match p {
            Pair::Reflection(h) => {
                let f = dielectric(wo.dot(h), eta);
                self.kr * (f * self.ggx.d(h) * g / (4.0 * wo.z * wi.z))
            }
            Pair::Transmission(m) => {
                let f = dielectric(wo.dot(m), eta);
                let (co, ci) = (wo.dot(m), wi.dot(m));
                let denom = co + eta * ci;
                let s = (1.0 - f) * self.ggx.d(m) * g * (ci * co).abs() * eta * eta
                    / (wo.z * wi.z * denom * denom).abs();
                self.kt * (s * transmission_scale(eta, mode))
            }
        };
        if value.is_finite() { value } else { Rgb::BLACK }
    }

    /// Solid-angle density of [`RoughDielectric::sample`].
    pub fn pdf(&self, wo: DVec3, wi: DVec3) -> f64 {
        let (wo, sign, eta) = orient(wo, self.eta);
        let wi = DVec3::new(wi.x, wi.y, wi.z * sign);
        let p = match pair(wo, wi, eta) {
            Some(Pair::Reflection(h)) => {
                let Some((_, pr)) = self.p_reflect(wo.dot(h), eta) else {
                    return 0.0;
                };
                pr * self.ggx.visible_pdf(wo, h) / (4.0 * wo.dot(h))
            }
            Some(Pair::Transmission(m)) => {
                let Some((_, pr)) = self.p_reflect(wo.dot(m), eta) else {
                    return 0.0;
                };
                let (co, ci) = (wo.dot(m), wi.dot(m));
                let denom = co + eta * ci;
                (1.0 - pr) * self.ggx.visible_pdf(wo, m) * eta * eta * ci.abs() / (denom * denom)
            }
            None => 0.0,
        };
        if p.is_finite() { p } else { 0.0 }
    }

    /// Draw a visible normal from `u`, then reflect or refract by `u_sub`.
    pub fn sample(&self, wo: DVec3, u_sub: f64, u: [f64; 2]) -> Option<LobeSample> {
        let (wo, sign, eta) = orient(wo, self.eta);
        let m = self.ggx.sample_visible(wo, u)?;
        let cos = wo.dot(m);
        if !positive(cos) {
            return None;
        }
        let (_, pr) = self.p_reflect(cos, eta)?;
        let wi = if u_sub < pr {
            let wi = reflect(wo, m);
            if !positive(wi.z) {
                return None;
            }
            wi
        } else {
            let wi = refract(wo, m, eta)?;
            if !negative(wi.z) {
                return None;
            }
            wi
        };
        Some(LobeSample::smooth(DVec3::new(wi.x, wi.y, wi.z * sign)))
    }

    /// `(u_sub, u0, u1)` drawn from their conditional law given `wi`.
    pub fn invert(&self, wo: DVec3, wi: DVec3, rng: &mut ChainRng) -> Option<[f64; 3]> {
        let (wo, sign, eta) = orient(wo, self.eta);
        let wi = DVec3::new(wi.x, wi.y, wi.z * sign);
        let (m, reflection) = match pair(wo, wi, eta)? {
            Pair::Reflection(h) => (h, true),
            Pair::Transmission(m) => (m, false),
        };
        let [u0, u1] = self.ggx.invert_visible(wo, m)?;
        let (_, pr) = self.p_reflect(wo.dot(m), eta)?;
        let u_sub = if reflection {
            if !positive(pr) {
                return None;
            }
            uniform_in(0.0, pr, rng)
        } else {
            if pr >= 1.0 || pr.is_nan() {
                return None;
            }
            uniform_in(pr, 1.0, rng)
        };
        Some([u_sub, u0, u1])
    }
}
