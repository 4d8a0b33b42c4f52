//! The chart swap by serial tempering as a proposal (paper eq. 25): keep the point, propose a
//! chart `j` from `mcmc_core`'s [`LevelProposal`], and draw the coordinates from `j`'s inverse
//! (through [`crate::Chart::partial_inverse`], so charts sharing coordinates invert only what
//! differs). The reported ratio is the level proposal's plus the family's Green ratio
//! `ln p_j(x) − ln p_i(x)`; run it in a Metropolis–Hastings kernel of the [`crate::Joint`]
//! target, which adds `ln c_j π_j(u') − ln c_i π_i(u)`. The acceptance is then exactly that of
//! `mcmc_core`'s `SerialTempering::level_move` (see the derivation in [`crate::moves`]).

use crate::{Chart, ChartState, ChartedTarget, Integrand};
use mcmc_core::tempering::LevelProposal;
use mcmc_core::{ChainRng, Family, Proposal, Proposed};

/// Serial-tempering chart swaps as a proposal.
pub struct ChartSwap<'a, X, I, C> {
    /// The targets.
    pub target: &'a ChartedTarget<'a, X, I, C>,
    /// How the next chart is proposed.
    pub levels: LevelProposal,
}

impl<'a, X, I, C> ChartSwap<'a, X, I, C> {
    /// Swaps over the levels of `target` proposed by `levels`.
    pub fn new(target: &'a ChartedTarget<'a, X, I, C>, levels: LevelProposal) -> Self {
        Self { target, levels }
    }
}

impl<X: Clone, I: Integrand<X>, C: Chart<X>> Proposal<ChartState<X>> for ChartSwap<'_, X, I, C> {
    fn propose(&self, x: &ChartState<X>, y: &mut ChartState<X>, rng: &mut ChainRng) -> Proposed {
        let (j, ln_q) = self.levels.draw(x.chart, self.target.levels(), rng);
        let Some(j) = j else {
            y.clone_from(x);
            return Proposed::with_ratio(f64::NEG_INFINITY); // off the ladder: rejected
        };
        let g = self.target.transfer(x.chart, j, x, y, rng);
        Proposed::with_ratio(g + ln_q)
    }

    fn kinds(&self) -> Vec<String> {
        vec!["chart swap".into()]
    }

    fn kind_count(&self) -> usize {
        1
    }
}
