//! Specular (delta) reflection `f = tint · F(cos θo) δ(wi − R(wo)) / |cos θi|` (pbrt-v3
//! `SpecularReflection`): the `mirror` material (`F = 1`, tint `Kr`), smooth conductors
//! (roughness 0, conductor Fresnel) and smooth coatings (dielectric Fresnel). Two-sided.
//!
//! It uses no direction numbers; its inverse fills `(u_sub, u0, u1)` uniformly.

use super::fresnel::Fresnel;
use super::lobes::{LobeSample, same_direction, uniform_in};
use crate::math::DVec3;
use crate::spectrum::Rgb;
use mcmc_core::ChainRng;

/// Delta reflection about the normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecularReflection {
    /// Fresnel term.
    pub fresnel: Fresnel,
    /// Tint (`Kr`).
    pub tint: Rgb,
}

/// Mirror a local direction about the normal `z`.
pub fn mirror_z(w: DVec3) -> DVec3 {
    DVec3::new(-w.x, -w.y, w.z)
}

impl SpecularReflection {
    fn value(&self, wo: DVec3, wi: DVec3) -> Option<Rgb> {
        if wo.z == 0.0 || wi.z == 0.0 {
            return None;
        }
        let f = self.fresnel.eval(wo.z) * self.tint / wi.z.abs();
        f.is_finite().then_some(f)
    }

    /// The mirrored direction, chosen with probability 1.
    pub fn sample(&self, wo: DVec3) -> Option<LobeSample> {
        let wi = mirror_z(wo);
        let f = self.value(wo, wi)?;
        Some(LobeSample::delta(wi, f, 1.0))
    }

    /// `(f, probability)` when `wi` is the mirrored direction.
    pub fn eval_delta(&self, wo: DVec3, wi: DVec3) -> Option<(Rgb, f64)> {
        if !same_direction(wi, mirror_z(wo)) {
            return None;
        }
        Some((self.value(wo, wi)?, 1.0))
    }

    /// Uniform numbers when `wi` is the mirrored direction.
    pub fn invert(&self, wo: DVec3, wi: DVec3, rng: &mut ChainRng) -> Option<[f64; 3]> {
        self.eval_delta(wo, wi)?;
        Some([
            uniform_in(0.0, 1.0, rng),
            uniform_in(0.0, 1.0, rng),
            uniform_in(0.0, 1.0, rng),
        ])
    }
}
