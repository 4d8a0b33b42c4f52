//! BSDFs with four faces each — `sample`, `eval`, `pdf` and `invert` — built per hit from a
//! material description.
//!
//! INTERFACE CONTRACT (implementation in progress; see the issue-4 helper brief):
//!
//! * Directions are **world-space unit vectors pointing away from the surface**. `wo` is the
//!   direction the random walk arrived from (toward the previous vertex); `wi` the new direction.
//! * [`TransportMode::Radiance`] (camera subpaths) evaluates `f(wo, wi)` for light flowing from
//!   `wi` to `wo`; [`TransportMode::Importance`] (light subpaths) evaluates the adjoint. They differ
//!   only for refraction (the `1/η²` radiance scaling).
//! * `eval` and `pdf` cover the non-delta lobes only (delta lobes evaluate to zero there);
//!   `pdf(wo, wi)` is the solid-angle density of `sample` producing `wi` from `wo`, so the reverse
//!   density is `pdf(wi, wo)`.
//! * `sample(wo, u_lobe, u, mode)` reads the vertex block's lobe number and two direction numbers
//!   (see [`crate::sampler`]). For a delta lobe it returns `delta = true`, `pdf` = the probability of
//!   choosing that lobe, and `f` such that `f · |cos θ_i| / pdf` is the lobe's weight.
//! * `invert(wo, wi, delta, rng)` draws `(u_lobe, u0, u1)` from the **exact conditional law** of the
//!   numbers given that `sample` produced `wi` (DESIGN §3): a lobe is chosen with probability
//!   proportional to its share of the density at `wi` (for delta: among the delta lobes that produce
//!   `wi`), `u_lobe` is uniform within that lobe's interval, and numbers a lobe does not use are
//!   uniform. `None` when `wi` cannot be produced.
//! * The local frame's normal is the **geometric** normal; reflection lobes are two-sided (they
//!   work for `wo` below the surface by mirroring), dielectrics choose `η` by the side of `wo`.

use crate::math::{DVec3, Frame};
use crate::spectrum::Rgb;
use mcmc_core::ChainRng;

/// Which quantity a random walk carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    /// Camera subpaths (radiance flows toward the camera).
    Radiance,
    /// Light subpaths (importance flows toward the lights).
    Importance,
}

/// A sampled direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// The new direction (world space).
    pub wi: DVec3,
    /// The BSDF value (see the module contract for delta lobes).
    pub f: Rgb,
    /// Solid-angle density, or the lobe probability for a delta lobe.
    pub pdf: f64,
    /// Whether a delta lobe produced it.
    pub delta: bool,
}

/// A BSDF at one surface point.
#[derive(Clone, Debug)]
pub struct Bsdf {
    /// Shading frame (normal = geometric normal).
    pub frame: Frame,
}

impl Bsdf {
    /// Sample a direction.
    pub fn sample(&self, _wo: DVec3, _u_lobe: f64, _u: [f64; 2], _mode: TransportMode) -> Option<BsdfSample> {
        None
    }
    /// Evaluate the non-delta part.
    pub fn eval(&self, _wo: DVec3, _wi: DVec3, _mode: TransportMode) -> Rgb {
        Rgb::BLACK
    }
    /// Density of sampling `wi` from `wo` (non-delta part).
    pub fn pdf(&self, _wo: DVec3, _wi: DVec3) -> f64 {
        0.0
    }
    /// Exact conditional inverse of `sample`.
    pub fn invert(&self, _wo: DVec3, _wi: DVec3, _delta: bool, _rng: &mut ChainRng) -> Option<[f64; 3]> {
        None
    }
    /// Whether some lobe is a delta (specular) lobe.
    pub fn has_delta(&self) -> bool {
        false
    }
    /// Whether every lobe is a delta lobe (connections through this vertex are impossible).
    pub fn is_delta_only(&self) -> bool {
        false
    }
}
