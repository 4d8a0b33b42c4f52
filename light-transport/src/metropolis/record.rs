//! How Metropolis chains record what they sample (Veach & Guibas 1997 §3.4; charted-MLT paper
//! §5.4): every proposal deposits its expected value — `a` times the candidate and `1 − a` times
//! the current state — each weighted by `b / I`, so a chain whose states have density `I / b`
//! deposits the image. PSSMLT and MMLT also count their large steps as independent samples of the
//! image, combined with the chain by the balance heuristic (Kelemen et al. 2002 §4;
//! [`LargeStepMis`]). *What* a state deposits is the recorder's business: splats on the film for
//! the image-space methods, photons at storage points for Metropolis photon sampling.
//!
//! The driver gives each group of chains its own [`Sink::Chunk`] per round, fills them in
//! parallel and hands them to the [`Sink`] in a fixed order, so results do not depend on the
//! thread count.

use crate::film::{Film, Splat};
use mcmc_core::kernel::Observer;

/// What a state contributes to the image: splats and the scalar importance `I` the chain samples.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Contribution {
    /// Raster positions and colours.
    pub splats: Vec<Splat>,
    /// The scalar importance (≥ 0).
    pub importance: f64,
}

/// A chain state that knows its contribution.
pub trait Recordable {
    /// The contribution of the state as last evaluated.
    fn contribution(&self) -> &Contribution;
    /// The driver's group of the state (MMLT: path length − 1); 0 unless a method has groups.
    fn group(&self) -> usize {
        0
    }
}

/// Receives what chain states deposit.
pub trait Recorder<S>: Send {
    /// Deposit `weight` times what `state` contributes (`weight` already includes `b / I`).
    fn record(&mut self, state: &S, weight: f64);
}

/// Splats go to a list (the film's recorder).
impl<S: Recordable> Recorder<S> for Vec<Splat> {
    #[inline]
    fn record(&mut self, state: &S, weight: f64) {
        for &(r, v) in &state.contribution().splats {
            self.push((r, v * weight));
        }
    }
}

/// The expected-value observer: every proposal deposits `1 − a` times the current state and `a`
/// times the candidate, each scaled by `b / I` (states of zero or non-finite importance deposit
/// nothing). Energy redistribution uses it with `b` = its energy quantum over the chain length.
pub struct ExpectedValue<'a, R> {
    /// Where deposits go.
    pub recorder: &'a mut R,
    /// The normalisation `b`.
    pub b: f64,
    /// Large steps combined with the chain by the balance heuristic, if any.
    pub large_steps: Option<LargeStepMis<'a>>,
}

/// Kelemen et al. (2002) §4: a chain whose move kind `kind` is, with probability `probability`, an
/// independent sample of unit density over its group's primary space yields two estimators of the
/// image at once, the chain's (states of density `I / b_g`) and the large steps' (density
/// `probability`). Combined by the balance heuristic, a state deposits `f / (I / b_g + p)` (times
/// `b / b_g`, the chain's share of the image) with the expected-value weight, and a large step's
/// candidate deposits that once more: where `I ≪ p b_g` the image comes from the independent
/// samples, where `I ≫ p b_g` from the chain.
#[derive(Clone, Copy, Debug)]
pub struct LargeStepMis<'a> {
    /// The move kind of the large steps.
    pub kind: usize,
    /// Their probability per proposal.
    pub probability: f64,
    /// The normalisation `b_g` of each group.
    pub group_normalisation: &'a [f64],
}

impl LargeStepMis<'_> {
    /// The summary line of a method whose large steps are (`on`) or are not counted as
    /// independent samples too.
    pub fn report(on: bool) -> String {
        if on {
            "large step counted twice: as a proposal and as an independent sample (balance heuristic; --large-step-mis)".into()
        } else {
            "large step counted as a proposal only (expected values; --large-step-mis false)".into()
        }
    }
}

impl<R> ExpectedValue<'_, R> {
    /// Deposit `w` times the state's contribution, scaled by `b / I` (or, with large steps
    /// combined, by `b / (I + p b_g)`).
    #[inline]
    pub fn record<S: Recordable>(&mut self, s: &S, w: f64)
    where
        R: Recorder<S>,
    {
        let i = s.contribution().importance;
        if w <= 0.0 || !(i > 0.0) || !i.is_finite() {
            return;
        }
        // A state's group is one of the driver's (a method's invariant, not input).
        let independent = self
            .large_steps
            .map_or(0.0, |l| l.probability * l.group_normalisation[s.group()]);
        self.recorder.record(s, w * self.b / (i + independent));
    }
}

impl<S: Recordable, R: Recorder<S>> Observer<S> for ExpectedValue<'_, R> {
    #[inline]
    fn observe(&mut self, current: &S, proposed: &S, a: f64, kind: usize) {
        // A proposal that could not be made is observed as the current state proposed to itself
        // (`Chain::fail`): no independent sample was drawn, so it does not count as one.
        let large =
            self.large_steps.is_some_and(|l| l.kind == kind) && !std::ptr::eq(current, proposed);
        self.record(current, 1.0 - a);
        self.record(proposed, a + if large { 1.0 } else { 0.0 });
    }
}

/// Where the driver puts what the chains record, round by round.
pub trait Sink<S>: Send {
    /// A recorder for one group of chains in one round.
    type Chunk: Recorder<S> + Send;
    /// An empty chunk.
    fn chunk(&self) -> Self::Chunk;
    /// Absorb a chunk (called in chunk order).
    fn absorb(&mut self, chunk: Self::Chunk);
    /// The chains have made `mutations` mutations in all, on an image of `pixels` pixels.
    fn mutations_done(&mut self, mutations: u64, pixels: f64);
}

impl<S: Recordable> Sink<S> for Film {
    type Chunk = Vec<Splat>;

    fn chunk(&self) -> Vec<Splat> {
        Vec::new()
    }

    fn absorb(&mut self, chunk: Vec<Splat>) {
        for (r, v) in chunk {
            self.add_splat(r, v);
        }
    }

    fn mutations_done(&mut self, mutations: u64, pixels: f64) {
        self.splat_scale = mutations as f64 / pixels;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::Rgb;

    struct State(Contribution);

    impl Recordable for State {
        fn contribution(&self) -> &Contribution {
            &self.0
        }
    }

    fn state() -> State {
        State(Contribution {
            splats: vec![([0.5, 0.5], Rgb::splat(2.0))],
            importance: 2.0,
        })
    }

    /// A large step that was made deposits the candidate once more (its independent sample); one
    /// that could not be made (the current state observed against itself) does not.
    #[test]
    fn only_a_large_step_that_was_made_counts_as_an_independent_sample() {
        let b = [1.0];
        let mut splats = Vec::new();
        let mut rec = ExpectedValue {
            recorder: &mut splats,
            b: 1.0,
            large_steps: Some(LargeStepMis {
                kind: 1,
                probability: 0.5,
                group_normalisation: &b,
            }),
        };
        let (x, y) = (state(), state());
        rec.observe(&x, &y, 0.0, 1); // made and rejected: x with 1 − a, y as a sample
        rec.observe(&x, &x, 0.0, 1); // not made: x with 1 − a only
        rec.observe(&x, &y, 0.0, 0); // a small step, rejected: x only
        // Each deposit is 2 · b / (I + p b_0) = 2 / 2.5.
        let values: Vec<f64> = splats.iter().map(|s| s.1.max_component()).collect();
        assert_eq!(values, [0.8; 4]);
    }
}
