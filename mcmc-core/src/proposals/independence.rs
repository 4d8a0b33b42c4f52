//! Independence sampler: `y ~ q` regardless of `x`, reporting `ln q(x) − ln q(y)` (Tierney 1994).
//! With `q` uniform on the unit cube this is the *large step* of primary-sample-space MLT.

use crate::{ChainRng, Density, Proposal, Proposed};

/// Propose from a fixed distribution `q`.
#[derive(Clone, Debug)]
pub struct Independence<D> {
    /// The proposal distribution.
    pub density: D,
}

impl<D> Independence<D> {
    /// An independence sampler drawing from `density`.
    pub fn new(density: D) -> Self {
        Self { density }
    }
}

impl<S, D: Density<S>> Proposal<S> for Independence<D> {
    fn propose(&self, x: &S, y: &mut S, rng: &mut ChainRng) -> Proposed {
        self.density.sample(rng, y);
        Proposed::with_ratio(self.density.ln_pdf(x) - self.density.ln_pdf(y))
    }

    fn ln_transition_density(&self, _from: &S, to: &S) -> Option<f64> {
        Some(self.density.ln_pdf(to))
    }

    fn kinds(&self) -> Vec<String> {
        vec!["independence".into()]
    }
}

/// The uniform distribution on `[0,1)^n` (the dimension is that of the state written to).
#[derive(Clone, Copy, Debug, Default)]
pub struct UniformCube;

impl<S: AsRef<[f64]> + AsMut<[f64]>> Density<S> for UniformCube {
    fn sample(&self, rng: &mut ChainRng, out: &mut S) {
        for v in out.as_mut() {
            *v = crate::rng::uniform(rng);
        }
    }
    fn ln_pdf(&self, x: &S) -> f64 {
        if x.as_ref().iter().all(|v| (0.0..1.0).contains(v)) {
            0.0
        } else {
            f64::NEG_INFINITY
        }
    }
}
