//! Target-space moves for states in the identity chart: any proposal on points (a random walk, the
//! path-space mutations of Veach and Guibas) joins a charted chain through this adapter.

use crate::ChartState;
use mcmc_core::{ChainRng, Proposal, Proposed};

/// Applies a proposal on points `X` to states in the identity chart.
#[derive(Clone, Debug)]
pub struct TargetSpace<P> {
    /// The proposal on points.
    pub proposal: P,
}

impl<P> TargetSpace<P> {
    /// Wrap a proposal on points.
    pub fn new(proposal: P) -> Self {
        Self { proposal }
    }
}

impl<X: Clone, P: Proposal<X>> Proposal<ChartState<X>> for TargetSpace<P> {
    fn propose(&self, x: &ChartState<X>, y: &mut ChartState<X>, rng: &mut ChainRng) -> Proposed {
        y.chart = x.chart;
        y.u.clear();
        y.fresh = false;
        if !x.u.is_empty() || !x.valid {
            // Not in the identity chart: this move does not apply.
            y.clone_from(x);
            return Proposed::with_ratio(f64::NEG_INFINITY);
        }
        y.valid = true;
        self.proposal.propose(&x.x, &mut y.x, rng)
    }

    fn ln_transition_density(&self, from: &ChartState<X>, to: &ChartState<X>) -> Option<f64> {
        self.proposal.ln_transition_density(&from.x, &to.x)
    }

    fn ln_move_density(
        &self,
        from: &ChartState<X>,
        to: &ChartState<X>,
        kind: usize,
    ) -> Option<f64> {
        self.proposal.ln_move_density(&from.x, &to.x, kind)
    }

    fn kind_count(&self) -> usize {
        self.proposal.kind_count()
    }

    fn kinds(&self) -> Vec<String> {
        self.proposal.kinds()
    }
}
