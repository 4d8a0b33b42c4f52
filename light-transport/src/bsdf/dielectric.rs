//! The smooth dielectric interface (pbrt-v3 `FresnelSpecular`, pbrt `glass` with roughness 0):
//! delta reflection with weight `F` and delta refraction with weight `1 − F`, `F` the dielectric
//! Fresnel reflectance at `cos θo`, `η` chosen by the side of `wo` (`wo` above the surface: from
//! outside into the material of index `η`; below: from inside out), total internal reflection when
//! Snell's law has no solution.
//!
//! * `f_R = Kr F / |cos θi|`, `f_T = Kt (1 − F) / |cos θi| · s`, with `s = (η_o/η_i)²` in
//!   [`TransportMode::Radiance`] (radiance is compressed by `1/η²` when it enters a denser medium;
//!   `η_o`, `η_i` the indices on the sides of `wo` and `wi`) and `s = 1` in
//!   [`TransportMode::Importance`] (Veach 1997, §5.2; pbrt-v3 §8.2).
//! * The branch is chosen with the lobe number `u_sub`: reflection when `u_sub < P_R`,
//!   `P_R = F·avg(Kr) / (F·avg(Kr) + (1 − F)·avg(Kt))` — exactly the Fresnel choice for the usual
//!   white tints, and never a zero-weight branch when a tint is black.
//! * The inverse draws `u_sub` uniformly inside the branch's interval and `(u0, u1)` uniformly
//!   (unused numbers).

use super::TransportMode;
use super::fresnel::{dielectric, refract};
use super::lobes::{LobeSample, positive, same_direction, uniform_in};
use super::mirror::mirror_z;
use crate::math::DVec3;
use crate::spectrum::Rgb;
use mcmc_core::ChainRng;

/// Smooth dielectric boundary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothDielectric {
    /// Index of refraction inside over outside.
    pub eta: f64,
    /// Reflection tint.
    pub kr: Rgb,
    /// Transmission tint.
    pub kt: Rgb,
}

/// `(wo in the upper hemisphere, sign to map back, relative index η_i/η_o)` for a dielectric of
/// index `eta` (inside over outside) seen from `wo`.
pub fn orient(wo: DVec3, eta: f64) -> (DVec3, f64, f64) {
    if wo.z < 0.0 {
        (DVec3::new(wo.x, wo.y, -wo.z), -1.0, 1.0 / eta)
    } else {
        (wo, 1.0, eta)
    }
}

/// Probability of choosing reflection given the Fresnel reflectance `f` and the tints.
pub fn reflect_probability(f: f64, kr: Rgb, kt: Rgb) -> Option<f64> {
    let pr = f * kr.average();
    let pt = (1.0 - f) * kt.average();
    let total = pr + pt;
    (total > 0.0 && total.is_finite()).then(|| pr / total)
}

/// Radiance scaling of a transmission with relative index `eta = η_i / η_o`.
pub fn transmission_scale(eta: f64, mode: TransportMode) -> f64 {
    match mode {
        TransportMode::Radiance => 1.0 / (eta * eta),
        TransportMode::Importance => 1.0,
    }
}

/// A resolved branch: direction (oriented frame), `f`, probability.
struct Branch {
    wi: DVec3,
    f: Rgb,
    prob: f64,
    reflect: bool,
}

impl SmoothDielectric {
    /// Both branches for an oriented `wo` (`wo.z > 0`).
    fn branches(&self, wo: DVec3, eta: f64, mode: TransportMode) -> [Option<Branch>; 2] {
        if !positive(wo.z) {
            return [None, None];
        }
        let f = dielectric(wo.z, eta);
        let Some(pr) = reflect_probability(f, self.kr, self.kt) else {
            return [None, None];
        };
        let reflection = (pr > 0.0).then(|| {
            let wi = mirror_z(wo);
            Branch {
                wi,
                f: self.kr * (f / wi.z),
                prob: pr,
                reflect: true,
            }
        });
        let transmission = if pr < 1.0 {
            refract(wo, DVec3::Z, eta)
                .filter(|wi| wi.z < 0.0)
                .map(|wi| Branch {
                    wi,
                    f: self.kt * ((1.0 - f) * transmission_scale(eta, mode) / -wi.z),
                    prob: 1.0 - pr,
                    reflect: false,
                })
        } else {
            None
        };
        [reflection, transmission]
    }

    /// Reflect or refract according to `u_sub`.
    pub fn sample(&self, wo: DVec3, u_sub: f64, mode: TransportMode) -> Option<LobeSample> {
        let (wo, sign, eta) = orient(wo, self.eta);
        let [r, t] = self.branches(wo, eta, mode);
        let pick = match (r, t) {
            (Some(r), Some(t)) => {
                if u_sub < r.prob {
                    r
                } else {
                    t
                }
            }
            (Some(b), None) | (None, Some(b)) => b,
            (None, None) => return None,
        };
        if !pick.f.is_finite() {
            return None;
        }
        let wi = DVec3::new(pick.wi.x, pick.wi.y, pick.wi.z * sign);
        Some(LobeSample::delta(wi, pick.f, pick.prob))
    }

    /// `(f, probability)` of the branch producing `wi`, if any.
    pub fn eval_delta(&self, wo: DVec3, wi: DVec3, mode: TransportMode) -> Option<(Rgb, f64)> {
        let (wo, sign, eta) = orient(wo, self.eta);
        let wi = DVec3::new(wi.x, wi.y, wi.z * sign);
        self.branches(wo, eta, mode)
            .into_iter()
            .flatten()
            .find(|b| same_direction(b.wi, wi))
            .filter(|b| b.f.is_finite())
            .map(|b| (b.f, b.prob))
    }

    /// `u_sub` uniform in the producing branch's interval, `(u0, u1)` uniform.
    pub fn invert(&self, wo: DVec3, wi: DVec3, rng: &mut ChainRng) -> Option<[f64; 3]> {
        let (wo, sign, eta) = orient(wo, self.eta);
        let wi = DVec3::new(wi.x, wi.y, wi.z * sign);
        let [r, t] = self.branches(wo, eta, TransportMode::Importance);
        let pr = r.as_ref().map_or(0.0, |b| b.prob);
        let b = [r, t]
            .into_iter()
            .flatten()
            .find(|b| same_direction(b.wi, wi))?;
        let u_sub = if b.reflect {
            uniform_in(0.0, pr, rng)
        } else {
            uniform_in(pr, 1.0, rng)
        };
        Some([u_sub, uniform_in(0.0, 1.0, rng), uniform_in(0.0, 1.0, rng)])
    }
}
