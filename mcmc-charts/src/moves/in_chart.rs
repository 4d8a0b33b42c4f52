//! In-chart moves: any proposal on the unit cube applied to a state's primary coordinates
//! (Kelemen small steps, large steps, their mixture).

use crate::ChartState;
use mcmc_core::{ChainRng, Proposal, Proposed};

/// Applies a cube proposal to the primary coordinates `u` of a state, keeping its chart.
#[derive(Clone, Debug)]
pub struct InChart<P> {
    /// The proposal on `[0,1)^d`.
    pub proposal: P,
}

impl<P> InChart<P> {
    /// Wrap a cube proposal.
    pub fn new(proposal: P) -> Self {
        Self { proposal }
    }
}

impl<X: Clone, P: Proposal<Vec<f64>>> Proposal<ChartState<X>> for InChart<P> {
    fn propose(&self, x: &ChartState<X>, y: &mut ChartState<X>, rng: &mut ChainRng) -> Proposed {
        y.chart = x.chart;
        y.fresh = false;
        if x.u.is_empty() {
            // The identity chart has no primary coordinates: this move does not apply.
            y.clone_from(x);
            return Proposed::with_ratio(f64::NEG_INFINITY);
        }
        y.u.resize(x.u.len(), 0.0);
        self.proposal.propose(&x.u, &mut y.u, rng)
    }

    fn ln_transition_density(&self, from: &ChartState<X>, to: &ChartState<X>) -> Option<f64> {
        if from.chart != to.chart {
            return Some(f64::NEG_INFINITY);
        }
        self.proposal.ln_transition_density(&from.u, &to.u)
    }

    fn ln_move_density(
        &self,
        from: &ChartState<X>,
        to: &ChartState<X>,
        kind: usize,
    ) -> Option<f64> {
        if from.chart != to.chart {
            return Some(f64::NEG_INFINITY);
        }
        self.proposal.ln_move_density(&from.u, &to.u, kind)
    }

    fn kind_count(&self) -> usize {
        self.proposal.kind_count()
    }

    fn kinds(&self) -> Vec<String> {
        self.proposal.kinds()
    }
}
