//! The moves of charted Metropolis–Hastings, each an ordinary `mcmc-core` kernel, and the
//! derivation of their acceptance rules from Metropolis–Hastings–Green.
//!
//! # Setting
//! Chart `i` has primary space `U_i = [0,1)^{d_i}`, forward map `T_i`, pushforward density `p_i`
//! and exact conditional inverse `κ_i(·|x)`. For `U` uniform, the pair `(T_i(U), U)` has law
//! `p_i(x) dμ(x) · κ_i(du|x)`, i.e. **`du = p_i(x) dμ(x) κ_i(du|x)`** on `U_i` — the one identity
//! every rule below uses. A primary-space target `π_i(u)` that depends on `u` only through
//! `x = T_i(u)` therefore has target-space marginal `π̄_i(x) = π_i(u) p_i(x)`, and given `x` its
//! coordinates follow `κ_i(·|x)`.
//!
//! # In-chart moves ([`InChart`])
//! A proposal `K` on `U_i` (Kelemen's small step, a large step, a mixture) accepted with
//! `min(1, π_i(u') K(u|u') / (π_i(u) K(u'|u)))`: plain Metropolis–Hastings on `U_i`.
//!
//! # Chart swap by serial tempering (`mcmc_core::tempering::SerialTempering` over
//! [`crate::ChartedTarget`], or [`ChartSwap`] as a proposal on the [`crate::Joint`] target)
//! State `(u, i)` with joint target `c_i π_i(u)`, which by the identity above is
//! `c_i π̄_i(x) dμ(x) κ_i(du|x)`. The move keeps `x = T_i(u)`, proposes chart `j` with probability
//! `q(j|i)`, and draws `u' ~ κ_j(·|x)`. In the `(x, chart, u)` parameterisation this is a move of the
//! chart with `x` fixed, followed by an exact Gibbs draw of `u` given `(x, j)`; the Gibbs draw needs
//! no acceptance and the chart move is accepted with
//! `min(1, c_j π̄_j(x) q(i|j) / (c_i π̄_i(x) q(j|i)))`. In primary-space densities,
//! `π̄_j / π̄_i = π_j(u') p_j(x) / (π_i(u) p_i(x))`: the family's Green ratio is
//! `ln p_j(x) − ln p_i(x)`. For the weighted targets `π_i = f / Σ p` this is
//! `min(1, c_j p_j(x) / (c_i p_i(x)))` — the paper's eq. 25, with no evaluation of `f`. For the
//! importance-sampled targets every swap is accepted (all charts share the law `f`).
//!
//! # Chart swap by replica exchange (`mcmc_core::tempering::ReplicaExchange`, or [`exchange`])
//! Chains at `x1` (chart i) and `x2` (chart j) exchange points, each re-parameterised in the other's
//! chart by its exact inverse. Applying the argument above to the product target gives
//! `min(1, π̄_i(x2) π̄_j(x1) / (π̄_i(x1) π̄_j(x2)))`; with weighted targets
//! `min(1, p_i(x2) p_j(x1) / (p_i(x1) p_j(x2)))` (eq. 24).
//!
//! # Inverse primary-space perturbation ([`InversePerturbation`])
//! A target-space chain at `x ~ π̄` draws `u ~ κ_i(·|x)`, proposes `u' ~ K(·|u)`, and moves to
//! `y = T_i(u')`. The pair `(x, u)` has law `π̄(x) dμ κ_i(du|x) = (π̄(x) / p_i(x)) du`, so this is
//! Metropolis–Hastings on `U_i` for the target `π̄ ∘ T_i / p_i ∘ T_i`, accepted with
//! `min(1, π̄(y) p_i(x) K(u|u') / (π̄(x) p_i(y) K(u'|u)))` (eq. 26/27); it preserves the law of `u`,
//! hence of `x`. Points outside the image of `T_i` (`p_i(x) = 0`) are left where they are, which
//! preserves `π̄` restricted to that set.
//!
//! # Moves of the point from any chart ([`PointMove`], [`InversePerturbation`] with [`Refresh`])
//! A chain in the charts can take any move built for a chain on points: the point moves, then the
//! chart and coordinates are redrawn from their conditional law given the new point (a Gibbs draw
//! inside the proposal) or, for a chain that must keep its chart, only the coordinates. Writing
//! the proposal as `T(y|x) · g(k', u'|y)` with `g` the exact conditional, the Metropolis–Hastings
//! ratio on the joint target is `Π(y) T(x|y) / (Π(x) T(y|x))` with `Π = Σ_k c_k π̄_k` the point
//! marginal: `g` cancels. [`Refresh`] has the details.
//!
//! # Independence samplers in a chart ([`ChartIndependence`])
//! Given its chart `i`, a chain's point has law `π̄_i`. A point `y` drawn independently of the
//! current one, with density `Q_i`, followed by `u' ~ κ_i(·|y)`, is accepted with
//! `min(1, π̄_i(y) Q_i(x) / (π̄_i(x) Q_i(y)))` — the [`Refresh::KeepChart`] rule with the point ratio
//! `ln Q_i(x) − ln Q_i(y)`. Mixing an outside sampler `q_i` (probability `λ`) with the chart's own
//! pushforward `p_i`, `Q_i = λ q_i + (1 − λ) p_i` (the paper's eq. 29) or each component's own density
//! (eq. 28, a mixture of two valid kernels) are both exact.
//!
//! # Charts without an exact inverse
//! If `R_i` samples `ρ_i = λ_i κ_i` instead of `κ_i`, the Gibbs draws above become proposals and the
//! ratios gain `λ_i(u) / λ_j(u')` (swaps: the reverse move draws `u` with `λ_i`, the forward move
//! drew `u'` with `λ_j`) and `λ_i(u') / λ_i(u)` (IPSM). [`crate::Chart::ln_inverse_bias`] reports
//! `ln λ`; both moves include it.

mod exchange;
mod in_chart;
mod independent;
mod ipsm;
mod point_move;
mod refresh;
mod swap;
mod target_space;

pub use exchange::{Exchange, exchange, exchange_ln_ratio};
pub use in_chart::InChart;
pub use independent::{
    ChartIndependence, FROM_CHART, FROM_SAMPLER, IndependenceRule, PointSampler,
};
pub use ipsm::InversePerturbation;
pub use point_move::PointMove;
pub use refresh::Refresh;
pub use swap::ChartSwap;
pub use target_space::TargetSpace;
