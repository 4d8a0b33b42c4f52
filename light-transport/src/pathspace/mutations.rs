//! The registry of path-space mutations and the mixture they run as: every mutation implements
//! [`Mutation`] in its own file and is listed once in [`REGISTRY`]; path-space MLT, ERPT and the
//! identity-chart moves of charted MLT choose among them with [`MutationProbabilities`] and run
//! them as one `mcmc_core` [`Mixture`] — per component (each mutation's own ratio) or combined
//! (`Σ_k P_k T̃_k`, seed 002 eq. 4) — whose components are chosen with fixed probabilities or in
//! proportion to their suitability for the current path (exactly: the selection probabilities
//! enter the ratio). Mutations that do not apply to the current path, or whose construction
//! fails, count as rejected proposals (the current path is recorded with weight 1) and are
//! counted.

use super::manifold_perturbation::ManifoldPerturbationSettings;
use super::mutation::{Mutation, MutationContext, MutationProposal, Registration};
use super::new_path::NewPath;
use super::perturbation::PerturbationSettings;
use super::state::PathState;
use super::user_path::UserPaths;
use crate::metropolis::ImportanceKind;
use crate::scene::Scene;
use crate::{Error, Result};
use mcmc_core::kernel::Observer;
use mcmc_core::proposals::{Mixture, MixtureRule, Selection};
use mcmc_core::{Chain, ChainRng, Kernel, MetropolisHastings, Proposal, Proposed};
use std::fmt;
use std::str::FromStr;
use std::sync::Arc;

type Component<'a> = Box<dyn mcmc_core::Proposal<PathState> + Send + Sync + 'a>;

const REGISTRY_USER_PATH: usize = 1;

/// Every path-space mutation, in statistics order. A new mutation is one file and one line here.
pub const REGISTRY: &[Registration] = &[
    super::bidirectional::REGISTRATION,
    super::user_path::REGISTRATION,
    super::lens_subpath::REGISTRATION,
    super::lens::REGISTRATION,
    super::caustic::REGISTRATION,
    super::multi_chain::REGISTRATION,
    super::new_path::REGISTRATION,
    super::manifold_perturbation::TOWARD_LIGHT,
    super::manifold_perturbation::TOWARD_EYE,
    super::photon_map_proposal::REGISTRATION,
];

/// The index of the registered mutation `name`.
pub fn index_of(name: &str) -> Option<usize> {
    REGISTRY.iter().position(|r| r.name == name)
}

/// The names of the registered mutations.
pub fn names() -> Vec<String> {
    REGISTRY.iter().map(|r| r.name.to_string()).collect()
}

/// The target of path-space chains in the common measure of [`super::mutation`]: 1 on paths that
/// carry light, 0 elsewhere (log density 0 or `−∞`).
pub fn ln_target(s: &PathState) -> f64 {
    if s.carries_light() {
        0.0
    } else {
        f64::NEG_INFINITY
    }
}

/// [`ln_target`] restricted to paths of at least `min_edges` edges (0 on shorter ones: chains
/// that leave those paths to another estimator, e.g. a direct-lighting pass).
pub fn ln_target_from(min_edges: usize, s: &PathState) -> f64 {
    if s.path.edges() < min_edges {
        f64::NEG_INFINITY
    } else {
        ln_target(s)
    }
}

/// Selection weights of the registered mutations (normalised when used), in [`REGISTRY`] order.
///
/// Defaults: bidirectional 0.25, lens subpath 0.1, lens 0.2, caustic 0.2, multi-chain 0.15, new
/// path 0.1 — the bidirectional and new-path mutations keep the chain ergodic, the perturbations
/// explore locally (their shares follow the practical-MLT paper's equal use of perturbations).
#[derive(Clone, Debug, PartialEq)]
pub struct MutationProbabilities(pub Vec<f64>);

impl Default for MutationProbabilities {
    fn default() -> Self {
        Self(REGISTRY.iter().map(|r| r.default_weight).collect())
    }
}

impl MutationProbabilities {
    /// Only the named mutations with the given weights (the others get 0).
    pub fn of(weights: &[(&str, f64)]) -> Result<Self> {
        let mut p = vec![0.0; REGISTRY.len()];
        for (name, w) in weights {
            let i = index_of(name).ok_or_else(|| unknown(name))?;
            p[i] += w;
        }
        let out = Self(p);
        out.validate()?;
        Ok(out)
    }

    /// Only `name` and the new-path mutation, half each (the per-mutation convergence tests).
    pub fn with_new_path(name: &str) -> Result<Self> {
        Self::of(&[(name, 0.5), ("new-path", 0.5)])
    }

    /// The manifold perturbation only, half in each direction (manifold exploration path
    /// tracing, MEPT).
    pub fn manifold() -> Self {
        Self::of(&[("manifold-light", 0.5), ("manifold-eye", 0.5)])
            .unwrap_or_else(|_| Self::default())
    }

    /// Manifold exploration MLT (MEMLT): bidirectional 0.3, the manifold perturbation 0.6 (0.3
    /// each direction), new path 0.1.
    pub fn manifold_exploration() -> Self {
        Self::of(&[
            ("bidirectional", 0.3),
            ("manifold-light", 0.3),
            ("manifold-eye", 0.3),
            ("new-path", 0.1),
        ])
        .unwrap_or_else(|_| Self::default())
    }

    /// The perturbations only (energy redistribution path tracing): lens 0.4, caustic 0.3,
    /// multi-chain 0.3.
    pub fn perturbations() -> Self {
        Self::of(&[("lens", 0.4), ("caustic", 0.3), ("multi-chain", 0.3)])
            .unwrap_or_else(|_| Self::default())
    }

    /// The normalised probability of the mutation `name` (0 for unknown names).
    pub fn probability(&self, name: &str) -> f64 {
        let total: f64 = self.0.iter().sum();
        index_of(name).map_or(0.0, |i| self.0[i] / total)
    }

    /// Check: one non-negative finite value per registered mutation, not all zero.
    pub fn validate(&self) -> Result<()> {
        let total: f64 = self.0.iter().sum();
        if self.0.len() == REGISTRY.len()
            && self.0.iter().all(|p| p.is_finite() && *p >= 0.0)
            && total > 0.0
        {
            Ok(())
        } else {
            Err(Error::InvalidParameter {
                name: "mutation probabilities".into(),
                reason: format!("need non-negative finite values, not all zero; got {self}"),
            })
        }
    }
}

fn unknown(name: &str) -> Error {
    Error::InvalidParameter {
        name: "mutations".into(),
        reason: format!("unknown mutation '{name}' (known: {})", names().join(", ")),
    }
}

impl fmt::Display for MutationProbabilities {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let parts: Vec<String> = REGISTRY
            .iter()
            .zip(&self.0)
            .map(|(r, p)| format!("{}={p}", r.name))
            .collect();
        f.write_str(&parts.join(","))
    }
}

impl FromStr for MutationProbabilities {
    type Err = Error;

    /// `name=p,name=p,…` with the registered names; unnamed mutations get 0.
    fn from_str(s: &str) -> Result<Self> {
        let mut pairs = Vec::new();
        for part in s.split(',').map(str::trim).filter(|x| !x.is_empty()) {
            let bad = |reason: String| Error::InvalidParameter {
                name: "mutations".into(),
                reason,
            };
            let (name, value) = part
                .split_once('=')
                .ok_or_else(|| bad(format!("expected name=probability, got '{part}'")))?;
            let v: f64 = value
                .trim()
                .parse()
                .map_err(|_| bad(format!("'{}' is not a number", value.trim())))?;
            pairs.push((name.trim(), v));
        }
        Self::of(&pairs)
    }
}

/// The settings every mutation is built from.
#[derive(Clone, Debug, PartialEq)]
pub struct MutationSettings {
    /// Longest path (edges).
    pub max_edges: usize,
    /// Colour to scalar.
    pub importance: ImportanceKind,
    /// Offsets of the perturbations.
    pub perturbation: PerturbationSettings,
    /// The manifold perturbation's `λ` and walk.
    pub manifold: ManifoldPerturbationSettings,
    /// Lengths of new paths.
    pub new_path: NewPath,
    /// The proposals of Metropolis photon sampling.
    pub photon: PhotonProposals,
}

/// How the user-path proposal joins a mixture run with the per-component rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum UserPathRule {
    /// With the bidirectional mutation as one component accepting by the combined rule (Fan,
    /// Chenney & Lai 2005, eq. 7).
    #[default]
    Hybrid,
    /// On its own ratio, like every other component — exact, but from a path away from every
    /// user path its candidates can never be accepted (the reverse move is impossible). Kept to
    /// show it.
    PerComponent,
    /// Deliberately wrong (a test of the tests): user-path candidates accepted with the
    /// bidirectional mutation's ratio `T_BD(x̄|ȳ) / T_BD(ȳ|x̄)` — a reading of the paper's remark
    /// that the bidirectional mutation can make any path, which ignores how concentrated the
    /// user-path proposal is (eq. 7 weighs both densities).
    BidirectionalRatio,
}

/// Settings of the proposals of Metropolis photon sampling (Fan, Chenney & Lai 2005, §5).
#[derive(Clone, Debug, PartialEq)]
pub struct PhotonProposals {
    /// Cone half-angle `γ` of the photon-map proposal, radians (30°).
    pub photon_map_gamma: f64,
    /// The user paths (empty: the user-path proposal never applies).
    pub user_paths: Arc<UserPaths>,
    /// How the user-path proposal is mixed under the per-component rule.
    pub user_path_rule: UserPathRule,
}

impl Default for PhotonProposals {
    fn default() -> Self {
        Self {
            photon_map_gamma: super::photon_map_proposal::DEFAULT_GAMMA_DEGREES.to_radians(),
            user_paths: Arc::new(UserPaths::default()),
            user_path_rule: UserPathRule::Hybrid,
        }
    }
}

impl PhotonProposals {
    /// Check `γ`.
    pub fn validate(&self) -> Result<()> {
        if self.photon_map_gamma > 0.0 && self.photon_map_gamma <= std::f64::consts::FRAC_PI_2 {
            Ok(())
        } else {
            Err(Error::InvalidParameter {
                name: "photon-map cone".into(),
                reason: format!(
                    "γ must lie in (0°, 90°], got {}°",
                    self.photon_map_gamma.to_degrees()
                ),
            })
        }
    }
}

/// A mutation set: settings, selection weights, and the mixture rules.
#[derive(Clone, Debug, PartialEq)]
pub struct Mutations {
    /// Longest path (edges).
    pub max_edges: usize,
    /// Shortest path (edges) the chains sample: 1, or more when the shorter paths are rendered
    /// apart (`crate::metropolis::SeparateDirect`); proposals of shorter paths are rejected.
    pub min_edges: usize,
    /// Colour to scalar.
    pub importance: ImportanceKind,
    /// Mutation selection weights.
    pub probabilities: MutationProbabilities,
    /// Offsets of the perturbations.
    pub perturbation: PerturbationSettings,
    /// The manifold perturbation's `λ` and walk.
    pub manifold: ManifoldPerturbationSettings,
    /// Per-component or combined transition densities.
    pub rule: MixtureRule,
    /// Fixed selection, or in proportion to suitability for the current path.
    pub selection: Selection,
    /// The proposals of Metropolis photon sampling (photon-map cone, user paths).
    pub photon: PhotonProposals,
}

impl Mutations {
    /// The defaults for paths of at most `max_edges` edges: the default probabilities, each
    /// mutation's own ratio, suitability-weighted selection.
    pub fn new(max_edges: usize) -> Self {
        Self {
            max_edges,
            min_edges: 1,
            importance: ImportanceKind::default(),
            probabilities: MutationProbabilities::default(),
            perturbation: PerturbationSettings::default(),
            manifold: ManifoldPerturbationSettings::default(),
            rule: MixtureRule::PerComponent,
            selection: Selection::Suitability,
            photon: PhotonProposals::default(),
        }
    }

    /// Check the settings.
    pub fn validate(&self) -> Result<()> {
        self.probabilities.validate()?;
        self.perturbation.validate()?;
        self.manifold.validate()?;
        self.photon.validate()?;
        if self
            .probabilities
            .probability(super::user_path::REGISTRATION.name)
            > 0.0
            && self.photon.user_paths.is_empty()
        {
            return Err(Error::InvalidParameter {
                name: "mutations".into(),
                reason: "the user-path proposal needs user paths (--user-paths FILE)".into(),
            });
        }
        let manifold = self
            .probabilities
            .probability(super::manifold_perturbation::TOWARD_LIGHT.name)
            + self
                .probabilities
                .probability(super::manifold_perturbation::TOWARD_EYE.name);
        if manifold > 0.0 && self.rule == MixtureRule::Combined {
            return Err(Error::InvalidParameter {
                name: "mixture rule".into(),
                reason:
                    "the manifold perturbation runs with the per-component rule only (its density \
                         for pairs another mutation proposed would need the walk replayed)"
                        .into(),
            });
        }
        if self.max_edges == 0 {
            return Err(Error::InvalidParameter {
                name: "max depth".into(),
                reason: "path-space mutations need paths of at least one edge".into(),
            });
        }
        if !(1..=self.max_edges).contains(&self.min_edges) {
            return Err(Error::InvalidParameter {
                name: "shortest path".into(),
                reason: format!(
                    "path-space chains on paths of {} to {} edges sample nothing",
                    self.min_edges, self.max_edges
                ),
            });
        }
        Ok(())
    }

    /// The settings the mutations are built from, with new paths of lengths `new_path`.
    pub fn settings(&self, new_path: NewPath) -> MutationSettings {
        MutationSettings {
            max_edges: self.max_edges,
            importance: self.importance,
            perturbation: self.perturbation,
            manifold: self.manifold,
            new_path,
            photon: self.photon.clone(),
        }
    }

    /// The registered mutation `name` built on `scene`.
    pub fn mutation<'a>(
        scene: &'a Scene,
        settings: &MutationSettings,
        name: &str,
    ) -> Option<Box<dyn Mutation + 'a>> {
        let r = REGISTRY.iter().find(|r| r.name == name)?;
        Some((r.build)(&MutationContext {
            scene,
            settings,
            walks: None,
        }))
    }

    /// The mixture of the mutations with positive weight, as an `mcmc_core` proposal whose kinds
    /// are all registered mutations in [`REGISTRY`] order.
    pub fn proposal<'a>(
        &self,
        scene: &'a Scene,
        new_path: NewPath,
    ) -> Result<Mixture<'a, PathState>> {
        self.proposal_recording(scene, new_path, None)
    }

    /// [`Mutations::proposal`] whose manifold walks are added to `walks` (when the mixture is
    /// dropped).
    pub fn proposal_recording<'a>(
        &self,
        scene: &'a Scene,
        new_path: NewPath,
        walks: Option<&'a std::sync::Mutex<crate::manifold::WalkStats>>,
    ) -> Result<Mixture<'a, PathState>> {
        let settings = self.settings(new_path);
        let context = MutationContext {
            scene,
            settings: &settings,
            walks,
        };
        const _: () = assert!(REGISTRY.len() <= super::state::CACHED_MUTATIONS);
        let bad = |e: mcmc_core::McmcError| Error::InvalidParameter {
            name: "mutation probabilities".into(),
            reason: e.to_string(),
        };
        let reversed = self.photon.user_path_rule == UserPathRule::BidirectionalRatio;
        let mut components: Vec<(f64, Component<'a>)> = REGISTRY
            .iter()
            .zip(&self.probabilities.0)
            .enumerate()
            .map(|(i, (r, &w))| {
                let mut mutation = (r.build)(&context);
                if reversed && i == REGISTRY_USER_PATH {
                    mutation = Box::new(super::user_path::BidirectionalRatio {
                        user_path: mutation,
                        bidirectional: (REGISTRY[0].build)(&context),
                    });
                }
                let p: Component<'a> = Box::new(MutationProposal {
                    mutation,
                    index: Some(i),
                });
                (w, p)
            })
            .collect();
        // Eq. 7 of Fan, Chenney & Lai 2005: under the per-component rule, the user-path proposal
        // and the bidirectional mutation form one component (chosen with P_UP + P_BD) whose
        // choice between the two is accepted by the combined rule. They stand first and second
        // in the registry, so statistics keep the registry's order.
        let p_up = self.probabilities.0[REGISTRY_USER_PATH];
        if self.rule == MixtureRule::PerComponent
            && self.photon.user_path_rule == UserPathRule::Hybrid
            && p_up > 0.0
        {
            // (REGISTRY[0] is the bidirectional mutation; a unit test checks it.)
            let mut pair = components.drain(..2);
            let (bd, up) = (pair.next(), pair.next());
            drop(pair);
            if let (Some(bd), Some(up)) = (bd, up) {
                let total = bd.0 + up.0;
                let hybrid = Mixture::new(vec![bd, up], MixtureRule::Combined)
                    .map_err(bad)?
                    .with_selection(self.selection);
                components.insert(0, (total, Box::new(hybrid)));
            }
        }
        Mixture::new(components, self.rule)
            .map(|m| m.with_selection(self.selection))
            .map_err(bad)
    }

    /// `n` Metropolis–Hastings steps of `chain` with `proposal` (from [`Mutations::proposal`]).
    /// Path-space chains carry no absolute density (paths with specular vertices have none): in
    /// the common measure the target is 1 on paths of at least [`Mutations::min_edges`] edges that
    /// carry light, so `chain.ln_density` is 0.
    pub fn run<O: Observer<PathState>>(
        &self,
        proposal: &Mixture<'_, PathState>,
        chain: &mut Chain<PathState>,
        n: u64,
        rng: &mut ChainRng,
        observer: &mut O,
    ) {
        chain.ln_density = 0.0;
        let min_edges = self.min_edges;
        let proposal = ChoiceRecording {
            mixture: proposal,
            kind: index_of(super::new_path::REGISTRATION.name),
        };
        let mut mh =
            MetropolisHastings::new(|s: &PathState| ln_target_from(min_edges, s), proposal);
        for _ in 0..n {
            mh.step(chain, rng, observer);
        }
    }

    /// Statistics names (the registered mutations).
    pub fn kinds() -> Vec<String> {
        names()
    }
}

/// The mixture of [`Mutations::run`], which also writes into each candidate of move kind `kind`
/// (the new-path mutation) the probability with which the mixture chose it from the current state
/// ([`PathState::chosen_with`]): with suitability selection it depends on the state, and the
/// large steps' estimate divides by it ([`crate::metropolis::record::LargeStepMis`]).
struct ChoiceRecording<'p, 'a> {
    mixture: &'p Mixture<'a, PathState>,
    kind: Option<usize>,
}

impl Proposal<PathState> for ChoiceRecording<'_, '_> {
    fn propose(&self, x: &PathState, y: &mut PathState, rng: &mut ChainRng) -> Proposed {
        let p = self.mixture.propose(x, y, rng);
        if p.failure.is_none() && Some(p.kind) == self.kind {
            y.chosen_with = Some(self.mixture.ln_selection_of_kind(x, p.kind).exp());
        }
        p
    }
    fn ln_transition_density(&self, from: &PathState, to: &PathState) -> Option<f64> {
        self.mixture.ln_transition_density(from, to)
    }
    fn ln_pair_densities(&self, x: &PathState, y: &PathState) -> Option<(f64, f64)> {
        self.mixture.ln_pair_densities(x, y)
    }
    fn suitability(&self, x: &PathState) -> f64 {
        self.mixture.suitability(x)
    }
    fn ln_move_density(&self, from: &PathState, to: &PathState, kind: usize) -> Option<f64> {
        self.mixture.ln_move_density(from, to, kind)
    }
    fn outcomes(&self, x: &PathState) -> Option<Vec<mcmc_core::Outcome<PathState>>> {
        self.mixture.outcomes(x)
    }
    fn kinds(&self) -> Vec<String> {
        self.mixture.kinds()
    }
    fn kind_count(&self) -> usize {
        self.mixture.kind_count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hybrid_pair_stands_first_in_the_registry() {
        assert_eq!(REGISTRY[0].name, "bidirectional");
        assert_eq!(REGISTRY[REGISTRY_USER_PATH].name, "user-path");
    }
}
