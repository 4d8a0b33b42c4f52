//! What becomes of a charted chain's chart and coordinates after a move of its *point*
//! ([`super::PointMove`], [`super::InversePerturbation`]).
//!
//! A chain over (chart `k`, coordinates `u`) with joint target `c_k π_k(u)` has point marginal
//! `Π(x) = Σ_k c_k π̄_k(x)`; given the point, the chart is distributed as `c_k π̄_k(x) / Π(x)` and
//! the coordinates by the chart's inverse `κ_k(·|x)`. A move `x → y` built for a target on points
//! (reporting its own ratio `r = ln T(x|y) − ln T(y|x)` for a chain on points) joins the charted
//! chain in one of two ways:
//!
//! * [`Refresh::Gibbs`]: the candidate's chart `k'` is drawn from its conditional law given `y`
//!   and `u' ~ κ_{k'}(·|y)`. Metropolis–Hastings on the whole state with this proposal accepts with
//!   `Π(y) T(x|y) / (Π(x) T(y|x))`: the chart and coordinate draws cancel against the joint
//!   target (they are exact conditionals), leaving the point chain's own rule for `Π`.
//! * [`Refresh::KeepChart`]: the chain keeps chart `k` (a replica that must stay in its chart);
//!   only `u' ~ κ_k(·|y)` is drawn, and the acceptance is `π̄_k(y) T(x|y) / (π̄_k(x) T(y|x))`.
//!   In the identity chart this is a plain target-space chain.
//!
//! The kernel these moves run in evaluates the chain's own density (`c_k π_k(u)`, a
//! [`crate::Joint`] or [`mcmc_core::Level`] target), so the ratio a move reports is the one above
//! divided by the change of that density. Charts whose inverse is not exact add
//! `ln λ(u) − ln λ(u')` (see [`crate::Chart::ln_inverse_bias`]).

use crate::{Chart, ChartState, ChartedTarget, Integrand};
use mcmc_core::ChainRng;

/// How the chart and coordinates follow a move of the point.
#[derive(Clone, Debug, PartialEq, Default)]
pub enum Refresh {
    /// Keep the chart, redraw the coordinates from its inverse (the default: a target-space chain
    /// stays in the identity chart).
    #[default]
    KeepChart,
    /// Redraw the chart from its conditional law given the point, under pseudo-priors
    /// `ln c_k` (one per level; those of the [`crate::Joint`] target the chain samples), then the
    /// coordinates from its inverse.
    Gibbs {
        /// `ln c_k`.
        ln_weights: Vec<f64>,
    },
}

/// `ln π_k(u)` of an evaluated valid state, from its cached point values (`π̄_k / p_k`).
fn ln_primary<X, I: Integrand<X>, C: Chart<X>>(
    target: &ChartedTarget<'_, X, I, C>,
    k: usize,
    s: &ChartState<X>,
) -> f64 {
    target.ln_target_space_density(k, s) - s.ln_p[k]
}

fn ln_bias<X, I, C: Chart<X>>(target: &ChartedTarget<'_, X, I, C>, s: &ChartState<X>) -> f64 {
    target
        .atlas
        .chart(s.chart)
        .map_or(0.0, |c| c.ln_inverse_bias(&s.x, &s.u))
}

impl Refresh {
    /// Give the candidate `y`, whose point a move from the current state `x` just placed (and
    /// [`ChartedTarget::refresh_point`] evaluated), its chart and coordinates, and return the log
    /// ratio to report to the kernel, given the point move's own ratio `ln_point_ratio`
    /// (`-inf`: reject). `x` must be an evaluated valid state.
    pub fn settle<X: Clone, I: Integrand<X>, C: Chart<X>>(
        &self,
        target: &ChartedTarget<'_, X, I, C>,
        x: &ChartState<X>,
        y: &mut ChartState<X>,
        ln_point_ratio: f64,
        rng: &mut ChainRng,
    ) -> f64 {
        let reject = f64::NEG_INFINITY;
        y.chart = x.chart;
        if !(y.valid && y.importance > 0.0) || ln_point_ratio.is_nan() {
            y.u.clear();
            return reject;
        }
        let atlas = target.atlas;
        let k_new = match self {
            Refresh::KeepChart => x.chart,
            Refresh::Gibbs { ln_weights } => match target.draw_level(y, ln_weights, rng) {
                Some(k) => k,
                None => return reject,
            },
        };
        y.chart = k_new;
        y.u.resize(atlas.dim(k_new), 0.0);
        if let Some(c) = atlas.chart(k_new)
            && !(y.ln_p[k_new] > f64::NEG_INFINITY && c.invert(&y.x, &mut y.u, rng))
        {
            return reject;
        }
        let bias = ln_bias(target, x) - ln_bias(target, y);
        let (k, kp) = (x.chart, k_new);
        let ln_point_target = |s: &ChartState<X>| match self {
            Refresh::KeepChart => target.ln_target_space_density(k, s),
            Refresh::Gibbs { ln_weights } => target.ln_marginal(s, ln_weights),
        };
        let ln_chain = |s: &ChartState<X>, level: usize| match self {
            Refresh::KeepChart => ln_primary(target, level, s),
            Refresh::Gibbs { ln_weights } => ln_weights[level] + ln_primary(target, level, s),
        };
        let marginal = ln_point_target(y) - ln_point_target(x);
        let chain = ln_chain(y, kp) - ln_chain(x, k);
        let r = ln_point_ratio + marginal - chain + bias;
        if r.is_nan() { reject } else { r }
    }
}
