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
use mcmc_core::kernel::acceptance;
use mcmc_core::rng::uniform;
use mcmc_core::{ChainRng, Family};

/// What an exchange proposal came to.
#[derive(Clone, Debug, PartialEq)]
pub enum Exchange<X> {
    /// Accepted with this probability; the new states of the two chains (in their own charts).
    Accepted(f64, ChartState<X>, ChartState<X>),
    /// Rejected with this acceptance probability.
    Rejected(f64),
    /// A point lies outside the other chain's chart (acceptance 0).
    NotApplicable,
    /// An inversion failed.
    Failed,
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

/// Propose exchanging the points of chains at `a` and `b` (evaluated valid states).
pub fn exchange<X: Clone, I: Integrand<X>, C: Chart<X>>(
    target: &ChartedTarget<'_, X, I, C>,
    a: &ChartState<X>,
    b: &ChartState<X>,
    rng: &mut ChainRng,
) -> Exchange<X> {
    let d = |k: usize, s: &ChartState<X>| target.ln_target_space_density(k, s);
    let (num, den) = (d(a.chart, b) + d(b.chart, a), d(a.chart, a) + d(b.chart, b));
    if num == f64::NEG_INFINITY || num.is_nan() {
        return Exchange::NotApplicable;
    }
    let (p, invalid) = acceptance(den, num, 0.0);
    if invalid {
        return Exchange::NotApplicable;
    }
    if !(uniform(rng) < p) {
        return Exchange::Rejected(p);
    }
    let (mut ya, mut yb) = (a.clone(), b.clone());
    let ga = target.transfer(b.chart, a.chart, b, &mut ya, rng);
    let gb = target.transfer(a.chart, b.chart, a, &mut yb, rng);
    if !(ga.is_finite() && gb.is_finite()) {
        return Exchange::Failed;
    }
    Exchange::Accepted(p, ya, yb)
}
