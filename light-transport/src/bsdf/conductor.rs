//! Rough GGX microfacet reflection (Walter et al. 2007, eq. 20; Heitz 2018 for sampling):
//! `f = tint · F(wo·h) D(h) G2(wo, wi) / (4 |cos θo| |cos θi|)`, `h = normalize(wo + wi)`, with
//! height-correlated Smith `G2` and a Fresnel term that is either a conductor's (pbrt `metal`:
//! complex `η + ik` per channel) or a dielectric's (the coating of `plastic`). Two-sided: for `wo`
//! below the surface both directions are mirrored through the tangent plane.
//!
//! Sampling draws a visible normal `m ~ D_wo` from `(u0, u1)` and reflects `wo` about it; the
//! density is `p(wi) = D_wo(h) / (4 wo·h) = G1(wo) D(h) / (4 |cos θo|)`. The inverse recovers
//! `h = normalize(wo + wi)` and inverts the visible-normal map exactly
//! ([`super::microfacet::Ggx::invert_visible`]). Samples reflected below the horizon fail, so the
//! density integrates to the probability of success.

use super::fresnel::Fresnel;
use super::lobes::{LobeSample, positive, to_upper};
use super::microfacet::Ggx;
use crate::math::{DVec3, reflect};
use crate::spectrum::Rgb;

/// GGX reflection with a Fresnel term and a tint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MicrofacetReflection {
    /// Distribution.
    pub ggx: Ggx,
    /// Fresnel term.
    pub fresnel: Fresnel,
    /// Tint (`Ks` of a coating; white for metals).
    pub tint: Rgb,
}

/// Half vector of a reflection pair already in the upper hemisphere.
fn half(wo: DVec3, wi: DVec3) -> Option<DVec3> {
    if !(positive(wo.z) && positive(wi.z)) {
        return None;
    }
    let h = wo + wi;
    let len2 = h.length_squared();
    (len2 > 0.0 && len2.is_finite()).then(|| h / len2.sqrt())
}

impl MicrofacetReflection {
    /// `f(wo, wi)`.
    pub fn eval(&self, wo: DVec3, wi: DVec3) -> Rgb {
        let (wo, wi) = to_upper(wo, wi);
        let Some(h) = half(wo, wi) else {
            return Rgb::BLACK;
        };
        let s = self.ggx.d(h) * self.ggx.g2(wo, wi) / (4.0 * wo.z * wi.z);
        if !s.is_finite() {
            return Rgb::BLACK;
        }
        self.fresnel.eval(wo.dot(h)) * self.tint * s
    }

    /// Solid-angle density of [`MicrofacetReflection::sample`].
    pub fn pdf(&self, wo: DVec3, wi: DVec3) -> f64 {
        let (wo, wi) = to_upper(wo, wi);
        let Some(h) = half(wo, wi) else {
            return 0.0;
        };
        let p = self.ggx.g1(wo) * self.ggx.d(h) / (4.0 * wo.z);
        if p.is_finite() { p } else { 0.0 }
    }

    /// `(f(wo, wi), pdf(wo, wi))`, bit for bit [`MicrofacetReflection::eval`] and
    /// [`MicrofacetReflection::pdf`], with the half vector, `D(h)` and `Λ(wo)` computed once for
    /// both (a sampled bounce, a next-event estimate and a path-space vertex need both).
    pub fn eval_pdf(&self, wo: DVec3, wi: DVec3) -> (Rgb, f64) {
        let (wo, wi) = to_upper(wo, wi);
        let Some(h) = half(wo, wi) else {
            return (Rgb::BLACK, 0.0);
        };
        let d = self.ggx.d(h);
        let lambda_o = self.ggx.lambda(wo);
        // `Ggx::g2` and `Ggx::g1` with `Λ(wo)` shared, in their order of operations.
        let g2 = 1.0 / (1.0 + lambda_o + self.ggx.lambda(wi));
        let s = d * g2 / (4.0 * wo.z * wi.z);
        let f = if s.is_finite() {
            self.fresnel.eval(wo.dot(h)) * self.tint * s
        } else {
            Rgb::BLACK
        };
        let p = 1.0 / (1.0 + lambda_o) * d / (4.0 * wo.z);
        (f, if p.is_finite() { p } else { 0.0 })
    }

    /// Reflect `wo` about a visible normal drawn from `u`.
    pub fn sample(&self, wo: DVec3, u: [f64; 2]) -> Option<LobeSample> {
        let flip = wo.z < 0.0;
        let (wo, _) = to_upper(wo, DVec3::ZERO);
        let m = self.ggx.sample_visible(wo, u)?;
        let wi = reflect(wo, m);
        if !positive(wi.z) {
            return None;
        }
        let wi = if flip {
            DVec3::new(wi.x, wi.y, -wi.z)
        } else {
            wi
        };
        Some(LobeSample::smooth(wi))
    }

    /// The numbers `(u0, u1)` that produce `wi`.
    pub fn invert(&self, wo: DVec3, wi: DVec3) -> Option<[f64; 2]> {
        let (wo, wi) = to_upper(wo, wi);
        let h = half(wo, wi)?;
        self.ggx.invert_visible(wo, h)
    }

    /// The microfacet normal of a reflection pair (upper-hemisphere frame of `wo`).
    pub fn half_vector(wo: DVec3, wi: DVec3) -> Option<DVec3> {
        let (wo, wi) = to_upper(wo, wi);
        half(wo, wi)
    }
}
