//! Multiplexed MLT (Hachisuka, Kaplanyan & Dachsbacher 2014): chains are grouped by path length
//! `k` (edges); a sample uses one bidirectional strategy `(s, k + 1 − s)`, chosen by the first
//! number of the technique stream (a coordinate Kelemen mutations perturb like any other), and
//! contributes its MIS-weighted value divided by the probability of choosing the strategy. Paths of
//! one edge use `(0, 2)` only (as in BDPT).
//!
//! The bootstrap's sample `i` of every length reads the numbers of one key, addressed by position
//! ([`KeyedStream`]), so one camera and one light subpath walked to the longest length serve all
//! lengths ([`technique_subpaths_every_length`]); a chain seeded from it holds those numbers.
//!
//! With [`Mmlt::direct_apart`] the chains leave the paths of at most two edges to a direct pass
//! ([`super::SeparateDirect`]): their path lengths get no bootstrap weight, hence no chains.

use super::driver::Method;
use super::importance::ImportanceKind;
use super::pssmlt::{PrimaryState, mutate_primary};
use super::stream::PrimaryStream;
use crate::path::{
    MisHeuristic, Subpath, WalkSettings, connect, mis_weight, technique_subpaths,
    technique_subpaths_every_length,
};
use crate::sampler::{
    CAMERA_STREAM, KeyedStream, LIGHT_STREAM, SampleStream, TECHNIQUE_STREAM, layout,
};
use crate::scene::Scene;
use crate::spectrum::Rgb;
use mcmc_core::kernel::Observer;
use mcmc_core::primary_sample::PrimarySample;
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

    /// The strategy `(s, t)` of paths of `k` edges that technique number `u` picks, and the
    /// number of strategies it picks among.
    fn technique(k: usize, u: f64) -> (usize, usize, usize) {
        let n = Self::strategies(k);
        let s = mcmc_core::rng::uniform_index(u, n);
        (s, k + 1 - s, n)
    }

    /// Strategy `(s, t)` of `n` on subpaths walked at least that far: its MIS-weighted value
    /// over the probability of picking it, and its raster position (`None`: the camera
    /// sample's own).
    #[allow(clippy::too_many_arguments)]
    fn strategy_value(
        &self,
        scene: &Scene,
        light: &Subpath,
        cam: &Subpath,
        s: usize,
        t: usize,
        n: usize,
    ) -> Option<(Option<[f64; 2]>, Rgb)> {
        let c = connect(scene, light, cam, s, t)?;
        let wgt = mis_weight(scene, light, cam, s, t, self.heuristic, c.ends);
        Some((c.raster, c.value * (wgt * n as f64)))
    }

    /// A state of length `k` holding the numbers of key `seed` ([`KeyedStream`]) at every
    /// position a path of at most [`WalkSettings::max_edges`] edges reads, unevaluated: the
    /// bootstrap sample [`Method::independent_all`] evaluated for that length.
    fn keyed_state(&self, seed: u64, k: usize) -> PrimaryState {
        let keyed = KeyedStream::new(seed);
        let numbers = vec![
            keyed.numbers(
                CAMERA_STREAM,
                layout::camera_numbers(self.walk.max_camera_vertices()),
            ),
            keyed.numbers(
                LIGHT_STREAM,
                layout::light_numbers(self.walk.max_light_vertices()),
            ),
            keyed.numbers(TECHNIQUE_STREAM, layout::TECHNIQUE + 1),
        ];
        PrimaryState {
            // Later coordinates from a generator keyed apart from the numbers above.
            sample: PrimarySample::with_validated_values(
                numbers,
                self.kelemen.small_step,
                mcmc_core::rng::mix64(seed),
            ),
            contribution: Default::default(),
            length: k,
        }
    }

    /// Evaluate a state of length `k` (its group + 1).
    pub fn evaluate(&self, scene: &Scene, k: usize, state: &mut PrimaryState) {
        state.contribution.splats.clear();
        state.contribution.importance = 0.0;
        let mut stream = PrimaryStream::new(&mut state.sample);
        stream.start_stream(TECHNIQUE_STREAM);
        stream.seek(layout::TECHNIQUE);
        let (s, t, n) = Self::technique(k, stream.next_1d());
        let value = SUBPATHS.with(|b| {
            let (cam, light) = &mut *b.borrow_mut();
            if !technique_subpaths(scene, &mut stream, s, t, cam, light) {
                return None;
            }
            self.strategy_value(scene, light, cam, s, t, n)
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
        let mut s = self.keyed_state(seed, g + 1);
        if !self.samples_length(g + 1) {
            return (s, 0.0);
        }
        self.evaluate(scene, g + 1, &mut s);
        let w = s.contribution.importance;
        (s, w)
    }

    fn shares_bootstrap_keys(&self) -> bool {
        true
    }

    /// Every path length's sample of key `seed` from one camera and one light subpath walked to
    /// the longest length ([`technique_subpaths_every_length`]).
    fn independent_all(&self, scene: &Scene, seed: u64, out: &mut [(usize, f64)]) {
        out.fill((0, 0.0));
        let mut stream = KeyedStream::new(seed);
        stream.start_stream(TECHNIQUE_STREAM);
        stream.seek(layout::TECHNIQUE);
        let u = stream.next_1d();
        SUBPATHS.with(|b| {
            let (cam, light) = &mut *b.borrow_mut();
            let strategy = |k| self.samples_length(k).then(|| Self::technique(k, u).0);
            technique_subpaths_every_length(
                scene,
                &mut stream,
                self.walk.max_edges,
                strategy,
                cam,
                light,
                |k, s, t, cam, light| {
                    if let Some((_, v)) =
                        self.strategy_value(scene, light, cam, s, t, Self::strategies(k))
                        && !v.is_black()
                    {
                        out[k - 1].1 = self.importance.of(v);
                    }
                },
            );
        });
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
