//! Chart swaps by replica exchange (charted-MLT paper §4, eqs. 22–24) between the chains of the
//! shared driver.
//!
//! Under [`SwapKind::ReplicaExchange`] every chain keeps the technique chart `s` it was seeded in
//! and samples `π_s(u) = f(x̄) / Σ p(x̄)` on `U_s` — in path space `f w_s`, with `w_s` the balance
//! weight. The driver seeds chains by resampling the bootstrap, which draws the chart of a chain
//! with probability `b_s / b_k`, so the population already carries each technique's share of the
//! image and no per-technique normalisation is needed.
//!
//! An exchange round pairs chains of the same path length in different charts `i ≠ j`, at paths
//! `x̄₁` and `x̄₂`, and proposes that chain `i` take `x̄₂` with numbers `u ~ κ_i(·|x̄₂)` while chain
//! `j` takes `x̄₁` with `u ~ κ_j(·|x̄₁)` (only the vertices whose numbers differ are inverted,
//! §6.1). On the product of the chains' targets the proposal is a Gibbs draw of the numbers after
//! exchanging the paths, so it is accepted with
//! `min(1, p_i(x̄₂) p_j(x̄₁) / (p_i(x̄₁) p_j(x̄₂)))` (eq. 24) — the importances `π` are equal in
//! every chart at the same path (eq. 23), and `f` is never evaluated. In terms of the stored
//! strategy importances `p_s ∝ 1 / I(C*_s)`, the ratio is
//! `I(C*_i(x̄₁)) I(C*_j(x̄₂)) / (I(C*_i(x̄₂)) I(C*_j(x̄₁)))`.
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
use mcmc_charts::Chart;
use mcmc_core::kernel::acceptance;
use mcmc_core::rng::{substream, uniform};
use mcmc_core::{Chain, ChainRng, Failure};
use rand::Rng;
use rayon::prelude::*;

/// What an exchange proposal between chains `a` and `b` came to.
enum Outcome {
    /// Accepted with this probability: the numbers of `b`'s path in `a`'s chart and of `a`'s
    /// path in `b`'s chart.
    Accepted(f64, Vec<f64>, Vec<f64>),
    /// Rejected with this acceptance probability.
    Rejected(f64),
    /// A path lies outside the other chart's image (probability 0).
    NotApplicable,
    /// An inversion failed.
    Failed,
}

impl Cmlt {
    /// Pairs of chains (indices into `chains`) for one exchange round: same path length,
    /// preferably different charts. Depends on the charts and `rng` only.
    pub fn exchange_pairs(chains: &[Chain<CmltState>], rng: &mut ChainRng) -> Vec<(usize, usize)> {
        let mut by_length: Vec<Vec<(usize, f64, usize)>> = Vec::new();
        for (c, chain) in chains.iter().enumerate() {
            let k = chain.state.k;
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

    /// The exchange proposal between two chains (read only; see the module docs).
    fn exchange_proposal(
        &self,
        scene: &Scene,
        a: &CmltState,
        b: &CmltState,
        rng: &mut ChainRng,
    ) -> Outcome {
        let (i, j, k) = (a.chart, b.chart, a.k);
        let (x1, x2) = (&a.x, &b.x);
        let ln = |v: f64| if v > 0.0 { v.ln() } else { f64::NAN };
        let ln_ratio = ln(x1.strategy_importance(i)) + ln(x2.strategy_importance(j))
            - ln(x2.strategy_importance(i))
            - ln(x1.strategy_importance(j));
        if ln_ratio.is_nan() || a.bootstrap_scaled || b.bootstrap_scaled || b.k != k {
            return Outcome::NotApplicable;
        }
        let (Some(ci), Some(cj)) = (self.chart(scene, k, i), self.chart(scene, k, j)) else {
            return Outcome::NotApplicable;
        };
        let (p, _) = acceptance(0.0, 0.0, ln_ratio);
        if !(uniform(rng) < p) {
            // The numbers are drawn only for an accepted exchange: they do not enter `p`.
            return Outcome::Rejected(p);
        }
        let (mut ua, mut ub) = (vec![0.0; ci.dim()], vec![0.0; cj.dim()]);
        if !ci.reparameterise(x2, &cj, &b.u, &mut ua, rng)
            || !cj.reparameterise(x1, &ci, &a.u, &mut ub, rng)
        {
            return Outcome::Failed;
        }
        Outcome::Accepted(p, ua, ub)
    }

    /// One replica-exchange round over all chains (see the module docs); the proposals are made
    /// in parallel, each pair from its own stream of `rng`, so the result does not depend on the
    /// thread count. Statistics go to the first chain of each pair, as kind "chart swap".
    pub fn exchange_round(
        &self,
        scene: &Scene,
        chains: &mut [Chain<CmltState>],
        rng: &mut ChainRng,
    ) {
        if self.settings.swaps != SwapKind::ReplicaExchange {
            return;
        }
        let pairs = Self::exchange_pairs(chains, rng);
        let key = rng.next_u64();
        let outcomes: Vec<Outcome> = pairs
            .par_iter()
            .enumerate()
            .map(|(n, &(a, b))| {
                let mut r = substream(key, 0xE8C4, n as u64);
                self.exchange_proposal(scene, &chains[a].state, &chains[b].state, &mut r)
            })
            .collect();
        for ((a, b), outcome) in pairs.into_iter().zip(outcomes) {
            let stats = &mut chains[a].stats;
            match outcome {
                Outcome::Accepted(p, ua, ub) => {
                    stats.record(SWAP, p, true, false);
                    let (lo, hi) = chains.split_at_mut(a.max(b));
                    let (ca, cb) = if a < b {
                        (&mut lo[a], &mut hi[0])
                    } else {
                        (&mut hi[0], &mut lo[b])
                    };
                    std::mem::swap(&mut ca.state.x, &mut cb.state.x);
                    std::mem::swap(&mut ca.ln_density, &mut cb.ln_density);
                    ca.state.u = ua;
                    cb.state.u = ub;
                }
                Outcome::Rejected(p) => stats.record(SWAP, p, false, false),
                Outcome::NotApplicable => stats.record_failure(SWAP, Failure::NotApplicable),
                Outcome::Failed => stats.record_failure(SWAP, Failure::Failed),
            }
        }
    }
}
