//! Primary-sample-space MLT (Kelemen et al. 2002) on bidirectional path tracing: the state is a
//! lazy primary sample (camera, light and technique streams), the target is the scalar importance
//! of the sum of MIS-weighted contributions of *all* strategies connecting the two subpaths it
//! generates, and the moves are Kelemen's small and large steps.
//!
//! With the BDPT's Russian roulette ([`crate::path::Roulette`]) the walks stop early where the
//! roulette numbers of the primary sample say so and the survivors carry `1/q`: the target is then
//! another function of the primary sample with the same integral, and a state still replays
//! exactly, since the decisions are read from its numbers.

use super::driver::Method;
use super::importance::ImportanceKind;
use super::record::{Contribution, LargeStepMis, Recordable};
use super::separate_direct::{DIRECT_EDGES, DirectApart};
use super::stream::PrimaryStream;
use crate::integrators::Bdpt;
use crate::path::Subpath;
use crate::sampler::{CAMERA_STREAM, STREAMS, layout};
use crate::scene::Scene;
use crate::spectrum::Rgb;
use mcmc_core::kernel::Observer;
use mcmc_core::primary_sample::{Kelemen, LARGE_STEP, PrimarySample};
use mcmc_core::{Chain, ChainRng, Kernel, MetropolisHastings, Proposal, Proposed, Target};
use std::cell::RefCell;

thread_local! {
    static SUBPATHS: RefCell<(Subpath, Subpath)> = const { RefCell::new((Subpath::new(), Subpath::new())) };
    /// The state a thread evaluates its bootstrap samples in ([`bootstrap_weight`]).
    static BOOTSTRAP: RefCell<Option<PrimaryState>> = const { RefCell::new(None) };
}

/// The importance of the fresh state `PrimaryState::new(kelemen, seed, length)` evaluated by
/// `evaluate`, computed in a per-thread state whose storage is reused: the bootstrap of PSSMLT
/// and MMLT evaluates 100 000 samples per path length and keeps none of them.
pub(super) fn bootstrap_weight(
    kelemen: Kelemen,
    seed: u64,
    length: usize,
    evaluate: impl FnOnce(&mut PrimaryState),
) -> f64 {
    BOOTSTRAP.with_borrow_mut(|slot| {
        let state = match slot {
            Some(state) => {
                state.sample.reset(kelemen.small_step, seed);
                state.contribution.splats.clear();
                state.contribution.importance = 0.0;
                state.length = length;
                state
            }
            None => slot.insert(PrimaryState::new(kelemen, seed, length)),
        };
        evaluate(state);
        state.contribution.importance
    })
}

/// A PSSMLT (or MMLT) chain state: the primary sample and what it evaluated to.
#[derive(Clone, Debug)]
pub struct PrimaryState {
    /// The lazy primary sample.
    pub sample: PrimarySample,
    /// Its contribution.
    pub contribution: Contribution,
    /// The path length (edges) of an MMLT chain; 0 for PSSMLT (all lengths at once).
    pub length: usize,
}

impl PrimaryState {
    /// A fresh state of path length `length` (0: all lengths) on the stream of `seed`,
    /// unevaluated.
    pub fn new(kelemen: Kelemen, seed: u64, length: usize) -> Self {
        Self {
            sample: PrimarySample::with_validated_step(STREAMS, kelemen.small_step, seed),
            contribution: Contribution::default(),
            length,
        }
    }
}

impl Recordable for PrimaryState {
    fn contribution(&self) -> &Contribution {
        &self.contribution
    }
    fn group(&self) -> usize {
        self.length.saturating_sub(1)
    }
}

/// PSSMLT settings.
#[derive(Clone, Copy, Debug)]
pub struct Pssmlt {
    /// The BDPT that evaluates a sample (path length limit, MIS heuristic).
    pub bdpt: Bdpt,
    /// Small and large steps.
    pub kelemen: Kelemen,
    /// Colour to scalar.
    pub importance: ImportanceKind,
    /// Large steps count as independent samples of the image too, combined with the chain by
    /// the balance heuristic (Kelemen et al. 2002 §4; [`super::record::LargeStepMis`]).
    pub large_step_mis: bool,
    /// Whether the paths of at most [`DIRECT_EDGES`] edges are left to a direct pass: the image of
    /// this method alone then lacks them ([`super::SeparateDirect`]).
    pub direct_apart: bool,
}

impl Pssmlt {
    /// Evaluate a state: trace both subpaths from its numbers and sum every strategy.
    pub fn evaluate(&self, scene: &Scene, state: &mut PrimaryState) {
        state.contribution.splats.clear();
        SUBPATHS.with(|b| {
            let (cam, light) = &mut *b.borrow_mut();
            let mut stream = PrimaryStream::new(&mut state.sample);
            self.bdpt
                .trace_subpaths(scene, &mut stream, None, cam, light);
            let splats = &mut state.contribution.splats;
            let own = if self.direct_apart {
                let mut own = Rgb::BLACK;
                self.bdpt.strategies(scene, light, cam, None, |c| {
                    if c.s + c.t - 1 <= DIRECT_EDGES {
                        return;
                    }
                    match c.raster {
                        Some(r) => splats.push((r, c.value)),
                        None => own += c.value,
                    }
                });
                own
            } else {
                self.bdpt.evaluate(scene, light, cam, splats, None)
            };
            let raster = scene.camera.raster_of_film([
                state.sample.get(CAMERA_STREAM, layout::FILM),
                state.sample.get(CAMERA_STREAM, layout::FILM + 1),
            ]);
            if !own.is_black() {
                state.contribution.splats.push((raster, own));
            }
        });
        state.contribution.importance = state
            .contribution
            .splats
            .iter()
            .map(|s| self.importance.of(s.1))
            .sum();
    }
}

/// The chain's target: the importance of a primary state (evaluated lazily, cached in the state).
pub struct PrimaryTarget<'a, F> {
    /// The scene.
    pub scene: &'a Scene,
    /// Evaluates a state in place.
    pub eval: F,
}

impl<F: Fn(&Scene, &mut PrimaryState)> Target<PrimaryState> for PrimaryTarget<'_, F> {
    fn ln_density(&self, x: &PrimaryState) -> f64 {
        x.contribution.importance.ln()
    }
    fn evaluate(&self, x: &mut PrimaryState) -> f64 {
        (self.eval)(self.scene, x);
        x.contribution.importance.ln()
    }
}

/// Kelemen's proposal acting on the primary sample of a state.
#[derive(Clone, Copy, Debug)]
pub struct PrimaryProposal(pub Kelemen);

impl Proposal<PrimaryState> for PrimaryProposal {
    fn propose(&self, x: &PrimaryState, y: &mut PrimaryState, rng: &mut ChainRng) -> Proposed {
        y.length = x.length;
        self.0.propose(&x.sample, &mut y.sample, rng)
    }
    fn kinds(&self) -> Vec<String> {
        self.0.kinds()
    }
}

/// Run `n` Kelemen mutations on a primary-sample chain with evaluation `eval`.
pub fn mutate_primary<O: Observer<PrimaryState>>(
    scene: &Scene,
    kelemen: Kelemen,
    eval: impl Fn(&Scene, &mut PrimaryState),
    chain: &mut Chain<PrimaryState>,
    n: u64,
    rng: &mut ChainRng,
    observer: &mut O,
) {
    let mut mh = MetropolisHastings::new(PrimaryTarget { scene, eval }, PrimaryProposal(kelemen));
    for _ in 0..n {
        mh.step(chain, rng, observer);
    }
}

impl DirectApart for Pssmlt {
    fn without_direct(self) -> Self {
        Self {
            direct_apart: true,
            ..self
        }
    }
    fn max_edges(&self) -> usize {
        self.bdpt.walk.max_edges
    }
}

impl Method for Pssmlt {
    type State = PrimaryState;

    fn details(&self) -> Vec<String> {
        let mut lines = vec![LargeStepMis::report(self.large_step_mis)];
        lines.extend(crate::path::Roulette::report(self.bdpt.roulette));
        lines
    }

    fn groups(&self) -> usize {
        1
    }

    fn independent(&self, scene: &Scene, _g: usize, seed: u64) -> (PrimaryState, f64) {
        let mut s = PrimaryState::new(self.kelemen, seed, 0);
        self.evaluate(scene, &mut s);
        let w = s.contribution.importance;
        (s, w)
    }

    fn independent_weight(&self, scene: &Scene, _g: usize, seed: u64) -> f64 {
        bootstrap_weight(self.kelemen, seed, 0, |s| self.evaluate(scene, s))
    }

    fn ln_density(&self, _scene: &Scene, state: &PrimaryState) -> f64 {
        state.contribution.importance.ln()
    }

    fn mutate<O: Observer<PrimaryState>>(
        &self,
        scene: &Scene,
        chain: &mut Chain<PrimaryState>,
        n: u64,
        rng: &mut ChainRng,
        observer: &mut O,
    ) {
        mutate_primary(
            scene,
            self.kelemen,
            |sc, st| self.evaluate(sc, st),
            chain,
            n,
            rng,
            observer,
        )
    }

    fn kinds(&self) -> Vec<String> {
        self.kelemen.kinds()
    }

    fn large_steps(&self) -> Option<(usize, f64)> {
        self.large_step_mis
            .then_some((LARGE_STEP, self.kelemen.large_step_probability))
    }

    fn independent_proposals(&self) -> Option<usize> {
        // A large step draws a fresh primary sample, as the bootstrap does.
        (self.kelemen.large_step_probability > 0.0).then_some(LARGE_STEP)
    }
}
