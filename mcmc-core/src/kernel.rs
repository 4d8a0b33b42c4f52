//! The Metropolis–Hastings step (Metropolis et al. 1953, Hastings 1970) with guards, the chain
//! state it acts on, and observers for expected-value recording.
//!
//! Acceptance of a candidate `y` from `x` with reported ratio `r = ln q(x|y) − ln q(y|x)`:
//! `a = min(1, exp(ln π(y) − ln π(x) + r))`. Guards:
//! * a NaN or `+inf` density or ratio is *invalid*: counted and rejected (`a = 0`);
//! * a current state of zero density (`ln π(x) = −inf`) accepts any valid candidate (`a = 1`), so a
//!   chain started off the support walks until it finds it;
//! * a zero-density candidate or a reverse move of zero density (`r = −inf`) is rejected.

use crate::rng::uniform;
use crate::stats::Failure;
use crate::{ChainRng, McmcError, Proposal, Stats, Target};

/// The acceptance probability and whether the inputs were invalid (NaN or `+inf`).
#[inline]
pub fn acceptance(ln_current: f64, ln_candidate: f64, ln_ratio: f64) -> (f64, bool) {
    if ln_candidate.is_nan()
        || ln_candidate == f64::INFINITY
        || ln_ratio.is_nan()
        || ln_ratio == f64::INFINITY
        || ln_current.is_nan()
        || ln_current == f64::INFINITY
    {
        return (0.0, true);
    }
    if ln_current == f64::NEG_INFINITY {
        return (1.0, false);
    }
    if ln_candidate == f64::NEG_INFINITY || ln_ratio == f64::NEG_INFINITY {
        return (0.0, false);
    }
    let l = ln_candidate - ln_current + ln_ratio;
    (if l >= 0.0 { 1.0 } else { l.exp() }, false)
}

/// Receives every proposal with its acceptance probability, before the accept/reject decision.
/// Recording `a·g(proposed) + (1−a)·g(current)` gives the expected-value estimator that renderers
/// use to make rejected proposals count.
pub trait Observer<S> {
    /// Called once per proposal.
    fn observe(&mut self, current: &S, proposed: &S, acceptance: f64, kind: usize);
}

impl<S> Observer<S> for () {
    #[inline]
    fn observe(&mut self, _: &S, _: &S, _: f64, _: usize) {}
}

/// An observer from a closure.
pub struct FnObserver<F>(pub F);

impl<S, F: FnMut(&S, &S, f64, usize)> Observer<S> for FnObserver<F> {
    #[inline]
    fn observe(&mut self, current: &S, proposed: &S, acceptance: f64, kind: usize) {
        (self.0)(current, proposed, acceptance, kind)
    }
}

impl<S, O: Observer<S> + ?Sized> Observer<S> for &mut O {
    #[inline]
    fn observe(&mut self, current: &S, proposed: &S, acceptance: f64, kind: usize) {
        (**self).observe(current, proposed, acceptance, kind)
    }
}

/// A chain: the current state with its cached log density, a reusable candidate buffer, and
/// acceptance statistics.
#[derive(Clone, Debug)]
pub struct Chain<S> {
    /// The current state.
    pub state: S,
    /// `ln π(state)` under the target the chain currently samples.
    pub ln_density: f64,
    /// Buffer for candidates (kept to avoid allocation; its content is unspecified).
    pub candidate: S,
    /// Acceptance counters per move kind.
    pub stats: Stats,
}

impl<S: Clone> Chain<S> {
    /// Start at `x0`, evaluating the target there; refuses a zero, NaN or infinite density.
    pub fn start<T: Target<S>>(target: &T, mut x0: S) -> Result<Self, McmcError> {
        let l = target.evaluate(&mut x0);
        Self::with_density(x0, l)
    }

    /// Start at `x0` whose log density `ln_density` is already known.
    pub fn with_density(x0: S, ln_density: f64) -> Result<Self, McmcError> {
        if !ln_density.is_finite() {
            return Err(McmcError::BadInitialState { ln_density });
        }
        Ok(Self::unchecked(x0, ln_density))
    }

    /// Start anywhere, even where the density is zero (the chain then accepts any valid move).
    pub fn unchecked(x0: S, ln_density: f64) -> Self {
        Self {
            candidate: x0.clone(),
            state: x0,
            ln_density,
            stats: Stats::default(),
        }
    }
}

impl<S> Chain<S> {
    /// Decide on the candidate now in [`Chain::candidate`]: record, draw, and on acceptance make it
    /// current. Returns whether it was accepted. This is the one place where every kernel of this
    /// crate (and of crates built on it) makes its accept/reject decision.
    #[inline]
    pub fn decide<O: Observer<S>>(
        &mut self,
        ln_candidate: f64,
        ln_ratio: f64,
        kind: usize,
        rng: &mut ChainRng,
        observer: &mut O,
    ) -> bool {
        let (a, invalid) = acceptance(self.ln_density, ln_candidate, ln_ratio);
        observer.observe(&self.state, &self.candidate, a, kind);
        let accepted = a >= 1.0 || (a > 0.0 && uniform(rng) < a);
        self.stats.record(kind, a, accepted, invalid);
        if accepted {
            std::mem::swap(&mut self.state, &mut self.candidate);
            self.ln_density = ln_candidate;
        }
        accepted
    }

    /// Count a proposal of `kind` that could not be made and stay: the observer sees the current
    /// state proposed to itself with `a = 0`, so expected-value recording still counts the step.
    #[inline]
    pub fn fail<O: Observer<S>>(&mut self, kind: usize, why: Failure, observer: &mut O) {
        observer.observe(&self.state, &self.state, 0.0, kind);
        self.stats.record_failure(kind, why);
    }
}

/// A Markov kernel acting on a [`Chain`].
pub trait Kernel<S> {
    /// One transition.
    fn step<O: Observer<S>>(&mut self, chain: &mut Chain<S>, rng: &mut ChainRng, observer: &mut O);

    /// Names of the move kinds this kernel reports.
    fn kinds(&self) -> Vec<String>;

    /// `n` transitions without an observer.
    fn run(&mut self, chain: &mut Chain<S>, n: usize, rng: &mut ChainRng) {
        for _ in 0..n {
            self.step(chain, rng, &mut ());
        }
    }
}

/// The Metropolis–Hastings kernel of a target and a proposal.
///
/// ```
/// use mcmc_core::{Chain, Kernel, MetropolisHastings, proposals::GaussianRandomWalk, rng::stream};
/// let target = |x: &Vec<f64>| -0.5 * x[0] * x[0];
/// let mut mh = MetropolisHastings::new(target, GaussianRandomWalk::new(1.0).unwrap());
/// let mut chain = Chain::start(&target, vec![0.0]).unwrap();
/// mh.run(&mut chain, 1000, &mut stream(1, 0));
/// assert!(chain.stats.total().acceptance_rate() > 0.3);
/// ```
#[derive(Clone, Debug)]
pub struct MetropolisHastings<T, P> {
    /// The target `π`.
    pub target: T,
    /// The proposal `q`.
    pub proposal: P,
}

impl<T, P> MetropolisHastings<T, P> {
    /// The kernel of `target` and `proposal`.
    pub fn new(target: T, proposal: P) -> Self {
        Self { target, proposal }
    }
}

impl<S, T: Target<S>, P: Proposal<S>> Kernel<S> for MetropolisHastings<T, P> {
    #[inline]
    fn step<O: Observer<S>>(&mut self, chain: &mut Chain<S>, rng: &mut ChainRng, observer: &mut O) {
        let p = self
            .proposal
            .propose(&chain.state, &mut chain.candidate, rng);
        if let Some(why) = p.failure {
            chain.fail(p.kind, why, observer);
            return;
        }
        let l = self.target.evaluate(&mut chain.candidate);
        chain.decide(l, p.ln_ratio, p.kind, rng, observer);
    }

    fn kinds(&self) -> Vec<String> {
        self.proposal.kinds()
    }
}

impl<S, K: Kernel<S> + ?Sized> Kernel<S> for &mut K {
    fn step<O: Observer<S>>(&mut self, chain: &mut Chain<S>, rng: &mut ChainRng, observer: &mut O) {
        (**self).step(chain, rng, observer)
    }
    fn kinds(&self) -> Vec<String> {
        (**self).kinds()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guards() {
        let inf = f64::INFINITY;
        assert_eq!(acceptance(0.0, f64::NAN, 0.0), (0.0, true));
        assert_eq!(acceptance(0.0, inf, 0.0), (0.0, true));
        assert_eq!(acceptance(0.0, 0.0, f64::NAN), (0.0, true));
        assert_eq!(acceptance(0.0, 0.0, inf), (0.0, true));
        assert_eq!(acceptance(-inf, -5.0, 0.0), (1.0, false));
        assert_eq!(acceptance(-inf, -inf, 0.0), (1.0, false));
        assert_eq!(acceptance(0.0, -inf, 0.0), (0.0, false));
        assert_eq!(acceptance(0.0, 0.0, -inf), (0.0, false));
        assert_eq!(acceptance(0.0, 1.0, 0.0), (1.0, false));
        assert!((acceptance(0.0, -1.0, 0.5).0 - (-0.5f64).exp()).abs() < 1e-15);
        // Ratios of densities spanning many orders of magnitude stay exact in the log domain.
        assert!((acceptance(700.0, -700.0, 1399.0).0 - (-1f64).exp()).abs() < 1e-12);
    }

    #[test]
    fn invalid_candidates_are_counted_and_rejected() {
        let target = |x: &Vec<f64>| {
            if x[0] > 0.5 {
                f64::NAN
            } else {
                -0.5 * x[0] * x[0]
            }
        };
        let mut chain = Chain::start(&target, vec![0.0]).unwrap();
        let mut mh = MetropolisHastings::new(
            target,
            crate::proposals::GaussianRandomWalk::new(1.0).unwrap(),
        );
        mh.run(&mut chain, 2000, &mut crate::rng::stream(0, 0));
        let t = chain.stats.total();
        assert!(t.invalid > 100, "{t:?}");
        assert!(chain.state[0] <= 0.5);
        assert!(chain.ln_density.is_finite());
    }

    #[test]
    fn start_refuses_zero_density() {
        let target = |_: &f64| f64::NEG_INFINITY;
        assert!(matches!(
            Chain::start(&target, 0.0),
            Err(McmcError::BadInitialState { .. })
        ));
    }
}
