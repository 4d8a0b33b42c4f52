//! The chart swap by replica exchange between two chains that keep their charts (paper eq. 24),
//! for populations of chains managed outside `mcmc_core::tempering::ReplicaExchange` (a renderer
//! pairing thousands of chains).
//!
//! Chains at `x1` (chart `i`) and `x2` (chart `j`) propose to exchange points, each point
//! re-parameterised in the other chain's chart by its inverse. The new coordinates are Gibbs draws
//! that do not enter the acceptance `min(1, π̄_i(x2) π̄_j(x1) / (π̄_i(x1) π̄_j(x2)))`, so they are
//! drawn only for an accepted exchange. This shortcut is exact for charts whose inverse honours
//! the contract (zero [`crate::Chart::ln_inverse_bias`]); with a biased inverse the acceptance
//! depends on the drawn coordinates, and `mcmc_core::tempering::ReplicaExchange` (which draws
//! first) is the one to use.

use crate::{Chart, ChartState, ChartedTarget, Integrand};
use mcmc_core::ChainRng;
use mcmc_core::kernel::acceptance;
use mcmc_core::rng::uniform;

/// What an exchange proposal came to.
#[derive(Clone, Debug, PartialEq)]
pub enum Exchange {
    /// Accepted with this probability: the coordinates of `b`'s point in `a`'s chart and of `a`'s
    /// point in `b`'s chart ([`Exchange::apply`] makes the exchange).
    Accepted(f64, Vec<f64>, Vec<f64>),
    /// Rejected with this acceptance probability.
    Rejected(f64),
    /// A point lies outside the other chain's chart (acceptance 0).
    NotApplicable,
    /// An inversion failed.
    Failed,
}

impl Exchange {
    /// Make an accepted exchange: the chains swap points (with their cached evaluations) and take
    /// the new coordinates; their charts stay. Returns whether it was accepted.
    pub fn apply<X>(self, a: &mut ChartState<X>, b: &mut ChartState<X>) -> bool {
        let Exchange::Accepted(_, ua, ub) = self else {
            return false;
        };
        std::mem::swap(&mut a.x, &mut b.x);
        std::mem::swap(&mut a.ln_p, &mut b.ln_p);
        std::mem::swap(&mut a.importance, &mut b.importance);
        std::mem::swap(&mut a.valid, &mut b.valid);
        std::mem::swap(&mut a.fresh, &mut b.fresh);
        a.u = ua;
        b.u = ub;
        true
    }
}

/// `ln` of eq. 24's ratio for evaluated valid states `a` (chart `i`) and `b` (chart `j`).
pub fn exchange_ln_ratio<X, I: Integrand<X>, C: Chart<X>>(
    target: &ChartedTarget<'_, X, I, C>,
    a: &ChartState<X>,
    b: &ChartState<X>,
) -> f64 {
    let d = |k: usize, s: &ChartState<X>| target.ln_target_space_density(k, s);
    d(a.chart, b) + d(b.chart, a) - d(a.chart, a) - d(b.chart, b)
}

/// Propose exchanging the points of chains at `a` and `b` (evaluated valid states): accept with
/// eq. 24 (through `mcmc_core`'s acceptance function), then draw the coordinates.
pub fn exchange<X, I: Integrand<X>, C: Chart<X>>(
    target: &ChartedTarget<'_, X, I, C>,
    a: &ChartState<X>,
    b: &ChartState<X>,
    rng: &mut ChainRng,
) -> Exchange {
    let d = |k: usize, s: &ChartState<X>| target.ln_target_space_density(k, s);
    let (num, den) = (d(a.chart, b) + d(b.chart, a), d(a.chart, a) + d(b.chart, b));
    if !(a.valid && b.valid && a.fresh && b.fresh) || num == f64::NEG_INFINITY || num.is_nan() {
        return Exchange::NotApplicable;
    }
    let (p, invalid) = acceptance(den, num, 0.0);
    if invalid {
        return Exchange::NotApplicable;
    }
    if !(uniform(rng) < p) {
        return Exchange::Rejected(p);
    }
    let atlas = target.atlas;
    let (mut ua, mut ub) = (Vec::new(), Vec::new());
    if !atlas.inverse_from(a.chart, &b.x, b.chart, &b.u, &mut ua, rng)
        || !atlas.inverse_from(b.chart, &a.x, a.chart, &a.u, &mut ub, rng)
    {
        return Exchange::Failed;
    }
    Exchange::Accepted(p, ua, ub)
}
