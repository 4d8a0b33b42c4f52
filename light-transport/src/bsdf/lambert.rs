//! The Lambertian BRDF `f = R/π` (pbrt `matte`), two-sided, with cosine-weighted sampling by the
//! mapping of the charted-MLT paper's appendix (eq. 31), `(θ, φ) = (acos √u1, 2π u0)`, and its
//! exact inverse (eq. 32), `(u0, u1) = (φ/2π, cos² θ)`.

use super::lobes::{LobeSample, same_side};
use crate::light::{cosine_hemisphere, invert_cosine_hemisphere};
use crate::math::DVec3;
use crate::spectrum::Rgb;
use std::f64::consts::FRAC_1_PI;

/// A Lambertian lobe with reflectance `r`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambert {
    /// Reflectance (albedo).
    pub r: Rgb,
}

impl Lambert {
    /// `f(wo, wi)`: `R/π` when both directions are on the same side.
    pub fn eval(&self, wo: DVec3, wi: DVec3) -> Rgb {
        if same_side(wo, wi) {
            self.r * FRAC_1_PI
        } else {
            Rgb::BLACK
        }
    }

    /// Density `|cos θi|/π` on `wo`'s side.
    pub fn pdf(&self, wo: DVec3, wi: DVec3) -> f64 {
        if same_side(wo, wi) {
            wi.z.abs() * FRAC_1_PI
        } else {
            0.0
        }
    }

    /// Cosine-weighted direction on `wo`'s side: the lights' [`cosine_hemisphere`] (eq. 31),
    /// mirrored below the surface when `wo` is.
    pub fn sample(&self, wo: DVec3, u: [f64; 2]) -> Option<LobeSample> {
        let w = cosine_hemisphere([u[0], u[1].clamp(0.0, 1.0)]);
        let wi = if wo.z < 0.0 {
            DVec3::new(w.x, w.y, -w.z)
        } else {
            w
        };
        (w.z > 0.0 && wo.z != 0.0).then_some(LobeSample::smooth(wi))
    }

    /// The numbers `(u0, u1)` that produce `wi` (eq. 32): [`invert_cosine_hemisphere`], whose
    /// numbers do not depend on the side.
    pub fn invert(&self, wo: DVec3, wi: DVec3) -> Option<[f64; 2]> {
        same_side(wo, wi).then(|| invert_cosine_hemisphere(wi))
    }
}
