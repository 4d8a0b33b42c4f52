//! Inverse primary-space perturbation (paper eq. 26–27): the chain steps down from its point into
//! a chart through that chart's stochastic inverse, perturbs there, and maps back.
//!
//! For a chain on points the move `x → y = T_j(K(R_j(x)))` is accepted with
//! `π̄(y) p_j(x) K(u|u') / (π̄(x) p_j(y) K(u'|u))`. States in the identity chart are such a chain
//! (the paper's setting); states in a chart reach the move through [`Refresh`]: the point moves as
//! above and the chain's own chart and coordinates follow it (Gibbs redraw, or kept).

use super::Refresh;
use crate::{Chart, ChartState, ChartedTarget, Integrand};
use mcmc_core::rng::{uniform, uniform_index};
use mcmc_core::{ChainRng, Proposal, Proposed};

/// IPSM through one chart, or through a chart chosen uniformly at every proposal.
pub struct InversePerturbation<'a, X, I, P, C = Box<dyn Chart<X>>> {
    /// The targets (used to evaluate the charts' densities at the candidate).
    pub target: &'a ChartedTarget<'a, X, I, C>,
    /// The chart to step through (`None`: one of the atlas' charts, uniformly, every time).
    pub chart: Option<usize>,
    /// The perturbation on `[0,1)^d`.
    pub kernel: P,
    /// What the chain's own chart and coordinates do (default: kept).
    pub refresh: Refresh,
    /// Whether to leave out the `p_j(x) / p_j(y)` factor — deliberately broken, for testing checks.
    pub forget_density_ratio: bool,
}

impl<'a, X, I, P, C> InversePerturbation<'a, X, I, P, C> {
    /// IPSM through `chart` with `kernel`.
    pub fn new(target: &'a ChartedTarget<'a, X, I, C>, chart: usize, kernel: P) -> Self {
        Self {
            target,
            chart: Some(chart),
            kernel,
            refresh: Refresh::KeepChart,
            forget_density_ratio: false,
        }
    }

    /// IPSM through a uniformly chosen chart of the atlas at every proposal.
    pub fn through_any_chart(target: &'a ChartedTarget<'a, X, I, C>, kernel: P) -> Self {
        Self {
            chart: None,
            ..Self::new(target, 0, kernel)
        }
    }

    /// Let the chain's chart and coordinates follow as `refresh` says.
    pub fn with_refresh(mut self, refresh: Refresh) -> Self {
        self.refresh = refresh;
        self
    }
}

impl<X: Clone, I: Integrand<X>, C: Chart<X>, P: Proposal<Vec<f64>>> Proposal<ChartState<X>>
    for InversePerturbation<'_, X, I, P, C>
{
    fn propose(&self, x: &ChartState<X>, y: &mut ChartState<X>, rng: &mut ChainRng) -> Proposed {
        let atlas = self.target.atlas;
        let reject = |y: &mut ChartState<X>| {
            y.clone_from(x);
            Proposed::with_ratio(f64::NEG_INFINITY)
        };
        let j = match self.chart {
            Some(j) => j,
            None if atlas.charts() > 0 => uniform_index(uniform(rng), atlas.charts()),
            None => return reject(y),
        };
        let Some(chart) = atlas.chart(j) else {
            return reject(y);
        };
        if !(x.valid && x.fresh) {
            return reject(y);
        }
        let ln_px = x.ln_p[j];
        let mut u = vec![0.0; chart.dim()];
        if ln_px == f64::NEG_INFINITY || !chart.invert(&x.x, &mut u, rng) {
            return reject(y); // outside the image of the chart: stay
        }
        let mut u2 = u.clone();
        let k = self.kernel.propose(&u, &mut u2, rng);
        if k.failure.is_some() {
            return k;
        }
        y.chart = x.chart;
        if !chart.forward(&u2, &mut y.x) {
            y.valid = false;
            y.fresh = true;
            y.importance = 0.0;
            return Proposed::new(f64::NEG_INFINITY, k.kind);
        }
        self.target.refresh_point(y);
        let ln_py = y.ln_p[j];
        let bias = chart.ln_inverse_bias(&y.x, &u2) - chart.ln_inverse_bias(&x.x, &u);
        let ln_point = if self.forget_density_ratio {
            k.ln_ratio
        } else {
            k.ln_ratio + ln_px - ln_py + bias
        };
        let r = self.refresh.settle(self.target, x, y, ln_point, rng);
        Proposed::new(r, k.kind)
    }

    fn kind_count(&self) -> usize {
        self.kernel.kind_count()
    }

    fn kinds(&self) -> Vec<String> {
        let through = match self.chart {
            Some(j) => format!("ipsm[{}]", self.target.atlas.name(j)),
            None => "ipsm".into(),
        };
        self.kernel
            .kinds()
            .into_iter()
            .map(|k| format!("{through}/{k}"))
            .collect()
    }
}
