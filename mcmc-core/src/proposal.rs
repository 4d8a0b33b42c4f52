//! Proposals: how a candidate `y` is drawn from the current state `x`.
//!
//! A proposal reports the log transition ratio `ln q(x|y) − ln q(y|x)` of the candidate it drew
//! (zero for a symmetric proposal, `ln q(x) − ln q(y)` for an independence sampler) together with a
//! *kind*, the index of the move type that produced it, so acceptance can be reported per move type.

use crate::{ChainRng, Failure};

/// What a proposal reports with its candidate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Proposed {
    /// `ln q(x|y) − ln q(y|x)`: the log ratio of reverse to forward transition densities.
    pub ln_ratio: f64,
    /// Index of the move type that produced the candidate (see [`Proposal::kinds`]).
    pub kind: usize,
    /// Set when no candidate could be made (the move does not apply to `x`, or its construction
    /// failed part-way): the kernel then counts the failure and stays, recording the current state
    /// as a rejected proposal ([`crate::Chain::fail`]); the content of `y` is unspecified.
    pub failure: Option<Failure>,
}

impl Proposed {
    /// A symmetric move of kind 0.
    pub const SYMMETRIC: Proposed = Proposed {
        ln_ratio: 0.0,
        kind: 0,
        failure: None,
    };

    /// A move of kind 0 with the given log ratio.
    pub fn with_ratio(ln_ratio: f64) -> Self {
        Self::new(ln_ratio, 0)
    }

    /// A move of `kind` with the given log ratio.
    pub fn new(ln_ratio: f64, kind: usize) -> Self {
        Self {
            ln_ratio,
            kind,
            failure: None,
        }
    }

    /// No candidate of `kind` could be made, for reason `why`.
    pub fn failed(kind: usize, why: Failure) -> Self {
        Self {
            ln_ratio: f64::NEG_INFINITY,
            kind,
            failure: Some(why),
        }
    }
}

/// A transition kernel `q(y|x)` that draws candidates.
///
/// `propose` writes the candidate into `y`, which holds a previous state of the same shape (kernels
/// reuse buffers; a proposal must overwrite every part of `y` it relies on).
pub trait Proposal<S> {
    /// Draw `y ~ q(·|x)` and report `ln q(x|y) − ln q(y|x)`.
    fn propose(&self, x: &S, y: &mut S, rng: &mut ChainRng) -> Proposed;

    /// `ln q(to|from)` when the proposal can evaluate it (needed by the combined mixture rule and by
    /// the pointwise balance check); `None` otherwise.
    fn ln_transition_density(&self, from: &S, to: &S) -> Option<f64> {
        let _ = (from, to);
        None
    }

    /// `(ln q(y|x), ln q(x|y))` for a candidate `y` just proposed from `x` by this proposal or by
    /// another component of the same mixture. A proposal whose candidates carry an auxiliary
    /// record of how they were made (which part of a path was regenerated, say) evaluates both
    /// densities *for that record*: the forward density of making `y` with it, and the reverse
    /// density of making `x` from `y` with the reversed record. The combined mixture rule sums
    /// these over components, which is exact on the space extended by the record. The default
    /// evaluates [`Proposal::ln_transition_density`] both ways.
    fn ln_pair_densities(&self, x: &S, y: &S) -> Option<(f64, f64)> {
        Some((
            self.ln_transition_density(x, y)?,
            self.ln_transition_density(y, x)?,
        ))
    }

    /// How suitable the proposal is for moving `x`: a non-negative weight, 0 when it cannot move
    /// `x` at all (a perturbation of a path without the vertices it needs). A mixture built with
    /// [`crate::proposals::Selection::Suitability`] chooses components in proportion to their base
    /// weight times this value and puts the selection probabilities in the ratio, so the choice
    /// stays exact. The default is 1 (always suitable).
    fn suitability(&self, x: &S) -> f64 {
        let _ = x;
        1.0
    }

    /// `ln q(to, kind | from)`: the density of drawing `to` by a move of `kind`, on the space in
    /// which the reported ratio is exact, i.e. `Proposed::ln_ratio = ln_move_density(to, from, kind)
    /// − ln_move_density(from, to, kind)`. It equals [`Proposal::ln_transition_density`] unless the
    /// kind is an auxiliary variable of the move: a per-component mixture reports `ln P_k +
    /// ln q_k(to|from)` (its ratio is exact on the space extended by the component index).
    fn ln_move_density(&self, from: &S, to: &S, kind: usize) -> Option<f64> {
        let _ = kind;
        self.ln_transition_density(from, to)
    }

    /// For proposals with finitely many outcomes from `x`: every outcome with its probability and
    /// what [`Proposal::propose`] reports for it. Used by the exact balance checks on finite state
    /// spaces ([`crate::balance::finite`]); `None` otherwise.
    fn outcomes(&self, x: &S) -> Option<Vec<Outcome<S>>> {
        let _ = x;
        None
    }

    /// Names of the move types this proposal reports, indexed by [`Proposed::kind`].
    fn kinds(&self) -> Vec<String> {
        let full = std::any::type_name::<Self>();
        let short = full.split('<').next().unwrap_or(full);
        vec![short.rsplit("::").next().unwrap_or(short).to_string()]
    }

    /// `kinds().len()`, without building the names (mixtures call it when they are built).
    fn kind_count(&self) -> usize {
        self.kinds().len()
    }
}

impl<S, P: Proposal<S> + ?Sized> Proposal<S> for &P {
    fn propose(&self, x: &S, y: &mut S, rng: &mut ChainRng) -> Proposed {
        (**self).propose(x, y, rng)
    }
    fn ln_transition_density(&self, from: &S, to: &S) -> Option<f64> {
        (**self).ln_transition_density(from, to)
    }
    fn ln_move_density(&self, from: &S, to: &S, kind: usize) -> Option<f64> {
        (**self).ln_move_density(from, to, kind)
    }
    fn ln_pair_densities(&self, x: &S, y: &S) -> Option<(f64, f64)> {
        (**self).ln_pair_densities(x, y)
    }
    fn suitability(&self, x: &S) -> f64 {
        (**self).suitability(x)
    }
    fn outcomes(&self, x: &S) -> Option<Vec<Outcome<S>>> {
        (**self).outcomes(x)
    }
    fn kinds(&self) -> Vec<String> {
        (**self).kinds()
    }
    fn kind_count(&self) -> usize {
        (**self).kind_count()
    }
}

impl<S, P: Proposal<S> + ?Sized> Proposal<S> for Box<P> {
    fn propose(&self, x: &S, y: &mut S, rng: &mut ChainRng) -> Proposed {
        (**self).propose(x, y, rng)
    }
    fn ln_transition_density(&self, from: &S, to: &S) -> Option<f64> {
        (**self).ln_transition_density(from, to)
    }
    fn ln_move_density(&self, from: &S, to: &S, kind: usize) -> Option<f64> {
        (**self).ln_move_density(from, to, kind)
    }
    fn ln_pair_densities(&self, x: &S, y: &S) -> Option<(f64, f64)> {
        (**self).ln_pair_densities(x, y)
    }
    fn suitability(&self, x: &S) -> f64 {
        (**self).suitability(x)
    }
    fn outcomes(&self, x: &S) -> Option<Vec<Outcome<S>>> {
        (**self).outcomes(x)
    }
    fn kinds(&self) -> Vec<String> {
        (**self).kinds()
    }
    fn kind_count(&self) -> usize {
        (**self).kind_count()
    }
}

/// One possible result of a proposal with finitely many outcomes.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome<S> {
    /// The candidate.
    pub state: S,
    /// Its probability given the current state.
    pub probability: f64,
    /// What the proposal reports when it draws it.
    pub proposed: Proposed,
}

/// A normalised distribution that can be sampled exactly and whose density can be evaluated:
/// the proposal of an independence sampler, or the exact law a balance check draws from.
pub trait Density<S> {
    /// Draw a state into `out`.
    fn sample(&self, rng: &mut ChainRng, out: &mut S);
    /// Log density of `x` (with respect to the same reference measure as the target).
    fn ln_pdf(&self, x: &S) -> f64;
}
