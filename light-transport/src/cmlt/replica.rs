//! Chart swaps by replica exchange (charted-MLT paper §4, eqs. 22–24) between the chains of the
//! shared driver.
//!
//! Under [`SwapKind::ReplicaExchange`] every chain keeps the technique chart `s` it was seeded in
//! and samples `π_s(u) = f(x̄) / Σ p(x̄)` on `U_s` — in path space `f w_s`, with `w_s` the balance
//! weight. The driver seeds chains by resampling the bootstrap, which draws the chart of a chain
//! with probability `b_s / b_k`, so the population already carries each technique's share of the
//! image and no per-technique normalisation is needed.
//!
//! An exchange round pairs chains of the same path length in different charts `i ≠ j` and
//! proposes that they exchange paths, through `mcmc_charts`' [`exchange`]: accepted with
//! `min(1, p_i(x̄₂) p_j(x̄₁) / (p_i(x̄₁) p_j(x̄₂)))` (eq. 24; the importances `π` are equal in every
//! chart at the same path, eq. 23, and `f` is never evaluated), the numbers drawn afterwards by
//! the charts' partial inverse (§6.1) — they are Gibbs draws and do not enter the acceptance.
//!
//! The pairing is a function of the chains' charts (which never change) and of fresh random
//! numbers only, never of the paths, so each pair's exchange preserves the product law. Chains of
//! one length are sorted by chart (random order within a chart) and the first half is paired with
//! the second: every pair crosses charts unless one chart holds more than half of the chains.
//! Exchanges are not recorded on the film (each chain records its own mutations), so how many a
//! chain takes part in does not weigh its samples.

use super::Cmlt;
use super::integrator::{CmltState, SWAP, SwapKind};
use crate::scene::Scene;
use mcmc_charts::moves::{Exchange, exchange};
use mcmc_core::rng::{substream, uniform};
use mcmc_core::{Chain, ChainRng, Failure, Family};
use rand::Rng;
use rayon::prelude::*;

impl Cmlt {
    /// Pairs of chains (indices into `chains`) for one exchange round: same group (path length;
    /// `groups[c]` for chain `c`), preferably different charts. Depends on the groups, the charts
    /// and `rng` only.
    pub fn exchange_pairs(
        chains: &[Chain<CmltState>],
        groups: &[usize],
        rng: &mut ChainRng,
    ) -> Vec<(usize, usize)> {
        let mut by_length: Vec<Vec<(usize, f64, usize)>> = Vec::new();
        for (c, chain) in chains.iter().enumerate() {
            let k = groups[c];
            if by_length.len() <= k {
                by_length.resize_with(k + 1, Vec::new);
            }
            by_length[k].push((chain.state.chart, uniform(rng), c));
        }
        let mut pairs = Vec::new();
        for mut group in by_length {
            group.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
            let half = group.len() / 2;
            let (lo, hi) = group.split_at(group.len() - half);
            for (a, b) in lo.iter().zip(hi) {
                if a.0 != b.0 {
                    pairs.push((a.2, b.2));
                }
            }
        }
        pairs
    }

    /// The exchange proposal between two chains (read only).
    fn exchange_proposal(
        &self,
        scene: &Scene,
        a: &CmltState,
        b: &CmltState,
        rng: &mut ChainRng,
    ) -> Exchange {
        let k = a.x.path.edges();
        if b.x.path.edges() != k {
            return Exchange::NotApplicable;
        }
        let atlas = self.atlas(scene, k);
        let target = Self::target(&atlas);
        exchange(&target, a, b, rng)
    }

    /// One replica-exchange round over all chains (see the module docs); the proposals are made
    /// in parallel, each pair from its own stream of `rng`, so the result does not depend on the
    /// thread count. Statistics go to the first chain of each pair, as kind "chart swap".
    pub fn exchange_round(
        &self,
        scene: &Scene,
        chains: &mut [Chain<CmltState>],
        groups: &[usize],
        rng: &mut ChainRng,
    ) {
        if self.settings.swaps != SwapKind::ReplicaExchange {
            return;
        }
        let pairs = Self::exchange_pairs(chains, groups, rng);
        let key = rng.next_u64();
        let outcomes: Vec<Exchange> = pairs
            .par_iter()
            .enumerate()
            .map(|(n, &(a, b))| {
                let mut r = substream(key, 0xE8C4, n as u64);
                self.exchange_proposal(scene, &chains[a].state, &chains[b].state, &mut r)
            })
            .collect();
        for ((a, b), outcome) in pairs.into_iter().zip(outcomes) {
            let (ca, cb) = pair_mut(chains, a, b);
            match outcome {
                Exchange::Accepted(p, ..) => {
                    ca.stats.record(SWAP, p, true, false);
                    outcome.apply(&mut ca.state, &mut cb.state);
                    // Each chain's density at its new state, as its kernel evaluates it.
                    for c in [ca, cb] {
                        let atlas = self.atlas(scene, c.state.x.path.edges());
                        let target = Self::target(&atlas);
                        c.ln_density = target.ln_density(c.state.chart, &mut c.state);
                    }
                }
                Exchange::Rejected(p) => ca.stats.record(SWAP, p, false, false),
                Exchange::NotApplicable => ca.stats.record_failure(SWAP, Failure::NotApplicable),
                Exchange::Failed => ca.stats.record_failure(SWAP, Failure::Failed),
            }
        }
    }
}

/// Mutable references to two distinct elements `a ≠ b` of a slice.
pub fn pair_mut<T>(v: &mut [T], a: usize, b: usize) -> (&mut T, &mut T) {
    assert_ne!(a, b, "a pair of one element");
    let (lo, hi) = v.split_at_mut(a.max(b));
    if a < b {
        (&mut lo[a], &mut hi[0])
    } else {
        (&mut hi[0], &mut lo[b])
    }
}
