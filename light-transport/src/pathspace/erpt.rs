//! Energy redistribution path tracing (Cline, Talbot & Egbert 2005; overview paper §5.3), the
//! unbiased variant without post-filters.
//!
//! Every pixel sample traces a path-tracing **seed**: a camera subpath through the pixel and one
//! light endpoint, giving for each length `k` the path that hits an emitter (strategy `s = 0`) and
//! the next-event path (`s = 1`, for `k ≥ 2`). Each seed path `x̄` carries the energy
//! `e(x̄) = 1 / Σ_u 1/I(C*_u(x̄))` over the sampled strategies `u` — its balance-heuristic
//! path-tracing estimate — and starts `⌊e/e_d + ξ⌋` chains. In expectation the chains start with
//! density `Σ_u p_u · e/e_d = I(f)/e_d`: already the stationary law of the perturbations (which
//! preserve `I(f)`), so every one of the `N` steps of every chain is distributed as `I(f)/e_d`,
//! and depositing `e_d/N` per step (by expected values) gives an unbiased image, whatever the
//! mutations' mixing. `e_d` is set from a deterministic pilot so that a pixel starts
//! `chains_per_seed` chains on average.
//!
//! **At most [`ErptSettings::max_chains`] chains per seed.** A seed whose energy is `r = e/e_d ≫
//! 1` quanta (a rare bright path: a caustic found by path tracing) would start `r` chains, and
//! one such seed could hold a pass for minutes. Above the cap, a seed starts `max_chains` chains
//! that each carry `e / max_chains` instead of `e_d` (deposits `e / (max_chains N)` per step).
//! The decision depends on `r` alone, so each seed still deposits `e` in expectation, from
//! chains that start at the seed: the argument above holds unchanged.
//!
//! **Direct lighting apart** ([`ErptSettings::direct_apart`]; off here, on in the command line):
//! seeds of at most [`DIRECT_EDGES`] edges (an emitter seen directly, direct illumination) start
//! no chains and deposit nothing, the chains sample longer paths only (their target is 0 on the
//! short ones, [`Mutations::min_edges`]), and the image lacks those paths: a direct-lighting pass
//! renders them beside the passes of seeds ([`crate::metropolis::SeparateDirect::around`]), as
//! for the other Metropolis methods. `e_d` stays the mean energy of all seeds, so a pixel sample
//! starts fewer chains and costs less. (Two other versions were measured and dropped: the short
//! seeds depositing their own path-traced estimate instead of chains — one sample per pixel per
//! pass, so at 10 s its direct light had 4× the RMSE on `cornell` and 2× on `door` of the chains
//! that redistribute it over their neighbourhoods; and `e_d` from the chains' seeds alone, which
//! rests on a pilot that rarely sees the bright indirect paths of scenes lit mostly directly: on
//! `ring`, whose caustic is such a path, it started 25 chains per pixel sample instead of 1.)

use super::mutations::{MutationProbabilities, Mutations};
use super::new_path::NewPath;
use super::path::FullPath;
use super::state::PathState;
use crate::integrators::{Estimator, Splat};
use crate::metropolis::{DIRECT_EDGES, ExpectedValue};
use crate::path::{Subpath, camera_subpath, connect, light_subpath};
use crate::sampler::{IndependentStream, PixelStream, SampleStream};
use crate::scene::Scene;
use crate::spectrum::Rgb;
use crate::{Error, Result};
use mcmc_core::rng::{uniform, uniform_index};
use mcmc_core::{Chain, Stats};
use std::sync::Mutex;

/// ERPT settings.
#[derive(Clone, Debug, PartialEq)]
pub struct ErptSettings {
    /// Mutations (their probabilities and offsets); default: the perturbations only.
    pub mutations: Mutations,
    /// Mutations per chain `N` (default 100, as Cline et al.).
    pub chain_length: u64,
    /// Average number of chains a pixel sample starts with [`ErptSettings::direct_apart`] off
    /// (sets `e_d`; default 1); with it on, the same `e_d` and fewer chains.
    pub chains_per_seed: f64,
    /// Pixel samples of the pilot that estimates the mean seed energy (default 4096).
    pub pilot: usize,
    /// Seeds of at most [`DIRECT_EDGES`] edges start no chains and deposit nothing: a direct
    /// pass renders those paths (default false; see the module comment).
    pub direct_apart: bool,
    /// Most chains one seed starts (default 100; see the module comment).
    pub max_chains: u64,
}

impl ErptSettings {
    /// Defaults for paths of at most `max_edges` edges.
    pub fn new(max_edges: usize) -> Self {
        Self {
            mutations: Mutations {
                probabilities: MutationProbabilities::perturbations(),
                ..Mutations::new(max_edges)
            },
            chain_length: 100,
            chains_per_seed: 1.0,
            pilot: 4096,
            direct_apart: false,
            max_chains: 100,
        }
    }

    /// The shortest path the chains sample: longer than [`DIRECT_EDGES`] edges with
    /// [`ErptSettings::direct_apart`] (when the longest paths are longer), else 1.
    pub fn chain_min_edges(&self) -> usize {
        if self.direct_apart && self.mutations.max_edges > DIRECT_EDGES {
            DIRECT_EDGES + 1
        } else {
            1
        }
    }
}

/// The ERPT estimator (splats only; one pass = one seed per pixel).
#[derive(Debug)]
pub struct Erpt {
    /// Settings.
    pub settings: ErptSettings,
    /// The energy quantum `e_d`.
    pub quantum: f64,
    /// Acceptance per kind, chains run, seeds whose chains were capped.
    stats: Mutex<(Stats, u64, u64)>,
    walks: Mutex<crate::manifold::WalkStats>,
}

const PILOT_STREAM: u64 = 0xE4F7;

impl Erpt {
    /// Set up ERPT on `scene`: validates the settings and runs the pilot for `e_d`.
    pub fn new(scene: &Scene, mut settings: ErptSettings) -> Result<Self> {
        settings.mutations.min_edges = settings.chain_min_edges();
        settings.mutations.validate()?;
        let manifold = ["manifold-light", "manifold-eye"]
            .iter()
            .map(|n| settings.mutations.probabilities.probability(n))
            .sum::<f64>();
        if let Some(target) = settings.mutations.manifold.target_acceptance
            && manifold > 0.0
        {
            // λ tuned on chains resampled from independent paths, frozen before rendering.
            let t = super::lambda_tuning::tune_lambda(scene, &settings.mutations, target, 0)?;
            settings.mutations.manifold.lambda = t.lambda;
            settings.mutations.manifold.tuning = Some(t);
        }
        let specular = settings.mutations.manifold.specular;
        if manifold > 0.0 && specular.glossy && specular.normal_change.is_none() {
            // Δθ of ψ by a pilot on paths resampled from independent ones, before rendering.
            let states = super::lambda_tuning::resampled_states(scene, &settings.mutations, 0)?;
            let p = super::normal_change::measure_normal_change(
                scene,
                &settings.mutations,
                &states,
                0,
            )?;
            if let Some(p) = p {
                settings.mutations.manifold.specular.normal_change = Some(p.delta_theta);
                settings.mutations.manifold.pilot = Some(p);
            }
        }
        let m = &settings.mutations;
        if settings.chain_length == 0 || settings.pilot == 0 || settings.max_chains == 0 {
            return Err(Error::InvalidParameter {
                name: "erpt".into(),
                reason: "need max depth ≥ 1, chain length ≥ 1, pilot ≥ 1 and at least one chain per seed".into(),
            });
        }
        if !(settings.chains_per_seed > 0.0 && settings.chains_per_seed.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "erpt chains per seed".into(),
                reason: format!("must be positive, got {}", settings.chains_per_seed),
            });
        }
        let npix = scene.camera.width * scene.camera.height;
        let mut total = 0.0;
        let mut seeds = Vec::new();
        for i in 0..settings.pilot {
            let mut stream =
                IndependentStream::new(mcmc_core::rng::substream(0, PILOT_STREAM, i as u64));
            let pixel = uniform_index(uniform(&mut stream.rng), npix);
            seed_paths(scene, m, pixel, &mut stream, &mut seeds);
            total += seeds.iter().map(|(_, e)| e).sum::<f64>();
        }
        let mean = total / settings.pilot as f64;
        if !(mean > 0.0 && mean.is_finite()) {
            return Err(Error::InvalidScene(format!(
                "no light reached the camera in {} path-traced pilot samples: nothing to render",
                settings.pilot
            )));
        }
        Ok(Self {
            quantum: mean / settings.chains_per_seed,
            settings,
            stats: Mutex::new((Stats::default(), 0, 0)),
            walks: Mutex::new(Default::default()),
        })
    }

    /// ERPT's statistics for people: energy quantum, chains, acceptance per mutation kind
    /// (`pixels`: of the image).
    pub fn summary(&self, pixels: f64) -> Vec<String> {
        let (stats, chains) = self.statistics();
        let capped = self.capped_seeds();
        let mut out = vec![format!(
            "erpt       energy quantum e_d = {:.4e}, {} chains of {} mutations ({:.2} chains per pixel){}",
            self.quantum,
            chains,
            self.settings.chain_length,
            chains as f64 / pixels,
            if capped > 0 {
                format!(
                    "; {capped} seeds of more than {} quanta started {} chains each",
                    self.settings.max_chains, self.settings.max_chains
                )
            } else {
                String::new()
            }
        )];
        out.extend(
            stats
                .table(&Mutations::kinds())
                .to_string()
                .lines()
                .map(str::to_string),
        );
        if let Some(t) = &self.settings.mutations.manifold.tuning {
            out.push(format!("lambda     {t}"));
        }
        if let Some(p) = &self.settings.mutations.manifold.pilot {
            out.push(format!("glossy     {p}"));
        }
        let walks = self.walk_stats();
        if walks.walks > 0 {
            out.push(format!("walks      {}", walks.summary()));
        }
        out
    }

    /// The manifold walks of the chains so far (the manifold perturbation's).
    pub fn walk_stats(&self) -> crate::manifold::WalkStats {
        self.walks.lock().map_or_else(|e| *e.into_inner(), |g| *g)
    }

    /// Acceptance per mutation kind and the number of chains run so far.
    pub fn statistics(&self) -> (Stats, u64) {
        let g = self.stats.lock().unwrap_or_else(|e| e.into_inner());
        (g.0.clone(), g.1)
    }

    /// Seeds so far whose energy exceeded [`ErptSettings::max_chains`] quanta.
    pub fn capped_seeds(&self) -> u64 {
        self.stats.lock().unwrap_or_else(|e| e.into_inner()).2
    }
}

/// The seed paths of one path-tracing sample in `pixel`, with their energies.
pub fn seed_paths(
    scene: &Scene,
    m: &Mutations,
    pixel: usize,
    stream: &mut impl SampleStream,
    out: &mut Vec<(PathState, f64)>,
) {
    out.clear();
    let (mut cam, mut light) = (Subpath::new(), Subpath::new());
    camera_subpath(scene, stream, m.max_edges + 1, Some(pixel), &mut cam);
    light_subpath(scene, stream, 1, &mut light);
    let mut path = FullPath::default();
    for t in 2..cam.len() + 1 {
        for s in 0..=1usize {
            let k = s + t - 1;
            if k > m.max_edges || t > cam.len() || s > light.len() {
                continue;
            }
            if s == 1 && connect(scene, &light, &cam, 1, t).is_none() {
                continue;
            }
            if path.set_from_subpaths(scene, &light, &cam, s, t).is_none() {
                continue;
            }
            let mut state = PathState {
                path: path.clone(),
                ..Default::default()
            };
            if !state.evaluate(scene, m.importance, 1.0) {
                continue;
            }
            // The sampled strategies: s = 0 always, s = 1 for paths of two or more edges.
            let u_max = if k >= 2 { 2 } else { 1 };
            let inv = state.inverse_sum(0, u_max);
            if inv > 0.0 && state.strategy_importance(s) > 0.0 {
                out.push((state, 1.0 / inv));
            }
        }
    }
}

impl Estimator for Erpt {
    fn sample(
        &self,
        scene: &Scene,
        pixel: usize,
        stream: &mut PixelStream,
        splats: &mut Vec<Splat>,
    ) -> Rgb {
        let m = &self.settings.mutations;
        let n = self.settings.chain_length;
        let mut seeds = Vec::new();
        seed_paths(scene, m, pixel, stream, &mut seeds);
        if seeds.is_empty() {
            return Rgb::BLACK;
        }
        // Validated in `new`: building the mixture cannot fail.
        let Ok(proposal) =
            m.proposal_recording(scene, NewPath::uniform(m.max_edges), Some(&self.walks))
        else {
            return Rgb::BLACK;
        };
        let mut rng = stream.chain_rng();
        let mut stats = Stats::default();
        let (mut chains, mut capped) = (0, 0);
        let max = self.settings.max_chains;
        let mut rec = ExpectedValue {
            recorder: splats,
            b: self.quantum / n as f64,
            large_steps: None,
            tally: None,
        };
        for (state, e) in seeds {
            if state.path.edges() < m.min_edges {
                continue; // the direct pass's path
            }
            let quanta = e / self.quantum;
            let count = if quanta > max as f64 {
                // Capped: `max` chains carry the seed's energy between them.
                capped += 1;
                rec.b = e / (max * n) as f64;
                max
            } else {
                rec.b = self.quantum / n as f64;
                (quanta + uniform(&mut rng)).floor() as u64
            };
            for _ in 0..count {
                let Ok(mut chain) = Chain::with_density(state.clone(), 0.0) else {
                    continue;
                };
                m.run(&proposal, &mut chain, n, &mut rng, &mut rec);
                stats.merge(&chain.stats);
                chains += 1;
            }
        }
        if chains > 0
            && let Ok(mut g) = self.stats.lock()
        {
            g.0.merge(&stats);
            g.1 += chains;
            g.2 += capped;
        }
        Rgb::BLACK
    }

    fn has_pixel_estimate(&self) -> bool {
        false
    }

    fn splats(&self) -> bool {
        true
    }
}
