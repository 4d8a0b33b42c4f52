//! Choosing the manifold perturbation's `λ` automatically, beyond Jakob & Marschner (2012), who
//! set it by hand "to achieve a desired acceptance ratio" and remark (§5.1) that it could be
//! automated with adaptive MCMC.
//!
//! A warm-up runs chains of the manifold perturbation alone (both directions) from independent
//! paths and moves `ln λ` by stochastic approximation (Robbins & Monro 1951) toward a target
//! acceptance: after each batch, `ln λ ← ln λ + 4 γ_t (a* − â_t)` with `γ_t = 1/(t + 1)^0.6` (larger
//! `λ` means smaller steps and more acceptances). The result is the mean of `ln λ` over the second
//! half of the batches, and it is **frozen** before rendering: the recorded chains are ordinary
//! Metropolis–Hastings chains with a fixed kernel, so adaptation cannot bias them (adapting during
//! the recorded run would need diminishing-adaptation arguments that this avoids). The warm-up is
//! deterministic for a given seed.

use super::mutations::{MutationProbabilities, Mutations};
use super::new_path::NewPath;
use super::state::PathState;
use crate::sampler::IndependentStream;
use crate::scene::Scene;
use crate::{Error, Result};
use mcmc_core::Chain;
use mcmc_core::rng::{stream, uniform};

/// What the warm-up found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LambdaTuning {
    /// The acceptance aimed at.
    pub target: f64,
    /// `λ` before the warm-up.
    pub initial: f64,
    /// The frozen `λ`.
    pub lambda: f64,
    /// Acceptance of the manifold perturbation in the last batch.
    pub acceptance: f64,
    /// Mutations of the warm-up.
    pub mutations: u64,
}

impl std::fmt::Display for LambdaTuning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "λ tuned from {:.3} to {:.3} for acceptance {:.2} (last warm-up batch {:.3}; {} warm-up mutations, not recorded)",
            self.initial, self.lambda, self.target, self.acceptance, self.mutations
        )
    }
}

/// Warm-up chains.
const CHAINS: usize = 96;
/// Independent paths per path length from which the chains are resampled.
const POOL: usize = 400;
/// Batches (updates of `λ`).
const BATCHES: usize = 40;
/// Gain of the updates: the acceptance depends weakly on `ln λ` (on the pool it falls from 0.9 to
/// 0.4 as `λ` goes from 50 to 3), so a step of `(a* − â)` alone moves too slowly.
const GAIN: f64 = 4.0;
/// Mutations per chain per batch.
const STEPS: u64 = 16;

/// The warm-up's mutations: `mutations` with the manifold perturbation alone (after checking that
/// `target` is an acceptance in `(0, 1)`).
fn warm_up_mutations(mutations: &Mutations, target: f64) -> Result<Mutations> {
    if !(target > 0.0 && target < 1.0) {
        return Err(Error::InvalidParameter {
            name: "λ target acceptance".into(),
            reason: format!("need a value in (0, 1), got {target}"),
        });
    }
    let mut m = mutations.clone();
    m.probabilities = MutationProbabilities::manifold();
    m.validate()?;
    Ok(m)
}

/// Tune `mutations.manifold.lambda` toward acceptance `target` (in `(0, 1)`) on `scene`, from
/// warm-up chains resampled from independent paths (for integrators without a seeded population,
/// such as MEPT); returns the frozen value and its record. Errors when no path the perturbation
/// applies to is found.
pub fn tune_lambda(
    scene: &Scene,
    mutations: &Mutations,
    target: f64,
    seed: u64,
) -> Result<LambdaTuning> {
    let m = warm_up_mutations(mutations, target)?;
    let states = resampled_states(scene, &m, seed)?;
    tune_lambda_from(scene, mutations, target, &states, seed)
}

/// Up to 96 states for a warm-up or a pilot of the manifold perturbation (for integrators without
/// a seeded population, such as MEPT): paths of every length that `m`'s mixture can move,
/// resampled in proportion to their importance weights from independent ones.
pub fn resampled_states(scene: &Scene, m: &Mutations, seed: u64) -> Result<Vec<PathState>> {
    let probe = m.proposal(scene, NewPath::uniform(m.max_edges))?;
    // Warm-up chains start from paths resampled in proportion to their importance weights (as
    // the driver seeds its chains), among independent paths of every length that the
    // perturbation can move: they start near the target, not at the sampler's distribution.
    let mut pool: Vec<(PathState, f64)> = Vec::new();
    for attempt in 0..(POOL * m.max_edges) as u64 {
        let k = 1 + (attempt as usize % m.max_edges);
        let mut s = IndependentStream::new(stream(seed ^ 0x1A4B_DA00, attempt));
        let mut state = PathState::default();
        if NewPath::sample(scene, m.importance, k, &mut s, &mut state)
            && state.carries_light()
            && mcmc_core::Proposal::suitability(&probe, &state) > 0.0
        {
            let w = (k + 1) as f64 * state.contribution.importance;
            pool.push((state, w));
        }
    }
    let total_weight: f64 = pool.iter().map(|p| p.1).sum();
    let mut pick = stream(seed ^ 0x1A4B_DA02, 0);
    let mut states: Vec<PathState> = Vec::with_capacity(CHAINS);
    if total_weight > 0.0 {
        for _ in 0..CHAINS {
            let mut u = uniform(&mut pick) * total_weight;
            let chosen = pool
                .iter()
                .find(|p| {
                    u -= p.1;
                    u < 0.0
                })
                .unwrap_or(&pool[pool.len() - 1]);
            states.push(chosen.0.clone());
        }
    }
    Ok(states)
}

/// [`tune_lambda`] from given warm-up states (e.g. a Metropolis driver's seeded chains, which
/// are distributed as the target): copies of up to 96 of those the perturbation can move run the
/// warm-up; the states themselves are not changed.
pub fn tune_lambda_from(
    scene: &Scene,
    mutations: &Mutations,
    target: f64,
    states: &[PathState],
    seed: u64,
) -> Result<LambdaTuning> {
    let mut m = warm_up_mutations(mutations, target)?;
    let probe = m.proposal(scene, NewPath::uniform(m.max_edges))?;
    let movable: Vec<&PathState> = states
        .iter()
        .filter(|s| mcmc_core::Proposal::suitability(&probe, *s) > 0.0)
        .collect();
    drop(probe);
    let stride = movable.len().div_ceil(CHAINS).max(1);
    let mut chains: Vec<Chain<PathState>> = movable
        .iter()
        .step_by(stride)
        .filter_map(|s| Chain::with_density((*s).clone(), 0.0).ok())
        .collect();
    if chains.is_empty() {
        return Err(Error::InvalidParameter {
            name: "λ tuning".into(),
            reason: "found no path that the manifold perturbation can move".into(),
        });
    }
    let initial = m.manifold.lambda;
    let mut ln_lambda = initial.ln();
    let (mut sum, mut count, mut acceptance, mut total) = (0.0, 0, 0.0, 0);
    let mut rngs: Vec<_> = (0..chains.len())
        .map(|c| stream(seed ^ 0x1A4B_DA01, c as u64))
        .collect();
    for t in 0..BATCHES {
        m.manifold.lambda = ln_lambda.exp();
        let proposal = m.proposal(scene, NewPath::uniform(m.max_edges))?;
        let (mut proposed, mut accepted) = (0u64, 0u64);
        for (chain, rng) in chains.iter_mut().zip(rngs.iter_mut()) {
            let before = chain.stats.total();
            m.run(&proposal, chain, STEPS, rng, &mut ());
            let after = chain.stats.total();
            proposed +=
                after.proposed - before.proposed - (after.not_applicable - before.not_applicable);
            accepted += after.accepted - before.accepted;
        }
        total += STEPS * chains.len() as u64;
        acceptance = accepted as f64 / proposed.max(1) as f64;
        if t >= BATCHES / 2 {
            sum += ln_lambda;
            count += 1;
        }
        ln_lambda += GAIN * (target - acceptance) / ((t + 1) as f64).powf(0.6);
        ln_lambda = ln_lambda.clamp((1e-3f64).ln(), (1e5f64).ln());
    }
    Ok(LambdaTuning {
        target,
        initial,
        lambda: (sum / count.max(1) as f64).exp(),
        acceptance,
        mutations: total,
    })
}
