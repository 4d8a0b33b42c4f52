//! Targets: unnormalised densities, evaluated in the log domain.
//!
//! A density may be zero (log density `-inf`) outside its support and may span many orders of
//! magnitude; the Metropolis–Hastings step ([`crate::kernel`]) guards against NaN and `+inf`.

/// An unnormalised target density `π` over states of type `S`.
///
/// Any `Fn(&S) -> f64` returning the log density is a target:
///
/// ```
/// use mcmc_core::Target;
/// let standard_normal = |x: &f64| -0.5 * x * x;
/// assert_eq!(standard_normal.ln_density(&0.0), 0.0);
/// ```
pub trait Target<S> {
    /// `ln π(x)`; `f64::NEG_INFINITY` where the density is zero.
    fn ln_density(&self, x: &S) -> f64;

    /// Evaluate `ln π(x)` and let the state cache what the evaluation produced (a renderer keeps the
    /// path contribution it traced). Kernels call this on every proposal; the default forwards to
    /// [`Target::ln_density`].
    fn evaluate(&self, x: &mut S) -> f64 {
        self.ln_density(x)
    }
}

impl<S, F: Fn(&S) -> f64> Target<S> for F {
    fn ln_density(&self, x: &S) -> f64 {
        self(x)
    }
}

/// A family of targets `π_0, …, π_{K-1}` over one state space: tempered powers of one density, the
/// per-chart targets of charted Metropolis–Hastings, or any user family. Used by replica exchange and
/// serial tempering.
pub trait Family<S> {
    /// Number of levels `K`.
    fn levels(&self) -> usize;

    /// `ln π_k(x)`, letting the state cache what the evaluation produced.
    fn ln_density(&self, level: usize, x: &mut S) -> f64;

    /// Carry a state of level `from` over to level `to`, writing it to `y`, and return the log of the
    /// Green ratio of this re-parameterisation (zero when all levels share one state space, the
    /// default: `y = x`). A chart family re-parameterises the point through the stochastic inverse of
    /// chart `to` and returns `ln p_to(x̄) − ln p_from(x̄)`; see the `mcmc-charts` crate.
    fn transfer(&self, from: usize, to: usize, x: &S, y: &mut S, rng: &mut crate::ChainRng) -> f64
    where
        S: Clone,
    {
        let _ = (from, to, rng);
        y.clone_from(x);
        0.0
    }
}

/// Tempered powers `π_k = π^{β_k}` of one target, the classic replica-exchange family.
#[derive(Clone, Debug)]
pub struct Tempered<T> {
    /// The base target `π`.
    pub target: T,
    /// Inverse temperatures `β_0 = 1 > β_1 > …` (any order is allowed).
    pub betas: Vec<f64>,
}

impl<T> Tempered<T> {
    /// A tempered family; every `β` must be finite and positive.
    pub fn new(target: T, betas: Vec<f64>) -> Result<Self, crate::McmcError> {
        if betas.is_empty() {
            return Err(crate::McmcError::InvalidParameter {
                name: "betas",
                reason: "at least one inverse temperature is required".into(),
            });
        }
        for &b in &betas {
            crate::error::check_positive("beta", b)?;
        }
        Ok(Self { target, betas })
    }

    /// A geometric ladder of `levels` inverse temperatures from 1 down to `beta_min`.
    pub fn geometric(target: T, levels: usize, beta_min: f64) -> Result<Self, crate::McmcError> {
        crate::error::check_positive("beta_min", beta_min)?;
        if levels == 0 {
            return Err(crate::McmcError::InvalidParameter {
                name: "levels",
                reason: "must be at least 1".into(),
            });
        }
        let betas = (0..levels)
            .map(|k| {
                if levels == 1 {
                    1.0
                } else {
                    beta_min.powf(k as f64 / (levels - 1) as f64)
                }
            })
            .collect();
        Self::new(target, betas)
    }
}

impl<S, T: Target<S>> Family<S> for Tempered<T> {
    fn levels(&self) -> usize {
        self.betas.len()
    }
    fn ln_density(&self, level: usize, x: &mut S) -> f64 {
        let l = self.target.evaluate(x);
        if l == f64::NEG_INFINITY {
            l
        } else {
            self.betas[level] * l
        }
    }
}

/// A family given by one closure `(level, x) -> ln π_level(x)`.
#[derive(Clone, Debug)]
pub struct FnFamily<F> {
    levels: usize,
    f: F,
}

impl<F> FnFamily<F> {
    /// A family of `levels` targets evaluated by `f(level, x)`.
    pub fn new(levels: usize, f: F) -> Self {
        Self { levels, f }
    }
}

impl<S, F: Fn(usize, &S) -> f64> Family<S> for FnFamily<F> {
    fn levels(&self) -> usize {
        self.levels
    }
    fn ln_density(&self, level: usize, x: &mut S) -> f64 {
        (self.f)(level, x)
    }
}

/// The target of one level of a family, usable wherever a [`Target`] is expected.
#[derive(Clone, Copy, Debug)]
pub struct Level<'a, F> {
    /// The family.
    pub family: &'a F,
    /// The level.
    pub level: usize,
}

impl<S: Clone, F: Family<S>> Target<S> for Level<'_, F> {
    fn ln_density(&self, x: &S) -> f64 {
        let mut y = x.clone();
        self.family.ln_density(self.level, &mut y)
    }
    fn evaluate(&self, x: &mut S) -> f64 {
        self.family.ln_density(self.level, x)
    }
}

impl<S, F: Family<S> + ?Sized> Family<S> for &F {
    fn levels(&self) -> usize {
        (**self).levels()
    }
    fn ln_density(&self, level: usize, x: &mut S) -> f64 {
        (**self).ln_density(level, x)
    }
    fn transfer(&self, from: usize, to: usize, x: &S, y: &mut S, rng: &mut crate::ChainRng) -> f64
    where
        S: Clone,
    {
        (**self).transfer(from, to, x, y, rng)
    }
}
