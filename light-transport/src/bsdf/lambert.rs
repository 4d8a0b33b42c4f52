//! The Lambertian BRDF `f = R/π` (pbrt `matte`), two-sided, with cosine-weighted sampling by the
//! mapping of the charted-MLT paper's appendix (eq. 31), `(θ, φ) = (acos √u1, 2π u0)`, and its
//! exact inverse (eq. 32), `(u0, u1) = (φ/2π, cos² θ)`.

use super::lobes::{LobeSample, same_side};
use crate::math::{DVec3, clamp_unit, phi};
use crate::spectrum::Rgb;
use std::f64::consts::{FRAC_1_PI, PI};

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

    /// Cosine-weighted direction on `wo`'s side.
    pub fn sample(&self, wo: DVec3, u: [f64; 2]) -> Option<LobeSample> {
        let cos_t = u[1].clamp(0.0, 1.0).sqrt();
        let sin_t = (1.0 - u[1].clamp(0.0, 1.0)).sqrt();
        let (cos_p, sin_p) = crate::math::turn(u[0]);
        let z = if wo.z < 0.0 { -cos_t } else { cos_t };
        let wi = DVec3::new(sin_t * cos_p, sin_t * sin_p, z);
        (cos_t > 0.0 && wo.z != 0.0).then_some(LobeSample::smooth(wi))
    }

    /// The numbers `(u0, u1)` that produce `wi` (eq. 32).
    pub fn invert(&self, wo: DVec3, wi: DVec3) -> Option<[f64; 2]> {
        if !same_side(wo, wi) {
            return None;
        }
        Some([clamp_unit(phi(wi) / (2.0 * PI)), clamp_unit(wi.z * wi.z)])
    }
}
