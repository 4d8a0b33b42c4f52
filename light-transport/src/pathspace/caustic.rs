//! The caustic perturbation (Veach & Guibas 1997, §5.3.3; practical-MLT paper §3.4): for paths
//! `(L|D) S* D E`, turn the direction leaving the last non-specular vertex before the eye's by an
//! angular offset, follow the specular chain, and connect to the kept lens point (the strategy
//! `s = k`). Densities in [`super::perturbation`]: `T̃ = g_θ / (p_σ(ȳ) Π P(ȳ) I(C*_k(ȳ)))`.

use super::mutation::{Change, Mutation, Registration};
use super::perturbation::{
    PerturbationSettings, direction, follow_specular, ln_branch_probabilities,
    same_specular_structure, scatters_diffusely,
};
use super::state::PathState;
use super::walk::{angular_offset, trace_between};
use crate::bsdf::TransportMode;
use crate::math::DVec3;
use crate::metropolis::ImportanceKind;
use crate::path::VertexKind;
use crate::scene::Scene;
use mcmc_core::{ChainRng, Failure};

/// The registration of the caustic perturbation.
pub const REGISTRATION: Registration = Registration {
    name: "caustic",
    default_weight: 0.2,
    build: |c| {
        Box::new(Caustic {
            scene: c.scene,
            settings: c.settings.perturbation,
            importance: c.settings.importance,
        })
    },
};

/// The caustic perturbation on a scene.
struct Caustic<'a> {
    scene: &'a Scene,
    settings: PerturbationSettings,
    importance: ImportanceKind,
}

impl Caustic<'_> {
    /// The vertex `i0` whose outgoing direction turns, when the perturbation applies to `x`.
    fn start(&self, x: &PathState) -> Option<usize> {
        let xp = &x.path;
        let k = xp.edges();
        if k < 2 || xp.specular(k - 1) || !scatters_diffusely(&xp.vertices[k - 1]) {
            return None;
        }
        let i0 = (0..k - 1).rev().find(|&i| !xp.specular(i)).unwrap_or(0);
        let w = direction(&xp.vertices[i0], &xp.vertices[i0 + 1]);
        let ok = self.first_pdf(xp, i0, w) > 0.0
            && x.strategy_importance(k) > 0.0
            && ln_branch_probabilities(xp, i0 + 1..k - 1, false, TransportMode::Importance)
                > f64::NEG_INFINITY;
        ok.then_some(i0)
    }

    /// `p_σ` of leaving `v_{i0}` of `path` in direction `w`: the emitter's or the BSDF's.
    fn first_pdf(&self, path: &super::FullPath, i0: usize, w: DVec3) -> f64 {
        let v = &path.vertices[i0];
        match v.kind {
            VertexKind::Light { light } => {
                self.scene.lights[light as usize].pdf_direction(v.n(), w)
            }
            _ if i0 >= 1 => v
                .bsdf
                .as_ref()
                .map_or(0.0, |b| b.pdf(direction(v, &path.vertices[i0 - 1]), w)),
            _ => 0.0,
        }
    }
}

impl Mutation for Caustic<'_> {
    fn name(&self) -> &'static str {
        REGISTRATION.name
    }

    fn suitability(&self, x: &PathState) -> f64 {
        self.start(x).is_some() as u8 as f64
    }

    fn propose(&self, x: &PathState, rng: &mut ChainRng, y: &mut PathState) -> Result<(), Failure> {
        let scene = self.scene;
        let i0 = self.start(x).ok_or(Failure::NotApplicable)?;
        let xp = &x.path;
        let k = xp.edges();
        let w_x = direction(&xp.vertices[i0], &xp.vertices[i0 + 1]);
        let mut w = angular_offset(w_x, self.settings.theta1, self.settings.theta2, rng);
        // ȳ is walked in place: x̄'s v_0 … v_{i0} and lens point kept, v'_{i0+1} … v'_{k−1}
        // traced into their slots (each trace rewrites its slot whole).
        y.path.splice_from(xp, i0 + 1, k + 1, 1);
        let yv = &mut y.path.vertices;
        for i in i0 + 1..k {
            if !trace_between(scene, yv, i - 1, i, w) {
                return Err(Failure::Failed);
            }
            let v = &mut yv[i];
            if i < k - 1 {
                w = follow_specular(v, xp, i, TransportMode::Importance)?;
            } else if !scatters_diffusely(v) {
                return Err(Failure::Failed);
            }
        }
        let change = Change {
            l: i0 as isize,
            m: k,
            added: k - 1 - i0,
            pivot: 0,
        };
        y.finish_candidate(scene, self.importance, x, change, k);
        Ok(())
    }

    fn ln_density(&self, x: &PathState, y: &PathState, c: Change) -> f64 {
        let never = f64::NEG_INFINITY;
        let Some(i0) = self.start(x) else {
            return never;
        };
        let (xp, yp) = (&x.path, &y.path);
        let k = xp.edges();
        let record = Change {
            l: i0 as isize,
            m: k,
            added: k - 1 - i0,
            pivot: 0,
        };
        if yp.edges() != k
            || c != record
            || !same_specular_structure(xp, yp, i0 + 1..k - 1)
            || yp.specular(k - 1)
            || !scatters_diffusely(&yp.vertices[k - 1])
        {
            return never;
        }
        let (xv, yv) = (&xp.vertices, &yp.vertices);
        let w_y = direction(&yv[i0], &yv[i0 + 1]);
        let g = self
            .settings
            .angular_offset_pdf(direction(&xv[i0], &xv[i0 + 1]), w_y);
        let p_sigma = self.first_pdf(yp, i0, w_y);
        let i_k = y.strategy_importance(k);
        if !(g > 0.0 && p_sigma > 0.0 && i_k > 0.0) {
            return never;
        }
        let ln = g.ln()
            - p_sigma.ln()
            - i_k.ln()
            - ln_branch_probabilities(yp, i0 + 1..k - 1, false, TransportMode::Importance);
        if ln.is_nan() { never } else { ln }
    }
}
