//! Serial (simulated) tempering: one chain over `(x, k)` with joint target `c_k π_k(x)`, where the
//! pseudo-prior weights `c_k` are chosen so the chain spends comparable time at every level
//! (ideally `c_k ∝ 1 / Z_k`).
//!
//! A level move `k → j` carries the state over with [`Family::transfer`] (Green ratio `g`) and is
//! accepted with `min(1, c_j π_j(y) q(k|j) / (c_k π_k(x) q(j|k)) · e^g)`.
//!
//! Weight adaptation (stochastic approximation, as in Wang–Landau): during warm-up, after every step
//! `ln c_k ← ln c_k − γ_t (1[level = k] − 1/K)` with `γ_t = γ_0 · min(1, t_0 / t)`; the weights are
//! frozen afterwards so the chain is a proper Markov chain from then on.

use super::{PairStats, RoundTrips};
use crate::kernel::Observer;
use crate::rng::uniform;
use crate::{Chain, ChainRng, Family, Kernel, McmcError};

/// How the next level is proposed.
#[derive(Clone, Debug, PartialEq)]
pub enum LevelProposal {
    /// `k ± 1` with probability 1/2 each; a move off the ladder is rejected (symmetric).
    Neighbour,
    /// `j` with fixed probability `w_j` whatever the current level (e.g. in proportion to technique
    /// energy for chart swaps).
    Independent(Vec<f64>),
}

impl LevelProposal {
    /// Draw the next level from `current` on a ladder of `levels`: the level (`None` for a move
    /// off the ladder, which is rejected) and the proposal's log ratio `ln q(current|j) −
    /// ln q(j|current)`. Shared by [`SerialTempering`] and by any kernel that moves a state
    /// between levels as a proposal (the chart swaps of `mcmc-charts`).
    pub fn draw(&self, current: usize, levels: usize, rng: &mut ChainRng) -> (Option<usize>, f64) {
        match self {
            LevelProposal::Neighbour => {
                let up = uniform(rng) < 0.5;
                let j = if up {
                    Some(current + 1).filter(|&j| j < levels)
                } else {
                    current.checked_sub(1)
                };
                (j, 0.0)
            }
            LevelProposal::Independent(w) => {
                let j = crate::rng::categorical(w, uniform(rng)).unwrap_or(levels - 1);
                (Some(j), (w[current] / w[j]).ln())
            }
        }
    }
}

/// Warm-up adaptation of the pseudo-prior weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptation {
    /// Initial gain `γ_0`.
    pub gamma0: f64,
    /// Steps before the gain starts to decay as `1/t`.
    pub t0: f64,
    /// Number of steps during which weights adapt; frozen afterwards.
    pub warmup: u64,
}

/// Serial tempering over a family, with one local kernel per level.
pub struct SerialTempering<S, F, K> {
    /// The family.
    pub family: F,
    /// Local kernel of each level.
    pub kernels: Vec<K>,
    /// The chain; `chain.ln_density` is `ln π_level(state)`.
    pub chain: Chain<S>,
    /// The current level.
    pub level: usize,
    /// `ln c_k`.
    pub ln_weights: Vec<f64>,
    /// How levels are proposed.
    pub level_proposal: LevelProposal,
    /// Local steps between level moves.
    pub local_steps: usize,
    /// Weight adaptation, if any.
    pub adaptation: Option<Adaptation>,
    /// Steps spent at each level after warm-up.
    pub visits: Vec<u64>,
    /// Level-move counters per (from, to) pair, indexed `from * K + to`.
    pub level_moves: Vec<PairStats>,
    /// Round trips bottom → top → bottom.
    pub round_trips: RoundTrips,
    steps: u64,
}

impl<S: Clone, F: Family<S>, K: Kernel<S>> SerialTempering<S, F, K> {
    /// Start at `x0` on `level` with pseudo-prior `ln_weights` (all zero when `None`).
    pub fn new(
        family: F,
        kernels: Vec<K>,
        mut x0: S,
        level: usize,
        ln_weights: Option<Vec<f64>>,
        level_proposal: LevelProposal,
    ) -> Result<Self, McmcError> {
        let n = family.levels();
        if n == 0 || kernels.len() != n || level >= n {
            return Err(McmcError::InvalidParameter {
                name: "levels",
                reason: format!(
                    "family has {n} levels, {} kernels, starting level {level}",
                    kernels.len()
                ),
            });
        }
        let ln_weights = ln_weights.unwrap_or_else(|| vec![0.0; n]);
        if ln_weights.len() != n || ln_weights.iter().any(|w| !w.is_finite()) {
            return Err(McmcError::InvalidParameter {
                name: "ln_weights",
                reason: "one finite log weight per level is required".into(),
            });
        }
        if let LevelProposal::Independent(w) = &level_proposal
            && (w.len() != n || w.iter().any(|p| !(p.is_finite() && *p > 0.0)))
        {
            return Err(McmcError::InvalidParameter {
                name: "level_proposal",
                reason: "one positive finite probability per level is required".into(),
            });
        }
        let l = family.ln_density(level, &mut x0);
        let chain = Chain::with_density(x0, l)?;
        let mut round_trips = RoundTrips::new(1);
        round_trips.visit(0, level, n);
        Ok(Self {
            family,
            kernels,
            chain,
            level,
            ln_weights,
            level_proposal,
            local_steps: 1,
            adaptation: None,
            visits: vec![0; n],
            level_moves: vec![PairStats::default(); n * n],
            round_trips,
            steps: 0,
        })
    }

    /// Number of levels.
    pub fn levels(&self) -> usize {
        self.ln_weights.len()
    }

    /// Whether the weights are still adapting.
    pub fn warming_up(&self) -> bool {
        self.adaptation.is_some_and(|a| self.steps < a.warmup)
    }

    /// One step: `local_steps` local moves at the current level, then one level move.
    pub fn step<O: Observer<S>>(&mut self, rng: &mut ChainRng, observer: &mut O) {
        for _ in 0..self.local_steps {
            self.kernels[self.level].step(&mut self.chain, rng, observer);
        }
        self.level_move(rng);
        self.steps += 1;
        if let Some(a) = self.adaptation
            && self.steps <= a.warmup
        {
            let gamma = a.gamma0 * (a.t0 / self.steps as f64).min(1.0);
            let n = self.levels() as f64;
            for (k, w) in self.ln_weights.iter_mut().enumerate() {
                *w -= gamma * ((k == self.level) as u8 as f64 - 1.0 / n);
            }
            return;
        }
        self.visits[self.level] += 1;
    }

    fn propose_level(&self, rng: &mut ChainRng) -> (Option<usize>, f64) {
        self.level_proposal.draw(self.level, self.levels(), rng)
    }

    /// Propose a level change; returns whether the chain moved to another level.
    pub fn level_move(&mut self, rng: &mut ChainRng) -> bool {
        let k = self.level;
        let n = self.levels();
        let (j, ln_q) = self.propose_level(rng);
        let Some(j) = j else {
            return false; // off the ladder: rejected, the chain stays
        };
        if j == k {
            return false;
        }
        let (a, l) = self.level_candidate(j, ln_q, rng);
        let invalid = a.is_nan();
        let accepted = !invalid && (a >= 1.0 || (a > 0.0 && uniform(rng) < a));
        self.level_moves[k * n + j].record(if invalid { 0.0 } else { a }, accepted, invalid);
        if accepted {
            std::mem::swap(&mut self.chain.state, &mut self.chain.candidate);
            self.chain.ln_density = l;
            self.level = j;
            self.round_trips.visit(0, j, n);
        }
        accepted
    }

    /// Write the candidate of a move to level `j` into the chain's candidate buffer and return
    /// `(acceptance probability, ln π_j(candidate))` (NaN probability: invalid), where `ln_q = ln q(k|j) − ln q(j|k)` is the
    /// level proposal's ratio. Exposed for the exact finite-space checks.
    pub fn level_candidate(&mut self, j: usize, ln_q: f64, rng: &mut ChainRng) -> (f64, f64) {
        let k = self.level;
        let g = self
            .family
            .transfer(k, j, &self.chain.state, &mut self.chain.candidate, rng);
        let l = self.family.ln_density(j, &mut self.chain.candidate);
        let ln_ratio = g + self.ln_weights[j] - self.ln_weights[k] + ln_q;
        (
            crate::kernel::acceptance(self.chain.ln_density, l, ln_ratio).0,
            l,
        )
    }

    /// Fraction of post-warm-up steps spent at each level.
    pub fn time_per_level(&self) -> Vec<f64> {
        let t: u64 = self.visits.iter().sum();
        self.visits.iter().map(|&v| v as f64 / t as f64).collect()
    }
}
