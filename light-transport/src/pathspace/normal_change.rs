//! The pilot that measures `Δθ` for the specular probability `ψ` (Jakob & Marschner 2012,
//! appendix A1: "the expected angular change Δθ of microsurface normals during a perturbation,
//! which is found by briefly running the Markov chain before rendering starts").
//!
//! From states distributed as the target (a driver's seeded chains, or paths resampled from
//! independent ones), the manifold perturbation proposes moves with every glossy vertex left free
//! (`ψ = 0`); at each glossy vertex whose microfacet normal a proposal changes, the angle between
//! the old and the new normal is recorded, and `Δθ` is their mean. The pilot's proposals are not
//! recorded and change no state: the rendering kernel is fixed before it starts.

use super::mutations::{MutationProbabilities, Mutations};
use super::new_path::NewPath;
use super::perturbation::direction;
use super::state::PathState;
use crate::scene::Scene;
use crate::{Error, Result};
use mcmc_core::rng::stream;

/// Most states the pilot proposes from.
const STATES: usize = 96;
/// Proposals per state (alternating the two directions).
const PROPOSALS: usize = 32;

/// What the pilot measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalChange {
    /// `Δθ`, radians.
    pub delta_theta: f64,
    /// Glossy vertices whose normal changed (the sample size).
    pub samples: u64,
    /// Proposals made.
    pub proposals: u64,
}

impl std::fmt::Display for NormalChange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Δθ = {:.4} rad measured by a pilot ({} glossy normals changed in {} proposals, not recorded)",
            self.delta_theta, self.samples, self.proposals
        )
    }
}

/// Whether vertex `i` of `state` is glossy in the sense of `ψ` (non-delta, every non-delta lobe
/// glossy): its microfacet normal, or `None`.
fn glossy_normal(state: &PathState, i: usize) -> Option<crate::math::DVec3> {
    let v = &state.path.vertices;
    if i == 0 || i + 1 >= v.len() || v[i].delta {
        return None;
    }
    let bsdf = v[i].bsdf.as_ref()?;
    let s = bsdf.summary();
    if !s.glossy || s.diffuse {
        return None;
    }
    bsdf.microfacet_normal(direction(&v[i], &v[i + 1]), direction(&v[i], &v[i - 1]))
}

/// Measure `Δθ` from `states` with the manifold perturbation of `mutations` (its `λ`, its walk).
/// `Ok(None)` when no proposal changed a glossy vertex's normal (no glossy vertex the perturbation
/// reaches: `Δθ` then does not matter).
pub fn measure_normal_change(
    scene: &Scene,
    mutations: &Mutations,
    states: &[PathState],
    seed: u64,
) -> Result<Option<NormalChange>> {
    let mut m = mutations.clone();
    m.probabilities = MutationProbabilities::manifold();
    m.manifold.specular.glossy = false;
    m.validate()?;
    let settings = m.settings(NewPath::uniform(m.max_edges));
    let directions = ["manifold-light", "manifold-eye"].map(|name| {
        Mutations::mutation(scene, &settings, name).ok_or_else(|| Error::InvalidParameter {
            name: "normal-change pilot".into(),
            reason: format!("the mutation {name} is not registered"),
        })
    });
    let [light, eye] = directions;
    let (light, eye) = (light?, eye?);
    let stride = states.len().div_ceil(STATES).max(1);
    let (mut sum, mut samples, mut proposals) = (0.0, 0u64, 0u64);
    let mut y = PathState::default();
    for (c, x) in states.iter().step_by(stride).enumerate() {
        let mut rng = stream(seed ^ 0x4E0A_11CE, c as u64);
        for j in 0..PROPOSALS {
            let mutation = if j % 2 == 0 { &light } else { &eye };
            if mutation.suitability(x) == 0.0 {
                continue;
            }
            proposals += 1;
            if mutation.propose(x, &mut rng, &mut y).is_err() || !y.carries_light() {
                continue;
            }
            if y.path.vertices.len() != x.path.vertices.len() {
                continue;
            }
            for i in 1..x.path.vertices.len().saturating_sub(1) {
                if let (Some(a), Some(b)) = (glossy_normal(x, i), glossy_normal(&y, i)) {
                    let angle = a.dot(b).clamp(-1.0, 1.0).acos();
                    if angle > 0.0 {
                        sum += angle;
                        samples += 1;
                    }
                }
            }
        }
    }
    Ok((samples > 0).then(|| NormalChange {
        delta_theta: sum / samples as f64,
        samples,
        proposals,
    }))
}
