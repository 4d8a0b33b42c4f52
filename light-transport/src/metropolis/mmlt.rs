//! Multiplexed MLT (Hachisuka, Kaplanyan & Dachsbacher 2014): chains are grouped by path length
//! `k` (edges); a sample uses one bidirectional strategy `(s, k + 1 − s)`, chosen by the first
//! number of the technique stream (a coordinate Kelemen mutations perturb like any other), and
//! contributes its MIS-weighted value divided by the probability of choosing the strategy. Paths of
//! one edge use `(0, 2)` only (as in BDPT).
//!
//! With [`Mmlt::direct_apart`] the chains leave the paths of at most two edges to a direct pass
//! ([`super::SeparateDirect`]): their path lengths get no bootstrap weight, hence no chains.

use super::driver::Method;
use super::importance::ImportanceKind;
use super::pssmlt::{PrimaryState, mutate_primary};
use super::stream::PrimaryStream;
use crate::path::{MisHeuristic, Subpath, WalkSettings, connect, mis_weight, technique_subpaths};
use crate::sampler::{CAMERA_STREAM, SampleStream, TECHNIQUE_STREAM, layout};
use crate::scene::Scene;
use mcmc_core::kernel::Observer;
use mcmc_core::primary_sample::{Kelemen, LARGE_STEP};
use mcmc_core::{Chain, ChainRng, Proposal};
use std::cell::RefCell;

thread_local! {
    static SUBPATHS: RefCell<(Subpath, Subpath)> = const { RefCell::new((Subpath::new(), Subpath::new())) };
}

/// MMLT settings.
#[derive(Clone, Copy, Debug)]
pub struct Mmlt {
    /// Path length limit (chains exist for every length `1 ..= max_edges`).
    pub walk: WalkSettings,
    /// MIS heuristic of the strategy weights.
    pub heuristic: MisHeuristic,
    /// Small and large steps.
    pub kelemen: Kelemen,
    /// Colour to scalar.
    pub importance: ImportanceKind,
    /// Large steps count as independent samples of their path length's image too, combined with
    /// the chains by the balance heuristic (Kelemen et al. 2002 §4;
    /// [`super::record::LargeStepMis`]).
    pub large_step_mis: bool,
    /// Whether the paths of at most [`super::DIRECT_EDGES`] edges are left to a direct pass: the
    /// image of this method alone then lacks them ([`super::SeparateDirect`]).
    pub direct_apart: bool,
}

impl Mmlt {
    /// Whether the chains sample some paths of `k` edges.
    fn samples_length(&self, k: usize) -> bool {
        !(self.direct_apart && k <= super::DIRECT_EDGES)
    }

    /// Number of strategies for paths of `k` edges.
    pub fn strategies(k: usize) -> usize {
        if k == 1 { 1 } else { k + 1 }
    }

    /// Evaluate a state of length `k` (its group + 1).
    pub fn evaluate(&self, scene: &Scene, k: usize, state: &mut PrimaryState) {
        state.contribution.splats.clear();
        state.contribution.importance = 0.0;
        let n = Self::strategies(k);
        let mut stream = PrimaryStream::new(&mut state.sample);
        stream.start_stream(TECHNIQUE_STREAM);
        stream.seek(layout::TECHNIQUE);
        let u = stream.next_1d();
        let s = mcmc_core::rng::uniform_index(u, n);
        let t = k + 1 - s;
        let value = SUBPATHS.with(|b| {
            let (cam, light) = &mut *b.borrow_mut();
            if !technique_subpaths(scene, &mut stream, s, t, cam, light) {
                return None;
            }
            let c = connect(scene, light, cam, s, t)?;
            let wgt = mis_weight(scene, light, cam, s, t, self.heuristic, c.ends);
            Some((c.raster, c.value * (wgt * n as f64)))
        });
        if let Some((raster, v)) = value
            && !v.is_black()
        {
            let r = raster.unwrap_or_else(|| {
                scene.camera.raster_of_film([
                    state.sample.get(CAMERA_STREAM, layout::FILM),
                    state.sample.get(CAMERA_STREAM, layout::FILM + 1),
                ])
            });
            state.contribution.splats.push((r, v));
            state.contribution.importance = self.importance.of(v);
        }
    }
}

impl super::DirectApart for Mmlt {
    fn without_direct(self) -> Self {
        Self {
            direct_apart: true,
            ..self
        }
    }
    fn max_edges(&self) -> usize {
        self.walk.max_edges
    }
}

impl Method for Mmlt {
    type State = PrimaryState;

    fn groups(&self) -> usize {
        self.walk.max_edges
    }

    fn details(&self) -> Vec<String> {
        vec![super::record::LargeStepMis::report(self.large_step_mis)]
    }

    fn independent(&self, scene: &Scene, g: usize, seed: u64) -> (PrimaryState, f64) {
        let mut s = PrimaryState::new(self.kelemen, seed, g + 1);
        if !self.samples_length(g + 1) {
            return (s, 0.0);
        }
        self.evaluate(scene, g + 1, &mut s);
        let w = s.contribution.importance;
        (s, w)
    }

    fn independent_weight(&self, scene: &Scene, g: usize, seed: u64) -> f64 {
        if !self.samples_length(g + 1) {
            return 0.0;
        }
        super::pssmlt::bootstrap_weight(self.kelemen, seed, g + 1, |s| {
            self.evaluate(scene, g + 1, s)
        })
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
        // A chain keeps the path length of the bootstrap sample it was seeded from.
        mutate_primary(
            scene,
            self.kelemen,
            |sc, st| self.evaluate(sc, st.length, st),
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
