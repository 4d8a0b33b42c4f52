//! Inverse primary-space perturbation (paper eq. 26–27): a target-space chain steps down into a
//! chart through its stochastic inverse, perturbs there, and maps back.

use crate::{Atlas, ChartState, ChartedTarget, Integrand};
use mcmc_core::{ChainRng, Proposal, Proposed};

/// IPSM through chart `chart` with the cube proposal `kernel`, for states in the identity chart.
pub struct InversePerturbation<'a, X, I, P> {
    /// The targets (used to evaluate the charts' densities at the candidate).
    pub target: &'a ChartedTarget<'a, X, I>,
    /// The chart to step through.
    pub chart: usize,
    /// The perturbation on `[0,1)^d`.
    pub kernel: P,
    /// Whether to leave out the `p_i(x) / p_i(y)` factor — deliberately broken, for testing checks.
    pub forget_density_ratio: bool,
}

impl<'a, X, I, P> InversePerturbation<'a, X, I, P> {
    /// IPSM through `chart` with `kernel`.
    pub fn new(target: &'a ChartedTarget<'a, X, I>, chart: usize, kernel: P) -> Self {
        Self {
            target,
            chart,
            kernel,
            forget_density_ratio: false,
        }
    }

    fn atlas(&self) -> &Atlas<X> {
        self.target.atlas
    }
}

impl<X: Clone, I: Integrand<X>, P: Proposal<Vec<f64>>> Proposal<ChartState<X>>
    for InversePerturbation<'_, X, I, P>
{
    fn propose(&self, x: &ChartState<X>, y: &mut ChartState<X>, rng: &mut ChainRng) -> Proposed {
        let atlas = self.atlas();
        let reject = |y: &mut ChartState<X>| {
            y.clone_from(x);
            Proposed::with_ratio(f64::NEG_INFINITY)
        };
        let Some(chart) = atlas.chart(self.chart) else {
            return reject(y);
        };
        if !x.valid {
            return reject(y);
        }
        let ln_px = chart.ln_density(&x.x);
        let mut u = vec![0.0; chart.dim()];
        if ln_px == f64::NEG_INFINITY || !chart.invert(&x.x, &mut u, rng) {
            return reject(y); // outside the image of the chart: stay
        }
        let mut u2 = u.clone();
        let k = self.kernel.propose(&u, &mut u2, rng);
        y.chart = x.chart;
        y.u.clear();
        y.fresh = false;
        y.valid = chart.forward(&u2, &mut y.x);
        if !y.valid {
            return Proposed {
                ln_ratio: 0.0,
                kind: k.kind,
            };
        }
        let ln_py = chart.ln_density(&y.x);
        let bias = chart.ln_inverse_bias(&y.x, &u2) - chart.ln_inverse_bias(&x.x, &u);
        let ln_ratio = if self.forget_density_ratio {
            k.ln_ratio
        } else {
            k.ln_ratio + ln_px - ln_py + bias
        };
        Proposed {
            ln_ratio,
            kind: k.kind,
        }
    }

    fn kinds(&self) -> Vec<String> {
        self.kernel
            .kinds()
            .into_iter()
            .map(|k| format!("ipsm[{}]/{k}", self.atlas().name(self.chart)))
            .collect()
    }
}
