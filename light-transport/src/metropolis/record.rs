//! How Metropolis chains record what they sample (Veach & Guibas 1997 §3.4; charted-MLT paper
//! §5.4): every proposal deposits its expected value — `a` times the candidate and `1 − a` times
//! the current state — each weighted by `b / I`, so a chain whose states have density `I / b`
//! deposits the image. PSSMLT and MMLT also count their large steps as independent samples of the
//! image, combined with the chain by the balance heuristic (Kelemen et al. 2002 §4;
//! [`LargeStepMis`]), and path-space MLT can count its new paths so. *What* a state deposits is the recorder's business: splats on the film for
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
    /// As a candidate of the method's independent proposals
    /// ([`super::Method::independent_proposals`]), which are drawn as the bootstrap's samples
    /// of one stratum are: the group and stratum it is a sample of, and its bootstrap weight.
    /// By default the state's group, stratum 0 and its importance (a sample of unit density, as
    /// a large step's).
    fn independent_weight(&self) -> BootstrapSample {
        BootstrapSample {
            group: self.group(),
            stratum: 0,
            weight: self.contribution().importance,
        }
    }
    /// As a candidate of the large steps ([`LargeStepMis`]): the probability with which its move
    /// kind was chosen, given the state it was proposed from, when that depends on the state
    /// (path-space mutations chosen by suitability). `None` (the default): the declared
    /// [`LargeStepMis::probability`], the same from every state.
    fn proposal_probability(&self) -> Option<f64> {
        None
    }
}

/// Where an independent sample falls in the bootstrap, and its weight there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BootstrapSample {
    /// Its group.
    pub group: usize,
    /// Its stratum in the group ([`super::Method::strata`]; 0 for a method without strata).
    pub stratum: usize,
    /// Its bootstrap weight: importance over the density of a bootstrap sample, the choice of
    /// its stratum included.
    pub weight: f64,
}

/// Receives what chain states deposit.
pub trait Recorder<S>: Send {
    /// Deposit `weight` times what `state` contributes (`weight` already includes `b / I`).
    fn record(&mut self, state: &S, weight: f64);
    /// Deposit `weight` times what `state` contributes to the estimate of its group's chains,
    /// whose scale the driver refines as the render goes on ([`Sink::chain_scales`]: the
    /// deposit counts times its group's scale). A recorder that keeps no groups apart records
    /// it as [`Recorder::record`] (its sink then keeps the bootstrap's normalisation).
    fn record_chain(&mut self, state: &S, weight: f64) {
        self.record(state, weight);
    }
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
    /// Where the importance of independent candidates is summed to refine the normalisation,
    /// if anywhere: the chains' deposits then go to [`Recorder::record_chain`].
    pub tally: Option<&'a mut NormalisationTally>,
}

/// Independent samples the chains draw as they run, summed per group and stratum to refine the
/// bootstrap's normalisation `b_g` (Kelemen et al. 2002 §4 estimate `b` from the large steps: a
/// large step's candidate is a sample of unit density over its group's primary space, so the mean
/// of its importance is an unbiased estimate of `b_g`, as a bootstrap sample's is).
///
/// A method whose bootstrap first picks one of `n` strata uniformly (charted MLT: a technique
/// chart) and whose chains draw samples of one stratum at a time (a large step in the chain's
/// chart) gets a post-stratified estimate: `b_g = (1/n) Σ_s` (mean bootstrap weight in stratum
/// `s`), each mean over the bootstrap's and the chains' samples of that stratum. With one
/// stratum that is the plain mean.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NormalisationTally {
    /// The move kind whose candidates are independent samples.
    pub kind: usize,
    /// Sum of their bootstrap weights per group and stratum (non-finite or negative weights
    /// count as 0, as in the bootstrap).
    pub sum: Vec<Vec<f64>>,
    /// Their number per group and stratum.
    pub count: Vec<Vec<u64>>,
}

impl NormalisationTally {
    /// An empty tally of the candidates of move kind `kind` over groups of `strata[g]` strata.
    pub fn new(kind: usize, strata: &[usize]) -> Self {
        Self {
            kind,
            sum: strata.iter().map(|&n| vec![0.0; n.max(1)]).collect(),
            count: strata.iter().map(|&n| vec![0; n.max(1)]).collect(),
        }
    }

    /// Count a sample (a non-finite or negative weight counts as 0). A group of one stratum
    /// takes every sample of the group, whatever stratum it names (its bootstrap is not
    /// stratified); a group or stratum outside the tally, which no method's bootstrap has, is
    /// not counted at all.
    #[inline]
    pub fn add(&mut self, x: BootstrapSample) {
        let w = if x.weight.is_finite() && x.weight > 0.0 {
            x.weight
        } else {
            0.0
        };
        let stratum = match self.sum.get(x.group) {
            Some(v) if v.len() == 1 => 0,
            _ => x.stratum,
        };
        if let (Some(s), Some(c)) = (
            self.sum.get_mut(x.group).and_then(|v| v.get_mut(stratum)),
            self.count.get_mut(x.group).and_then(|v| v.get_mut(stratum)),
        ) {
            *s += w;
            *c += 1;
        }
    }

    /// Add another tally's counts (in a fixed order, for results independent of the threads).
    pub fn merge(&mut self, o: &Self) {
        for (a, b) in self.sum.iter_mut().zip(&o.sum) {
            a.iter_mut().zip(b).for_each(|(a, b)| *a += b);
        }
        for (a, b) in self.count.iter_mut().zip(&o.count) {
            a.iter_mut().zip(b).for_each(|(a, b)| *a += b);
        }
    }

    /// The estimate of group `g`'s normalisation, or `None` while a stratum of it has no
    /// sample.
    pub fn normalisation(&self, g: usize) -> Option<f64> {
        let (sum, count) = (self.sum.get(g)?, self.count.get(g)?);
        let mut b = 0.0;
        for (s, &n) in sum.iter().zip(count) {
            if n == 0 {
                return None;
            }
            b += s / n as f64;
        }
        Some(b / sum.len() as f64)
    }

    /// Samples counted in all.
    pub fn samples(&self) -> u64 {
        self.count.iter().flatten().sum()
    }
}

/// Kelemen et al. (2002) §4: a chain whose move kind `kind` is, with probability `probability`, an
/// independent sample of unit density over its group's primary space yields two estimators of the
/// image at once, the chain's (states of density `I / b_g`) and the large steps' (density
/// `probability`). Combined by the balance heuristic, a state deposits `f / (I / b_g + p)` (times
/// `b / b_g`, the chain's share of the image) with the expected-value weight, and a large step's
/// candidate deposits that once more: where `I ≪ p b_g` the image comes from the independent
/// samples, where `I ≫ p b_g` from the chain.
///
/// In general a state `x` deposits `b / (I(x) + p d(x))` with `d(x) = b q(x)`, `q` the independent
/// proposal's density in the measure in which `I` is the state's (unnormalised) density and `b`
/// the normalisation of the chain that contains `x`; [`LargeStepMis::density`] holds `d` per
/// independent group ([`Recordable::independent_weight`]). A large step in primary space has
/// `q = 1` within its group: `d = b_g`. Path-space MLT's new path (Veach & Guibas 1997 §5.3.3)
/// has `q = P_len(k) / (k + 1)` against `I = f / Σ_s p_s` (README). Where the chance of an
/// independent proposal depends on the state it is made from (`p(x)`: a mixture choosing its
/// mutations by suitability), its candidate's second deposit is multiplied by `p / p(x)`
/// ([`Recordable::proposal_probability`]), which keeps the large steps' estimate unbiased; `p` is
/// then any constant near the mean rate (the weights sum to one for every `p`).
#[derive(Clone, Copy, Debug)]
pub struct LargeStepMis<'a> {
    /// The move kind of the large steps.
    pub kind: usize,
    /// Their probability per proposal.
    pub probability: f64,
    /// `d = b q` per independent group: the normalisation times the independent proposal's
    /// density (for large steps in primary space `b_g`, the group's normalisation).
    pub density: &'a [f64],
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
    /// `b / I` (or, with large steps combined, `b / (I + p d)`) for a state of importance
    /// `i`, or `None` if the state deposits nothing.
    #[inline]
    fn scale<S: Recordable>(&self, s: &S) -> Option<f64> {
        let i = s.contribution().importance;
        if !(i > 0.0) || !i.is_finite() {
            return None;
        }
        // A state's group is one of the driver's (a method's invariant, not input).
        let independent = self.large_steps.map_or(0.0, |l| {
            let d = l.density.get(s.independent_weight().group).copied();
            l.probability * d.unwrap_or(0.0)
        });
        Some(self.b / (i + independent))
    }

    /// How many times a large step's candidate `s` counts in the large steps' own estimate: once,
    /// or `p / p(x)` when the chance of the large step depended on the state it was proposed
    /// from.
    #[inline]
    fn independent_factor<S: Recordable>(&self, s: &S) -> f64 {
        let declared = self.large_steps.map_or(1.0, |l| l.probability);
        match s.proposal_probability() {
            Some(p) if p > 0.0 => declared / p,
            Some(_) => 0.0,
            None => 1.0,
        }
    }

    /// Deposit `w` times the state's contribution to the chain's estimate, scaled by `b / I`
    /// (or `b / (I + p d)`).
    #[inline]
    pub fn record<S: Recordable>(&mut self, s: &S, w: f64)
    where
        R: Recorder<S>,
    {
        if w <= 0.0 {
            return;
        }
        if let Some(k) = self.scale(s) {
            if self.tally.is_some() {
                self.recorder.record_chain(s, w * k);
            } else {
                self.recorder.record(s, w * k);
            }
        }
    }
}

impl<S: Recordable, R: Recorder<S>> Observer<S> for ExpectedValue<'_, R> {
    #[inline]
    fn observe(&mut self, current: &S, proposed: &S, a: f64, kind: usize) {
        // A proposal that could not be made is observed as the current state proposed to itself
        // (`Chain::fail`): no independent sample was drawn, so it does not count as one.
        let made = !std::ptr::eq(current, proposed);
        if let Some(t) = self.tally.as_deref_mut()
            && made
            && t.kind == kind
        {
            t.add(proposed.independent_weight());
        }
        let large = made && self.large_steps.is_some_and(|l| l.kind == kind);
        self.record(current, 1.0 - a);
        let independent = if large {
            self.independent_factor(proposed)
        } else {
            0.0
        };
        if self.tally.is_none() {
            self.record(proposed, a + independent);
            return;
        }
        self.record(proposed, a);
        // The large step's candidate once more, as the large steps' own estimate: not the
        // chain's, so its scale stays (`b_g` enters it only through the balance heuristic).
        if independent > 0.0
            && let Some(k) = self.scale(proposed)
        {
            self.recorder.record(proposed, k * independent);
        }
    }
}

/// Where the driver puts what the chains record, round by round.
pub trait Sink<S>: Send {
    /// A recorder for one group of chains in one round.
    type Chunk: Recorder<S> + Send;
    /// An empty chunk.
    fn chunk(&self) -> Self::Chunk;
    /// Absorb a chunk's deposits (called in chunk order), leaving it without them: the same
    /// chunk goes on recording (its buffers keep their storage).
    fn absorb(&mut self, chunk: &mut Self::Chunk);
    /// The chains have made `mutations` mutations in all, on an image of `pixels` pixels.
    fn mutations_done(&mut self, mutations: u64, pixels: f64);
    /// What the chains of group `g` recorded by [`Recorder::record_chain`], so far and from now
    /// on, counts `scales[g]` times (the refined normalisation over the bootstrap's). A sink
    /// whose recorders keep no groups apart ignores it, and keeps the bootstrap's
    /// normalisation.
    fn chain_scales(&mut self, _scales: &[f64]) {}
}

/// What one group of chains deposits on the film in a round: splats, and the splats of the
/// chains' own estimate with their group (the film's splat layer of that group).
#[derive(Clone, Debug, Default)]
pub struct FilmChunk {
    splats: Vec<Splat>,
    chain: Vec<(usize, Splat)>,
}

impl<S: Recordable> Recorder<S> for FilmChunk {
    #[inline]
    fn record(&mut self, state: &S, weight: f64) {
        self.splats.record(state, weight);
    }

    #[inline]
    fn record_chain(&mut self, state: &S, weight: f64) {
        let g = state.group();
        for &(r, v) in &state.contribution().splats {
            self.chain.push((g, (r, v * weight)));
        }
    }
}

impl<S: Recordable> Sink<S> for Film {
    type Chunk = FilmChunk;

    fn chunk(&self) -> FilmChunk {
        FilmChunk::default()
    }

    fn absorb(&mut self, chunk: &mut FilmChunk) {
        for (r, v) in chunk.splats.drain(..) {
            self.add_splat(r, v);
        }
        for (g, (r, v)) in chunk.chain.drain(..) {
            self.add_layer_splat(g, r, v);
        }
    }

    fn chain_scales(&mut self, scales: &[f64]) {
        for (g, &k) in scales.iter().enumerate() {
            self.set_layer_scale(g, k);
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
                density: &b,
            }),
            tally: None,
        };
        let (x, y) = (state(), state());
        rec.observe(&x, &y, 0.0, 1); // made and rejected: x with 1 − a, y as a sample
        rec.observe(&x, &x, 0.0, 1); // not made: x with 1 − a only
        rec.observe(&x, &y, 0.0, 0); // a small step, rejected: x only
        // Each deposit is 2 · b / (I + p b_0) = 2 / 2.5.
        let values: Vec<f64> = splats.iter().map(|s| s.1.max_component()).collect();
        assert_eq!(values, [0.8; 4]);
    }

    /// A candidate in a group of its own (path space: its length) whose large step was chosen
    /// with a probability of its own.
    struct Chosen(Contribution, usize, Option<f64>);

    impl Recordable for Chosen {
        fn contribution(&self) -> &Contribution {
            &self.0
        }
        fn independent_weight(&self) -> BootstrapSample {
            BootstrapSample {
                group: self.1,
                stratum: 0,
                weight: self.0.importance,
            }
        }
        fn proposal_probability(&self) -> Option<f64> {
            self.2
        }
    }

    /// The balance heuristic takes `d` of each state's independent group, and a large step's
    /// candidate chosen with probability `p(x)` counts `p / p(x)` times in the large steps' own
    /// estimate (once when it reports none, not at all when it reports 0), with a tally and
    /// without.
    #[test]
    fn large_steps_use_the_density_of_the_group_and_the_chance_of_the_step() {
        let d = [1.0, 3.0];
        let state = |group, chosen| Chosen(state().0, group, chosen);
        for tally in [false, true] {
            let mut counted = NormalisationTally::new(1, &[1, 1]);
            let mut splats = Vec::new();
            let mut rec = ExpectedValue {
                recorder: &mut splats,
                b: 1.0,
                large_steps: Some(LargeStepMis {
                    kind: 1,
                    probability: 0.5,
                    density: &d,
                }),
                tally: tally.then_some(&mut counted),
            };
            let x = state(0, None);
            // 2 · b / (I + p d_g): 0.8 in group 0, 2 / 3.5 in group 1.
            let (k0, k1) = (0.8, 2.0 / 3.5);
            for (y, factor) in [
                (state(1, Some(0.25)), 2.0),
                (state(1, None), 1.0),
                (state(1, Some(0.0)), 0.0),
            ] {
                rec.observe(&x, &y, 0.5, 1);
                let got: f64 = rec.recorder.drain(..).map(|s| s.1.max_component()).sum();
                let expected = 0.5 * k0 + 0.5 * k1 + factor * k1;
                assert!((got - expected).abs() < 1e-12, "{tally} {factor}: {got}");
            }
        }
    }

    /// With a tally the chains' deposits go to their group's layer and the large step's second
    /// deposit stays apart; the tally counts the candidates of large steps that were made, with
    /// non-finite importance as 0.
    #[test]
    fn a_tally_counts_the_candidates_of_large_steps_made() {
        let b = [1.0];
        let mut chunk = FilmChunk::default();
        let mut tally = NormalisationTally::new(1, &[1]);
        let mut rec = ExpectedValue {
            recorder: &mut chunk,
            b: 1.0,
            large_steps: Some(LargeStepMis {
                kind: 1,
                probability: 0.5,
                density: &b,
            }),
            tally: Some(&mut tally),
        };
        let (x, y) = (state(), state());
        let mut z = state();
        z.0.importance = f64::NAN;
        rec.observe(&x, &y, 0.25, 1); // made: counted, y's independent deposit apart
        rec.observe(&x, &x, 0.0, 1); // not made: not counted
        rec.observe(&x, &y, 0.5, 0); // a small step: not counted
        rec.observe(&x, &z, 0.0, 1); // made, importance NaN: counted as 0
        assert_eq!(tally.count, [[2]]);
        assert_eq!(tally.sum, [[2.0]]);
        assert_eq!(tally.normalisation(0), Some(1.0));
        // 2 · b / (I + p b_0) = 0.8 per unit weight.
        let chain: Vec<f64> = chunk.chain.iter().map(|s| s.1.1.max_component()).collect();
        let expected = [0.6, 0.2, 0.8, 0.4, 0.4, 0.8];
        assert_eq!(chain.len(), expected.len());
        assert!(
            chain
                .iter()
                .zip(expected)
                .all(|(c, e)| (c - e).abs() < 1e-15),
            "{chain:?}"
        );
        assert!(chunk.chain.iter().all(|s| s.0 == 0));
        let independent: Vec<f64> = chunk.splats.iter().map(|s| s.1.max_component()).collect();
        assert_eq!(independent, [0.8]);
    }

    /// With strata, `b_g` is the mean over strata of each stratum's mean weight: here the
    /// weights of stratum 1 come three times as often as stratum 0's, which a plain mean would
    /// follow. A group of one stratum takes samples of any stratum; a stratum without samples
    /// leaves the group without an estimate.
    #[test]
    fn a_stratified_tally_averages_the_means_of_its_strata() {
        let sample = |group, stratum, weight| BootstrapSample {
            group,
            stratum,
            weight,
        };
        let mut tally = NormalisationTally::new(0, &[2, 1, 3]);
        tally.add(sample(0, 0, 1.0));
        for _ in 0..3 {
            tally.add(sample(0, 1, 3.0));
        }
        tally.add(sample(1, 0, 1.0));
        tally.add(sample(1, 4, 2.0));
        tally.add(sample(2, 0, f64::INFINITY));
        tally.add(sample(2, 1, 1.0));
        tally.add(sample(5, 0, 1.0)); // no such group
        assert_eq!(tally.normalisation(0), Some(2.0)); // (1 + 3) / 2, not 10 / 4
        assert_eq!(tally.normalisation(1), Some(1.5));
        assert_eq!(tally.normalisation(2), None);
        assert_eq!(tally.samples(), 8);
        let mut other = NormalisationTally::new(0, &[2, 1, 3]);
        other.add(sample(2, 2, 6.0));
        tally.merge(&other);
        assert_eq!(tally.normalisation(2), Some((0.0 + 1.0 + 6.0) / 3.0));
    }
}
