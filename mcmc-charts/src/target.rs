//! The targets of charted Metropolis light transport (paper §3.2–3.4) as a
//! [`mcmc_core::Family`] over the atlas: level `i` is chart `i`'s primary-space target.
//!
//! * **Importance-sampled** (eq. 12): `π_i(u) = f(x) / p_i(x)`, `x = T_i(u)`; its target-space law
//!   is `f` in every chart.
//! * **Weighted** (eq. 14/16/21): `π_i(u) = f(x) / Σ_k p_k(x)`; target-space law
//!   `π̄_i = w_i f` with the balance-heuristic weight `w_i = p_i / Σ_k p_k`, and `Σ_i π̄_i = f`. The
//!   value is the same in every chart at the same point (eq. 17), and has no geometric-term
//!   singularities when all techniques are in the atlas.
//! * **Visibility** (eq. 18): `π'_i(u) = V(x)`, a user predicate (visibility of the one connection
//!   the technique does not sample); target-space law `V p_i`.
//!
//! Colour (§3.4): `f` is the scalar importance `f*` (e.g. the maximum RGB component) of the
//! [`Integrand`]; a recorder re-weights each recorded point by `f(x) / f*(x)`.

use crate::{Atlas, Chart, ChartState};
use mcmc_core::rng::{categorical, uniform};
use mcmc_core::{ChainRng, Family, Target};

/// The scalar importance `f*(x) ≥ 0` a charted chain samples.
pub trait Integrand<X>: Sync {
    /// `f*(x)`.
    fn importance(&self, x: &X) -> f64;
}

impl<X, F: Fn(&X) -> f64 + Sync> Integrand<X> for F {
    fn importance(&self, x: &X) -> f64 {
        self(x)
    }
}

/// Which primary-space targets the levels carry.
pub enum TargetKind<X> {
    /// `π_i = f / p_i` (eq. 12).
    ImportanceSampled,
    /// `π_i = f / Σ_k p_k` (eq. 16).
    Weighted,
    /// `π'_i = V(x)` for a user predicate (eq. 18).
    Visibility(Box<dyn Fn(&X) -> bool + Send + Sync>),
}

impl<X> std::fmt::Debug for TargetKind<X> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            TargetKind::ImportanceSampled => "ImportanceSampled",
            TargetKind::Weighted => "Weighted",
            TargetKind::Visibility(_) => "Visibility",
        })
    }
}

/// The per-chart targets over an atlas; implements [`Family`] with chart swaps as transfers.
pub struct ChartedTarget<'a, X, I, C = Box<dyn Chart<X>>> {
    /// The atlas.
    pub atlas: &'a Atlas<X, C>,
    /// The integrand.
    pub integrand: I,
    /// The kind of target.
    pub kind: TargetKind<X>,
}

impl<'a, X, I: Integrand<X>, C: Chart<X>> ChartedTarget<'a, X, I, C> {
    /// The targets of `kind` for `integrand` over `atlas`.
    pub fn new(atlas: &'a Atlas<X, C>, integrand: I, kind: TargetKind<X>) -> Self {
        Self {
            atlas,
            integrand,
            kind,
        }
    }

    /// Bring the cached evaluation of a state up to date with its coordinates.
    pub fn refresh(&self, s: &mut ChartState<X>) {
        if s.fresh {
            return;
        }
        if let Some(c) = self.atlas.chart(s.chart) {
            s.valid = s.u.len() == c.dim() && c.forward(&s.u, &mut s.x);
        }
        self.evaluate_point(s);
    }

    /// Evaluate the integrand and every chart's density at the state's point `s.x`, which is
    /// taken to be a valid point (a target-space move just placed it there); the coordinates are
    /// left as they are.
    pub fn refresh_point(&self, s: &mut ChartState<X>) {
        s.valid = true;
        self.evaluate_point(s);
    }

    fn evaluate_point(&self, s: &mut ChartState<X>) {
        if s.valid {
            s.importance = self.integrand.importance(&s.x);
            self.atlas.ln_densities(&s.x, &mut s.ln_p);
            if !(s.importance.is_finite() && s.importance >= 0.0) {
                s.importance = f64::NAN; // reported as invalid by the kernel
            }
        } else {
            s.importance = 0.0;
        }
        s.fresh = true;
    }

    /// `ln Σ_k c_k π̄_k(x)`: the point marginal of a chain over (chart, coordinates) with joint
    /// target `c_k π_k(u)`, at an evaluated valid state (`ln_weights = ln c`).
    pub fn ln_marginal(&self, s: &ChartState<X>, ln_weights: &[f64]) -> f64 {
        let terms: Vec<f64> = (0..self.atlas.levels())
            .map(|k| ln_weights[k] + self.ln_target_space_density(k, s))
            .collect();
        mcmc_core::proposals::log_sum_exp(&terms)
    }

    /// Draw a level `k` with probability `c_k π̄_k(x) / Σ_j c_j π̄_j(x)`: the conditional law of
    /// the chart given the point under the joint target (`None` when every term is zero).
    pub fn draw_level(
        &self,
        s: &ChartState<X>,
        ln_weights: &[f64],
        rng: &mut ChainRng,
    ) -> Option<usize> {
        let terms: Vec<f64> = (0..self.atlas.levels())
            .map(|k| ln_weights[k] + self.ln_target_space_density(k, s))
            .collect();
        let top = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !top.is_finite() {
            return None;
        }
        let w: Vec<f64> = terms.iter().map(|t| (t - top).exp()).collect();
        categorical(&w, uniform(rng))
    }

    /// `ln Σ_k p_k(x)` of an evaluated state.
    fn ln_sum(s: &ChartState<X>) -> f64 {
        mcmc_core::proposals::log_sum_exp(&s.ln_p)
    }

    /// The target-space density `ln π̄_level(x)` of an evaluated valid state.
    pub fn ln_target_space_density(&self, level: usize, s: &ChartState<X>) -> f64 {
        let ln_f = s.importance.ln();
        match &self.kind {
            TargetKind::ImportanceSampled => ln_f,
            TargetKind::Weighted => ln_f + s.ln_p[level] - Self::ln_sum(s),
            TargetKind::Visibility(v) => {
                if v(&s.x) {
                    s.ln_p[level]
                } else {
                    f64::NEG_INFINITY
                }
            }
        }
    }
}

impl<X: Clone, I: Integrand<X>, C: Chart<X>> Family<ChartState<X>> for ChartedTarget<'_, X, I, C> {
    fn levels(&self) -> usize {
        self.atlas.levels()
    }

    /// `ln π_level(u)`: the primary-space density of the level's target (`= ln π̄_level(x) −
    /// ln p_level(x)`; in the identity chart the target-space density itself).
    fn ln_density(&self, level: usize, s: &mut ChartState<X>) -> f64 {
        debug_assert_eq!(level, s.chart, "a state is evaluated in its own chart");
        self.refresh(s);
        if !s.valid {
            return f64::NEG_INFINITY;
        }
        if s.importance.is_nan() {
            return f64::NAN;
        }
        match &self.kind {
            TargetKind::Visibility(v) => {
                if v(&s.x) {
                    0.0
                } else {
                    f64::NEG_INFINITY
                }
            }
            // A point of zero integrand, or outside the level's image, has density zero there
            // (not the NaN `−∞ − (−∞)` would give).
            _ if s.importance == 0.0 || s.ln_p[level] == f64::NEG_INFINITY => f64::NEG_INFINITY,
            _ => self.ln_target_space_density(level, s) - s.ln_p[level],
        }
    }

    /// The chart swap: keep the point, draw new coordinates from the exact conditional inverse of
    /// chart `to` (see [`Atlas::reparameterise`]).
    fn transfer(
        &self,
        from: usize,
        to: usize,
        x: &ChartState<X>,
        y: &mut ChartState<X>,
        rng: &mut ChainRng,
    ) -> f64 {
        debug_assert_eq!(from, x.chart);
        if x.fresh {
            self.atlas.reparameterise(x, to, y, rng)
        } else {
            let mut src = x.clone();
            self.refresh(&mut src);
            self.atlas.reparameterise(&src, to, y, rng)
        }
    }
}

/// The joint target `c_k π_k(u)` of a chain over (chart, coordinates): a [`Target`] for
/// Metropolis–Hastings kernels whose moves change the chart ([`crate::moves::ChartSwap`], the
/// Gibbs refresh of [`crate::moves::Refresh`]). Its point marginal is `Σ_k c_k π̄_k`; with the
/// weighted targets and equal pseudo-priors that is the integrand itself (eq. 17).
pub struct Joint<'a, X, I, C = Box<dyn Chart<X>>> {
    /// The per-chart targets.
    pub target: &'a ChartedTarget<'a, X, I, C>,
    /// `ln c_k`, one per level.
    pub ln_weights: Vec<f64>,
}

impl<'a, X, I: Integrand<X>, C: Chart<X>> Joint<'a, X, I, C> {
    /// Equal pseudo-priors (`c_k = 1`).
    pub fn new(target: &'a ChartedTarget<'a, X, I, C>) -> Self {
        Self {
            ln_weights: vec![0.0; target.atlas.levels()],
            target,
        }
    }

    /// Pseudo-priors `ln c_k` (one finite value per level).
    pub fn with_weights(
        target: &'a ChartedTarget<'a, X, I, C>,
        ln_weights: Vec<f64>,
    ) -> Result<Self, mcmc_core::McmcError> {
        if ln_weights.len() != target.atlas.levels() || ln_weights.iter().any(|w| !w.is_finite()) {
            return Err(mcmc_core::McmcError::InvalidParameter {
                name: "ln_weights",
                reason: format!(
                    "need one finite log weight per level ({}), got {:?}",
                    target.atlas.levels(),
                    ln_weights
                ),
            });
        }
        Ok(Self { target, ln_weights })
    }
}

impl<X: Clone, I: Integrand<X>, C: Chart<X>> Target<ChartState<X>> for Joint<'_, X, I, C> {
    fn ln_density(&self, x: &ChartState<X>) -> f64 {
        let mut y = x.clone();
        self.evaluate(&mut y)
    }

    fn evaluate(&self, x: &mut ChartState<X>) -> f64 {
        let l = self.target.ln_density(x.chart, x);
        if l == f64::NEG_INFINITY || l.is_nan() {
            return l;
        }
        self.ln_weights[x.chart] + l
    }
}

impl<X: Clone, I: Integrand<X>, C: Chart<X>> Target<ChartState<X>> for &Joint<'_, X, I, C> {
    fn ln_density(&self, x: &ChartState<X>) -> f64 {
        (**self).ln_density(x)
    }

    fn evaluate(&self, x: &mut ChartState<X>) -> f64 {
        (**self).evaluate(x)
    }
}
