//! The photon-map proposal of Metropolis photon sampling (Fan, Chenney & Lai 2005, §5.3).
//!
//! On a path `… x_l  x_a  S*  x_d  S*  E` — `x_d` the first non-specular vertex seen from the eye,
//! `x_a` the non-specular vertex before it, `x_l = x_{a−1}` non-specular too (a diffuse point or
//! the light) — keep `x_l` and everything before it, and `x_d` and everything after it. Turn the
//! direction `x_d → x_{d−1}` by an angle `θ` uniform in `[0, γ)` about itself (azimuth uniform),
//! trace it back through surfaces that only scatter specularly (each lobe chosen as the BSDF
//! samples it) to the first surface that does not, `x'_a`, and connect `x'_a` to `x_l`. The new
//! `D S*` section is what a final-gather ray from `x_d` would have found, so the global photon
//! stored at the second diffuse point from the eye moves to where a gather reads it.
//!
//! **Density.** The new vertices are those of strategy `s = l + 1`'s camera walk from `x_d`,
//! except that the first direction comes from the cone (density `g = 1/(2πγ sin θ)` per steradian)
//! rather than from the BSDF at `x_d` (`p_σ`); specular lobes are chosen with the same
//! probabilities `P` in both. In the common measure of [`super::mutation`]:
//!
//! `T̃(ȳ|x̄) = g / (p_σ(ȳ) · I(C*_{l+1}(ȳ)))`.
//!
//! The paper's `T_PM` writes the same product in area measure, without the lobe probabilities
//! (its specular surfaces have one lobe) and without `sin θ`, which cancels between the two
//! directions here (`θ` is the angle between the same two directions).

use super::mutation::{Change, Mutation, Registration};
use super::perturbation::{bsdf_pdf, direction, scatters_diffusely, specular_only};
use super::state::PathState;
use super::walk::{cone_direction, cone_pdf, trace};
use crate::bsdf::TransportMode;
use crate::metropolis::ImportanceKind;
use crate::path::Vertex;
use crate::scene::Scene;
use mcmc_core::rng::uniform;
use mcmc_core::{ChainRng, Failure};

/// The paper's cone half-angle `γ = 30°`.
pub const DEFAULT_GAMMA_DEGREES: f64 = 30.0;

/// The registration of the photon-map proposal (weight 0 in path-space MLT; Metropolis photon
/// sampling gives it 0.2).
pub const REGISTRATION: Registration = Registration {
    name: "photon-map",
    default_weight: 0.0,
    build: |c| {
        Box::new(PhotonMapProposal {
            scene: c.scene,
            gamma: c.settings.photon.photon_map_gamma,
            max_edges: c.settings.max_edges,
            importance: c.settings.importance,
        })
    },
};

/// The vertices a photon-map proposal works on: `x_l` kept, `x_a` (and the specular vertices up
/// to `x_d`) replaced, `x_d` kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GatherSection {
    /// Last kept light-side vertex.
    pub l: usize,
    /// The first non-specular vertex from the eye.
    pub d: usize,
}

/// The section of `path` a photon-map proposal replaces, when the path has the form
/// `… (L|D) D S* D S* E` with `x_d` scattering diffusely.
pub fn gather_section(path: &super::FullPath) -> Option<GatherSection> {
    if path.edges() < 3 {
        return None;
    }
    let d = super::user_path::eye_diffuse(path)?;
    let a = (1..d).rev().find(|&i| !path.specular(i))?;
    let l = a - 1;
    (!path.specular(l)).then_some(GatherSection { l, d })
}

/// The photon-map proposal on a scene.
pub struct PhotonMapProposal<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Cone half-angle `γ` (radians).
    pub gamma: f64,
    /// Longest path (edges).
    pub max_edges: usize,
    /// Colour to scalar.
    pub importance: ImportanceKind,
}

impl PhotonMapProposal<'_> {
    fn record(section: GatherSection, added: usize) -> Change {
        Change {
            l: section.l as isize,
            m: section.d,
            added,
            pivot: 0,
        }
    }
}

impl Mutation for PhotonMapProposal<'_> {
    fn name(&self) -> &'static str {
        REGISTRATION.name
    }

    fn suitability(&self, x: &PathState) -> f64 {
        gather_section(&x.path).is_some() as u8 as f64
    }

    fn propose(&self, x: &PathState, rng: &mut ChainRng, y: &mut PathState) -> Result<(), Failure> {
        let section = gather_section(&x.path).ok_or(Failure::NotApplicable)?;
        let (xv, k) = (&x.path.vertices, x.path.edges());
        let GatherSection { l, d } = section;
        // The new section, walked from x_d toward the light.
        let axis = direction(&xv[d], &xv[d - 1]);
        let mut w = cone_direction(axis, self.gamma, rng);
        let mut from = xv[d].clone();
        let mut section_vertices: Vec<Vertex> = Vec::new();
        loop {
            let mut v = trace(self.scene, &from, w).ok_or(Failure::Failed)?;
            if !specular_only(&v) {
                section_vertices.push(v);
                break;
            }
            let b = v.bsdf.as_ref().ok_or(Failure::Failed)?;
            let s = b
                .sample(
                    v.wo,
                    uniform(rng),
                    [uniform(rng), uniform(rng)],
                    TransportMode::Radiance,
                )
                .ok_or(Failure::Failed)?;
            if !(s.delta && s.pdf > 0.0) {
                return Err(Failure::Failed);
            }
            v.delta = true;
            w = s.wi;
            from = v.clone();
            section_vertices.push(v);
            // The finished path would have l + 1 + |section| + (k − d + 1) vertices.
            if l + 1 + section_vertices.len() + (k - d) > self.max_edges {
                return Err(Failure::Failed);
            }
        }
        let added = section_vertices.len();
        if l + 1 + added + (k - d) > self.max_edges {
            return Err(Failure::Failed);
        }
        let yp = &mut y.path;
        yp.vertices.clear();
        yp.vertices.extend_from_slice(&xv[..=l]);
        yp.vertices.extend(section_vertices.into_iter().rev());
        yp.vertices.extend_from_slice(&xv[d..]);
        y.finish_candidate(
            self.scene,
            self.importance,
            x,
            Self::record(section, added),
            l + 1,
        );
        Ok(())
    }

    fn ln_density(&self, x: &PathState, y: &PathState, c: Change) -> f64 {
        let never = f64::NEG_INFINITY;
        let Some(section) = gather_section(&x.path) else {
            return never;
        };
        let GatherSection { l, d } = section;
        let k = x.path.edges();
        if c != Self::record(section, c.added)
            || c.added == 0
            || c.result_edges(k) != Some(y.path.edges())
            || y.path.edges() > self.max_edges
        {
            return never;
        }
        let (xv, yv) = (&x.path.vertices, &y.path.vertices);
        let yd = l + 1 + c.added;
        // ȳ's new section: x'_a non-specular and diffuse, then surfaces that only scatter
        // specularly, used specularly.
        let a = &yv[l + 1];
        if y.path.specular(l + 1) || specular_only(a) || !scatters_diffusely(a) {
            return never;
        }
        if !(l + 2..yd).all(|i| y.path.specular(i) && specular_only(&yv[i])) {
            return never;
        }
        let g = cone_pdf(
            direction(&xv[d], &xv[d - 1]),
            direction(&yv[yd], &yv[yd - 1]),
            self.gamma,
        );
        let p_sigma = bsdf_pdf(&yv[yd], &yv[yd + 1], &yv[yd - 1]);
        let i_s = y.strategy_importance(l + 1);
        if !(g > 0.0 && p_sigma > 0.0 && i_s > 0.0) {
            return never;
        }
        let ln = g.ln() - p_sigma.ln() - i_s.ln();
        if ln.is_nan() { never } else { ln }
    }
}
