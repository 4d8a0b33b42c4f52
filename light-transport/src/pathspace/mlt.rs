//! Path-space Metropolis light transport (Veach & Guibas 1997) on the shared Metropolis driver.
//!
//! Bootstrap and seeding: group `g` holds paths of `k = g + 1` edges made by a uniformly chosen
//! bidirectional strategy; a sample's importance weight is `I(f)/q_k = (k + 1) I(f) / Σ_s p_s`, so
//! the driver's per-group normalisations `b_k` are the image energy per path length, their sum
//! `b` normalises the image, and resampling the whole population in proportion to the weights
//! seeds the chains without start-up bias. Chains then move freely between lengths (bidirectional
//! and new-path mutations); the new-path mutation picks lengths in proportion to `b_k`. Sample `i`
//! of every length reads one key's numbers ([`KeyedStream`]), so its subpaths are walked once for
//! all lengths ([`NewPath::sample_every_length`]).
//!
//! With direct lighting rendered apart ([`crate::metropolis::SeparateDirect`]) the chains sample
//! paths of more than two edges only ([`Mutations::min_edges`]): the shorter lengths get no
//! bootstrap weight (so no seeds and no new paths), and a mutation proposing one is rejected.

use super::lambda_tuning::{LambdaTuning, tune_lambda_from};
use super::mutations::Mutations;
use super::new_path::NewPath;
use super::normal_change::{NormalChange, measure_normal_change};
use super::state::PathState;
use crate::Result;
use crate::manifold::WalkStats;
use crate::metropolis::{DIRECT_EDGES, DirectApart, Method};
use crate::sampler::KeyedStream;
use crate::scene::Scene;
use mcmc_core::kernel::Observer;
use mcmc_core::{Chain, ChainRng};
use std::sync::{Mutex, RwLock};

thread_local! {
    /// The state the bootstrap samples of a thread are evaluated in (its vectors reused).
    static STATE: std::cell::RefCell<PathState> = std::cell::RefCell::new(PathState::default());
}

/// Path-space MLT.
#[derive(Debug)]
pub struct PathMlt {
    /// The mutations.
    pub mutations: Mutations,
    new_path: RwLock<NewPath>,
    walks: Mutex<WalkStats>,
    tuning: RwLock<Option<LambdaTuning>>,
    /// How the warm-up measured `Δθ` of the specular probability (glossy chains).
    pilot: RwLock<Option<NormalChange>>,
    /// Whether new paths also count as independent samples of the image
    /// ([`PathMlt::with_large_step_mis`]).
    large_step_mis: bool,
}

impl PathMlt {
    /// Path-space MLT with `mutations`; errors on invalid probabilities or offsets.
    pub fn new(mutations: Mutations) -> Result<Self> {
        mutations.validate()?;
        Ok(Self {
            new_path: RwLock::new(NewPath::uniform(mutations.max_edges)),
            walks: Mutex::new(WalkStats::default()),
            tuning: RwLock::new(None),
            pilot: RwLock::new(None),
            large_step_mis: false,
            mutations,
        })
    }

    /// Count each new path twice, as a proposal and as an independent sample of the image,
    /// combined with the chains by the balance heuristic (Kelemen et al. 2002 §4 carried over to
    /// path space; [`crate::metropolis::record::LargeStepMis`]): a state `x` of `k` edges
    /// deposits `b / (I + p b P_len(k) / (k + 1))`, and a new path deposits that once more, times
    /// `p / p(x)` where `p(x)` is the chance of the new-path mutation from the state it was
    /// proposed from. Off by default (expected values alone).
    pub fn with_large_step_mis(mut self, on: bool) -> Self {
        self.large_step_mis = on;
        self
    }

    /// The manifold walks of the chains so far (the manifold perturbation's).
    pub fn walk_stats(&self) -> WalkStats {
        self.walks.lock().map_or_else(|e| *e.into_inner(), |g| *g)
    }

    /// How the warm-up chose `λ` (when the settings ask for it and the warm-up has run).
    pub fn tuning(&self) -> Option<LambdaTuning> {
        self.tuning.read().map_or_else(|e| *e.into_inner(), |g| *g)
    }

    /// How the warm-up measured `Δθ` (when glossy chains need it and the warm-up has run).
    pub fn pilot(&self) -> Option<NormalChange> {
        self.pilot.read().map_or_else(|e| *e.into_inner(), |g| *g)
    }

    /// The mutations the chains run: the settings', with `λ` as tuned and `Δθ` as measured.
    fn running(&self) -> Mutations {
        let mut m = self.mutations.clone();
        if let Some(t) = self.tuning() {
            m.manifold.lambda = t.lambda;
            m.manifold.tuning = Some(t);
        }
        if let Some(p) = self.pilot() {
            m.manifold.specular.normal_change = Some(p.delta_theta);
            m.manifold.pilot = Some(p);
        }
        m
    }

    /// The current new-path length distribution.
    pub fn new_path(&self) -> NewPath {
        self.new_path
            .read()
            .map(|g| g.clone())
            .unwrap_or_else(|e| e.into_inner().clone())
    }

    /// Independent sample `seed` of group `g` (paths of `g + 1` edges) into `state`, returning its
    /// bootstrap weight: strategy `s` uniform in `0 … k`, so the weight within its length is
    /// `(k + 1) I(f / Σ_s p_s)`.
    fn sample_independent(&self, scene: &Scene, g: usize, seed: u64, state: &mut PathState) -> f64 {
        let k = g + 1;
        if k < self.mutations.min_edges {
            return 0.0;
        }
        let mut stream = KeyedStream::new(seed);
        NewPath::sample(scene, self.mutations.importance, k, &mut stream, state);
        (k + 1) as f64 * state.contribution.importance
    }
}

impl DirectApart for PathMlt {
    fn without_direct(mut self) -> Self {
        self.mutations.min_edges = DIRECT_EDGES + 1;
        self
    }
    fn max_edges(&self) -> usize {
        self.mutations.max_edges
    }
}

impl Method for PathMlt {
    type State = PathState;

    fn groups(&self) -> usize {
        self.mutations.max_edges
    }

    fn independent(&self, scene: &Scene, g: usize, seed: u64) -> (PathState, f64) {
        let mut state = PathState::default();
        let w = self.sample_independent(scene, g, seed, &mut state);
        (state, w)
    }

    fn independent_weight(&self, scene: &Scene, g: usize, seed: u64) -> f64 {
        STATE.with_borrow_mut(|state| self.sample_independent(scene, g, seed, state))
    }

    fn shares_bootstrap_keys(&self) -> bool {
        true
    }

    /// Every length's sample of key `seed` from one camera and one light subpath walked to the
    /// longest length ([`NewPath::sample_every_length`]).
    fn independent_all(&self, scene: &Scene, seed: u64, out: &mut [(usize, f64)]) {
        out.fill((0, 0.0));
        let edges = (
            self.mutations.min_edges,
            self.mutations.max_edges.min(out.len()),
        );
        STATE.with_borrow_mut(|state| {
            NewPath::sample_every_length(
                scene,
                self.mutations.importance,
                edges,
                seed,
                state,
                |k, state| out[k - 1].1 = (k + 1) as f64 * state.contribution.importance,
            )
        });
    }

    fn ln_density(&self, _scene: &Scene, state: &PathState) -> f64 {
        super::mutations::ln_target_from(self.mutations.min_edges, state)
    }

    fn bootstrap_done(&self, group_normalisation: &[f64]) {
        let np = NewPath::from_energies(group_normalisation, self.mutations.min_edges);
        match self.new_path.write() {
            Ok(mut g) => *g = np,
            Err(e) => *e.into_inner() = np,
        }
    }

    fn mutate<O: Observer<PathState>>(
        &self,
        scene: &Scene,
        chain: &mut Chain<PathState>,
        n: u64,
        rng: &mut ChainRng,
        observer: &mut O,
    ) {
        // Validated in `new`: building the mixture cannot fail.
        let running = self.running();
        if let Ok(proposal) = running.proposal_recording(scene, self.new_path(), Some(&self.walks))
        {
            running.run(&proposal, chain, n, rng, observer);
        }
    }

    fn mutate_chunk<O: Observer<PathState>>(
        &self,
        scene: &Scene,
        chains: &mut [Chain<PathState>],
        rngs: &mut [ChainRng],
        n: u64,
        observer: &mut O,
    ) {
        // One mixture for the whole group (validated in `new`: building it cannot fail).
        let running = self.running();
        if let Ok(proposal) = running.proposal_recording(scene, self.new_path(), Some(&self.walks))
        {
            for (chain, rng) in chains.iter_mut().zip(rngs.iter_mut()) {
                running.run(&proposal, chain, n, rng, observer);
            }
        }
    }

    fn kinds(&self) -> Vec<String> {
        Mutations::kinds()
    }

    fn independent_proposals(&self) -> Option<usize> {
        // A new path is drawn as a bootstrap sample is (its length from `P_len`).
        let name = super::new_path::REGISTRATION.name;
        (self.mutations.probabilities.probability(name) > 0.0)
            .then(|| super::mutations::index_of(name))
            .flatten()
    }

    fn chains_span_groups(&self) -> bool {
        true
    }

    fn large_steps(&self) -> Option<(usize, f64)> {
        // The new-path mutation's share of the selection weights: its chance under fixed
        // selection, about its mean chance under suitability selection (any constant keeps the
        // estimate unbiased; `LargeStepMis`).
        let kind = self
            .independent_proposals()
            .filter(|_| self.large_step_mis)?;
        let p = self
            .mutations
            .probabilities
            .probability(super::new_path::REGISTRATION.name);
        (p > 0.0).then_some((kind, p))
    }

    fn large_step_density(&self, _group_normalisation: &[f64], b: f64) -> Vec<f64> {
        // A state of `k = g + 1` edges: a new path has density `P_len(k) / (k + 1)` against
        // `I = f / Σ_s p_s` (the new path's `T = P_len(k) / (k + 1) · Σ_s p_s`).
        let new_path = self.new_path();
        (0..self.mutations.max_edges)
            .map(|g| b * new_path.probability(g + 1) / (g + 2) as f64)
            .collect()
    }

    fn warm_up(&self, scene: &Scene, chains: &[Chain<PathState>], seed: u64) -> Result<()> {
        let m = &self.mutations;
        let manifold = m
            .probabilities
            .probability(super::manifold_perturbation::TOWARD_LIGHT.name)
            + m.probabilities
                .probability(super::manifold_perturbation::TOWARD_EYE.name);
        if manifold <= 0.0 {
            return Ok(());
        }
        let states: Vec<PathState> = chains.iter().map(|c| c.state.clone()).collect();
        if let Some(target) = m.manifold.target_acceptance {
            let t = tune_lambda_from(scene, m, target, &states, seed)?;
            match self.tuning.write() {
                Ok(mut g) => *g = Some(t),
                Err(e) => *e.into_inner() = Some(t),
            }
        }
        // Δθ of ψ by a pilot of the perturbation as it will run (λ tuned), when glossy vertices
        // may join chains and Δθ is not given.
        let running = self.running();
        let specular = running.manifold.specular;
        if specular.glossy && specular.normal_change.is_none() {
            let p = measure_normal_change(scene, &running, &states, seed)?;
            match self.pilot.write() {
                Ok(mut g) => *g = p,
                Err(e) => *e.into_inner() = p,
            }
        }
        Ok(())
    }

    fn details(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.large_step_mis {
            out.push("new path counted twice: as a proposal and as an independent sample (balance heuristic; --large-step-mis)".into());
        }
        if let Some(t) = self.tuning() {
            out.push(format!("lambda     {t}"));
        }
        if let Some(p) = self.pilot() {
            out.push(format!("glossy     {p}"));
        }
        let w = self.walk_stats();
        if w.walks > 0 {
            out.push(format!("walks      {}", w.summary()));
        }
        out
    }
}
