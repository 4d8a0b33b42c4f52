//! Independence samplers inside a chart (charted-MLT paper §5.3, eqs. 28–29): a chain in chart
//! `i` proposes a point `y` that does not depend on its current point — drawn either by an outside
//! [`PointSampler`] (the renderer's density-estimation merge) or by the chart itself (a uniform
//! `u`, pushed forward: for technique charts, a bidirectional connection) — keeps its chart, and
//! takes `u' ~ κ_i(·|y)` from the chart's inverse ([`super::Refresh::KeepChart`]).
//!
//! Given the chart, the point of a chain in chart `i` has law `π̄_i`; an independence sampler of
//! density `Q_i` moves it with `min(1, π̄_i(y) Q_i(x) / (π̄_i(x) Q_i(y)))`, and the inverse draw of
//! `u'` is a Gibbs step (see [`super::Refresh`]). With the outside sampler chosen with probability
//! `λ` and the chart's pushforward `p_i` otherwise, two rules are exact:
//!
//! * [`IndependenceRule::Expected`] (eq. 29): `Q_i = λ q_i + (1 − λ) p_i`, the density of the
//!   mixture as a whole ("state-independent mixing", Geyer 2011). The rule does not depend on which
//!   component drew `y`, and dominates the other rule in Peskun's order (Tierney 1998: a sum of
//!   minima is at most the minimum of the sums), so it accepts at least as often.
//! * [`IndependenceRule::PerComponent`] (eq. 28 for the outside sampler, the large step for the
//!   chart): each component is its own independence sampler, `Q_i = q_i` or `Q_i = p_i` according
//!   to which drew `y`. A mixture of two valid kernels; same invariant law, lower acceptance.
//!
//! Densities are with respect to the reference measure of the charts' own densities (for the
//! technique charts, `I(f) dμ`). A sampler that fails to produce a point leaves the chain where it
//! is: a sub-probability proposal keeps the rule exact (the failure is the same from every point).

use super::Refresh;
use crate::{Chart, ChartState, ChartedTarget, Integrand};
use mcmc_core::proposals::log_sum_exp;
use mcmc_core::rng::uniform;
use mcmc_core::{ChainRng, Failure, Proposal, Proposed};

/// Draws of points for a chain in a given chart that do not depend on its current point, with
/// their density.
pub trait PointSampler<X>: Send + Sync {
    /// Draw a point for a chain in chart `chart` into `y`; `false` if none could be made.
    fn draw(&self, chart: usize, y: &mut X, rng: &mut ChainRng) -> bool;

    /// `ln q_chart(x)`: the log density of drawing `x` (reference measure of the charts'
    /// densities); `-inf` where the sampler cannot produce `x`.
    fn ln_density(&self, chart: usize, x: &X) -> f64;

    /// A name for statistics.
    fn name(&self) -> String;
}

/// How an outside sampler and the chart's own draws are combined.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum IndependenceRule {
    /// Eq. 29: the expected density of the mixture.
    #[default]
    Expected,
    /// Eq. 28: each component's own density.
    PerComponent,
}

/// An independence sampler in the current chart: the outside [`PointSampler`] with probability
/// `share`, the chart's pushforward otherwise.
pub struct ChartIndependence<'a, X, I, C, S> {
    /// The targets.
    pub target: &'a ChartedTarget<'a, X, I, C>,
    /// The outside sampler.
    pub sampler: S,
    /// Probability that the outside sampler draws (`λ`).
    pub share: f64,
    /// The acceptance rule.
    pub rule: IndependenceRule,
}

impl<'a, X, I, C, S> ChartIndependence<'a, X, I, C, S> {
    /// `sampler` with probability `share`, the chart's own draws otherwise, combined by `rule`.
    pub fn new(
        target: &'a ChartedTarget<'a, X, I, C>,
        sampler: S,
        share: f64,
        rule: IndependenceRule,
    ) -> Self {
        Self {
            target,
            sampler,
            share: share.clamp(0.0, 1.0),
            rule,
        }
    }
}

/// Kind of a candidate drawn by the outside sampler.
pub const FROM_SAMPLER: usize = 0;
/// Kind of a candidate drawn by the chart.
pub const FROM_CHART: usize = 1;

impl<X: Clone, I: Integrand<X>, C: Chart<X>, S: PointSampler<X>> ChartIndependence<'_, X, I, C, S> {
    /// `ln Q_i` at an evaluated valid state, for a candidate of `kind`.
    pub fn ln_proposal_density(&self, chart: usize, s: &ChartState<X>, kind: usize) -> f64 {
        let outside = self.sampler.ln_density(chart, &s.x);
        let own = s.ln_p.get(chart).copied().unwrap_or(f64::NEG_INFINITY);
        match (self.rule, kind) {
            (IndependenceRule::Expected, _) => {
                log_sum_exp(&[self.share.ln() + outside, (1.0 - self.share).ln() + own])
            }
            (IndependenceRule::PerComponent, FROM_SAMPLER) => outside,
            (IndependenceRule::PerComponent, _) => own,
        }
    }
}

impl<X: Clone, I: Integrand<X>, C: Chart<X>, S: PointSampler<X>> Proposal<ChartState<X>>
    for ChartIndependence<'_, X, I, C, S>
{
    fn propose(&self, x: &ChartState<X>, y: &mut ChartState<X>, rng: &mut ChainRng) -> Proposed {
        let i = x.chart;
        let kind = if uniform(rng) < self.share {
            FROM_SAMPLER
        } else {
            FROM_CHART
        };
        let Some(chart) = self.target.atlas.chart(i) else {
            // The identity chart has no pushforward to draw from.
            return Proposed::failed(kind, Failure::NotApplicable);
        };
        if !(x.valid && x.fresh) {
            y.clone_from(x);
            return Proposed::new(f64::NEG_INFINITY, kind);
        }
        let drawn = if kind == FROM_SAMPLER {
            self.sampler.draw(i, &mut y.x, rng)
        } else {
            y.u.resize(chart.dim(), 0.0);
            y.u.iter_mut().for_each(|v| *v = uniform(rng));
            chart.forward(&y.u, &mut y.x)
        };
        if !drawn {
            return Proposed::failed(kind, Failure::Failed);
        }
        self.target.refresh_point(y);
        let ln_ratio = self.ln_proposal_density(i, x, kind) - self.ln_proposal_density(i, y, kind);
        let r = Refresh::KeepChart.settle(self.target, x, y, ln_ratio, rng);
        Proposed::new(r, kind)
    }

    fn kind_count(&self) -> usize {
        2
    }

    fn kinds(&self) -> Vec<String> {
        vec![self.sampler.name(), "connection".into()]
    }
}
