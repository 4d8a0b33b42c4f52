//! A move of the point of a charted chain in any chart: a proposal on points (a random walk, the
//! path-space mutations of a renderer) moves `x`, then the chart and coordinates follow it as
//! [`super::Refresh`] says. With [`super::Refresh::Gibbs`] this is how target-space moves join a
//! chain that lives in the charts (the renderer's path-space mutations in charted MLT).

use super::Refresh;
use crate::{Chart, ChartState, ChartedTarget, Integrand};
use mcmc_core::{ChainRng, Proposal, Proposed};

/// Applies a proposal on points `X` to the point of a state in any chart.
pub struct PointMove<'a, X, I, C, P> {
    /// The targets (to evaluate the moved point and redraw its chart and coordinates).
    pub target: &'a ChartedTarget<'a, X, I, C>,
    /// The proposal on points; its ratio must be that of a chain on points (with respect to the
    /// reference measure the charts' densities use).
    pub proposal: P,
    /// What the chart and coordinates do.
    pub refresh: Refresh,
}

impl<'a, X, I, C, P> PointMove<'a, X, I, C, P> {
    /// Move points with `proposal`; charts follow as `refresh` says.
    pub fn new(target: &'a ChartedTarget<'a, X, I, C>, proposal: P, refresh: Refresh) -> Self {
        Self {
            target,
            proposal,
            refresh,
        }
    }
}

impl<X: Clone, I: Integrand<X>, C: Chart<X>, P: Proposal<X>> Proposal<ChartState<X>>
    for PointMove<'_, X, I, C, P>
{
    fn propose(&self, x: &ChartState<X>, y: &mut ChartState<X>, rng: &mut ChainRng) -> Proposed {
        if !(x.valid && x.fresh) {
            y.clone_from(x);
            return Proposed::with_ratio(f64::NEG_INFINITY);
        }
        let p = self.proposal.propose(&x.x, &mut y.x, rng);
        if p.failure.is_some() {
            // A failed proposal may leave a partial point behind; the candidate is the current
            // point again, so that what the chain reads of a failed candidate later (a renderer's
            // path length, when a large step's map fails too) is the chain's, not a fragment's.
            y.x.clone_from(&x.x);
            return p;
        }
        self.target.refresh_point(y);
        let r = self.refresh.settle(self.target, x, y, p.ln_ratio, rng);
        Proposed::new(r, p.kind)
    }

    fn suitability(&self, x: &ChartState<X>) -> f64 {
        self.proposal.suitability(&x.x)
    }

    fn kind_count(&self) -> usize {
        self.proposal.kind_count()
    }

    fn kinds(&self) -> Vec<String> {
        self.proposal.kinds()
    }
}
