//! Gaussian random walk on `R^n`: `y = x + σ ⊙ ε`, `ε ~ N(0, I)`; symmetric.

use crate::error::check_positive;
use crate::{ChainRng, McmcError, Proposal, Proposed};
use rand::RngExt;
use rand_distr::StandardNormal;

/// Gaussian random walk with per-coordinate scales (one scale broadcasts to every coordinate).
#[derive(Clone, Debug)]
pub struct GaussianRandomWalk {
    sigma: Vec<f64>,
}

impl GaussianRandomWalk {
    /// The same scale `sigma` on every coordinate.
    pub fn new(sigma: f64) -> Result<Self, McmcError> {
        check_positive("sigma", sigma)?;
        Ok(Self { sigma: vec![sigma] })
    }

    /// One scale per coordinate.
    pub fn with_scales(sigma: Vec<f64>) -> Result<Self, McmcError> {
        if sigma.is_empty() {
            return Err(McmcError::InvalidParameter {
                name: "sigma",
                reason: "at least one scale is required".into(),
            });
        }
        for &s in &sigma {
            check_positive("sigma", s)?;
        }
        Ok(Self { sigma })
    }

    #[inline]
    fn scale(&self, i: usize) -> f64 {
        if self.sigma.len() == 1 {
            self.sigma[0]
        } else {
            self.sigma[i]
        }
    }
}

impl<S: AsRef<[f64]> + AsMut<[f64]>> Proposal<S> for GaussianRandomWalk {
    #[inline]
    fn propose(&self, x: &S, y: &mut S, rng: &mut ChainRng) -> Proposed {
        let (x, y) = (x.as_ref(), y.as_mut());
        for (i, (yi, &xi)) in y.iter_mut().zip(x).enumerate() {
            let e: f64 = rng.sample(StandardNormal);
            *yi = xi + self.scale(i) * e;
        }
        Proposed::SYMMETRIC
    }

    fn ln_transition_density(&self, from: &S, to: &S) -> Option<f64> {
        let mut l = 0.0;
        for (i, (a, b)) in from.as_ref().iter().zip(to.as_ref()).enumerate() {
            let s = self.scale(i);
            let z = (b - a) / s;
            l += -0.5 * z * z - s.ln() - 0.5 * (2.0 * std::f64::consts::PI).ln();
        }
        Some(l)
    }

    fn kinds(&self) -> Vec<String> {
        vec!["gaussian_walk".into()]
    }
}
