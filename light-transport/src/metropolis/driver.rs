//! The driver shared by every Metropolis integrator: bootstrap, unbiased seeding by resampling,
//! chains in parallel, expected-value recording, budgets, statistics.
//!
//! Determinism: bootstrap sample `i` of group `g` and chain `c` draw from their own streams of the
//! master seed; chains are processed in fixed groups whose splats are applied to the film in group
//! order after every round, so the image is identical for any thread count.

use crate::film::Film;
use crate::scene::Scene;
use crate::spectrum::Rgb;
use crate::{Error, Result};
use mcmc_core::kernel::Observer;
use mcmc_core::population::systematic_resample;
use mcmc_core::rng::substream;
use mcmc_core::{Chain, ChainRng, Stats};
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// What a state contributes: splats (raster position, colour) and the scalar importance `I` the
/// chain samples (a function of the splats, see [`super::ImportanceKind`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Contribution {
    /// Raster positions and colours.
    pub splats: Vec<([f64; 2], Rgb)>,
    /// The scalar importance (≥ 0).
    pub importance: f64,
}

/// A chain state that knows its contribution.
pub trait Recordable {
    /// The contribution of the state as last evaluated.
    fn contribution(&self) -> &Contribution;
}

/// A Metropolis method the driver can run.
pub trait Method: Sync {
    /// The chain state.
    type State: Clone + Send + Recordable;
    /// Number of independent groups (e.g. path lengths); chains never leave their group.
    fn groups(&self) -> usize;
    /// An independent sample of group `g` from stream key `seed`, evaluated. Must be a deterministic
    /// function of `(g, seed)`: the driver replays seeds this way and checks the importance.
    fn independent(&self, scene: &Scene, g: usize, seed: u64) -> Self::State;
    /// Run `n` mutations of `chain`, reporting every proposal to `observer`.
    fn mutate<O: Observer<Self::State>>(
        &self,
        scene: &Scene,
        chain: &mut Chain<Self::State>,
        n: u64,
        rng: &mut ChainRng,
        observer: &mut O,
    );
    /// Names of the move kinds (for statistics).
    fn kinds(&self) -> Vec<String>;
    /// Told the per-group normalisations `b_g` once the bootstrap is done, before any chain runs
    /// (e.g. to choose path lengths in proportion to their energy).
    fn bootstrap_done(&self, _group_normalisation: &[f64]) {}
    /// Mutations per chain between two calls of [`Method::exchange`]; `None` (the default): the
    /// chains never interact.
    fn exchange_every(&self) -> Option<u64> {
        None
    }
    /// Moves between chains (e.g. replica exchange), called between sub-rounds of
    /// [`Method::exchange_every`] mutations. They must leave the product of the chains'
    /// stationary laws invariant and may depend on `rng` only for their randomness (determinism).
    /// The driver does not record them on the film: each chain records its own mutations, so the
    /// number of exchanges a chain takes part in does not weigh its samples.
    fn exchange(&self, _scene: &Scene, _chains: &mut [Chain<Self::State>], _rng: &mut ChainRng) {}
}

/// How long to run the chains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// Total mutations = this × number of pixels.
    MutationsPerPixel(f64),
    /// Wall-clock time for the chains (whole rounds; the bootstrap is extra).
    Time(Duration),
}

/// How chains are seeded from the bootstrap population.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Seeding {
    /// Systematic resampling in proportion to the importance: no start-up bias.
    #[default]
    Resample,
    /// Uniformly among the samples that carry light — deliberately biased (chains start away from
    /// their stationary law), kept to show that the unbiasedness test can fail.
    UniformBiased,
}

/// Driver settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MetropolisSettings {
    /// Number of chains.
    pub chains: usize,
    /// Bootstrap samples per group.
    pub bootstrap: usize,
    /// Chain budget.
    pub budget: Budget,
    /// Master seed.
    pub seed: u64,
    /// Seeding rule.
    pub seeding: Seeding,
}

impl Default for MetropolisSettings {
    fn default() -> Self {
        Self {
            chains: 1000,
            bootstrap: 100_000,
            budget: Budget::MutationsPerPixel(16.0),
            seed: 1,
            seeding: Seeding::Resample,
        }
    }
}

/// What happened.
#[derive(Clone, Debug, Default)]
pub struct MetropolisStats {
    /// Normalisation `b = E[I]` (sum over groups).
    pub normalisation: f64,
    /// Per group.
    pub group_normalisation: Vec<f64>,
    /// Chains per group.
    pub group_chains: Vec<usize>,
    /// Bootstrap samples with positive importance.
    pub bootstrap_nonzero: usize,
    /// Bootstrap samples discarded as non-finite.
    pub bootstrap_discarded: usize,
    /// Mutations made.
    pub mutations: u64,
    /// Acceptance per move kind, all chains.
    pub stats: Stats,
    /// Move kind names.
    pub kinds: Vec<String>,
    /// Time of the bootstrap, the seeding, the chains.
    pub bootstrap_time: Duration,
    /// Seeding time.
    pub seed_time: Duration,
    /// Chain time.
    pub chain_time: Duration,
    /// Rays traced.
    pub rays: u64,
}

/// A splat: raster position and colour.
type Splat = ([f64; 2], Rgb);

const BOOTSTRAP: u64 = 0xB007;
const CHAINS: u64 = 0xC4A1;
const SPLIT: usize = 16;
const EXCHANGE: u64 = 0xE8C4;

fn key(seed: u64, g: usize, i: usize) -> u64 {
    // Distinct stream keys for every (group, index) of the bootstrap.
    let mut z = seed
        ^ (g as u64).wrapping_mul(0xD1B5_4A32_D192_ED03)
        ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ BOOTSTRAP;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The expected-value recorder: every proposal deposits `a` times the candidate's splats and
/// `1 − a` times the current state's, each scaled by `b / I` (so a chain whose states have density
/// `I / b` deposits the image). Energy redistribution uses it with `b` = its energy quantum.
pub struct SplatRecorder<'a> {
    /// Where splats go.
    pub splats: &'a mut Vec<([f64; 2], Rgb)>,
    /// The normalisation.
    pub b: f64,
}

impl SplatRecorder<'_> {
    /// Deposit `w` times the state's splats, scaled by `b / I`.
    #[inline]
    pub fn record<S: Recordable>(&mut self, s: &S, w: f64) {
        let c = s.contribution();
        if w <= 0.0 || !(c.importance > 0.0) || !c.importance.is_finite() {
            return;
        }
        let scale = w * self.b / c.importance;
        for &(r, v) in &c.splats {
            self.splats.push((r, v * scale));
        }
    }
}

impl<S: Recordable> Observer<S> for SplatRecorder<'_> {
    #[inline]
    fn observe(&mut self, current: &S, proposed: &S, a: f64, _kind: usize) {
        self.record(current, 1.0 - a);
        self.record(proposed, a);
    }
}

/// Run `method` on `scene`. `progress(film, mutations done, elapsed)` is called after every round
/// and may stop the chains by returning `false`.
pub fn run<M: Method>(
    scene: &Scene,
    method: &M,
    settings: &MetropolisSettings,
    mut progress: impl FnMut(&Film, u64, Duration) -> bool,
) -> Result<(Film, MetropolisStats)> {
    if settings.chains == 0 || settings.bootstrap == 0 {
        return Err(Error::InvalidParameter {
            name: "chains/bootstrap".into(),
            reason: "need at least one chain and one bootstrap sample".into(),
        });
    }
    let (w, h) = (scene.camera.width, scene.camera.height);
    let pixels = (w * h) as f64;
    let groups = method.groups().max(1);
    let mut stats = MetropolisStats {
        kinds: method.kinds(),
        ..Default::default()
    };
    crate::accel::take_ray_count();
    // 1. Bootstrap.
    let t = Instant::now();
    let n = groups * settings.bootstrap;
    let mut weights: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|j| {
            let (g, i) = (j / settings.bootstrap, j % settings.bootstrap);
            method
                .independent(scene, g, key(settings.seed, g, i))
                .contribution()
                .importance
        })
        .collect();
    for wgt in &mut weights {
        if !wgt.is_finite() || *wgt < 0.0 {
            *wgt = 0.0;
            stats.bootstrap_discarded += 1;
        }
    }
    stats.bootstrap_nonzero = weights.iter().filter(|&&v| v > 0.0).count();
    stats.group_normalisation = (0..groups)
        .map(|g| {
            weights[g * settings.bootstrap..(g + 1) * settings.bootstrap]
                .iter()
                .sum::<f64>()
                / settings.bootstrap as f64
        })
        .collect();
    stats.normalisation = stats.group_normalisation.iter().sum();
    stats.bootstrap_time = t.elapsed();
    method.bootstrap_done(&stats.group_normalisation);
    if !(stats.normalisation > 0.0) {
        return Err(Error::InvalidScene(format!(
            "no light reached the camera in {n} bootstrap paths: nothing to render (raise --bootstrap, or check the lights)"
        )));
    }
    // 2. Seeding by systematic resampling, with the replay check.
    let t = Instant::now();
    let mut rng = substream(settings.seed, CHAINS, u64::MAX);
    let seed_weights: Vec<f64> = match settings.seeding {
        Seeding::Resample => weights.clone(),
        Seeding::UniformBiased => weights
            .iter()
            .map(|&w| if w > 0.0 { 1.0 } else { 0.0 })
            .collect(),
    };
    let picks = systematic_resample(&seed_weights, settings.chains, &mut rng)
        .map_err(|e| Error::InvalidScene(e.to_string()))?;
    stats.group_chains = vec![0; groups];
    let seeded: Vec<Result<Chain<M::State>>> = picks
        .par_iter()
        .map(|&j| {
            let (g, i) = (j / settings.bootstrap, j % settings.bootstrap);
            let s = method.independent(scene, g, key(settings.seed, g, i));
            let imp = s.contribution().importance;
            if (imp - weights[j]).abs() > 1e-9 * weights[j].abs().max(1e-300) {
                return Err(Error::InvalidScene(format!("replay of bootstrap path {i} (group {g}) gave importance {imp}, the bootstrap saw {}: the sampler is not a deterministic function of its numbers", weights[j])));
            }
            Chain::with_density(s, imp.ln()).map_err(|e| Error::InvalidScene(e.to_string()))
        })
        .collect();
    let mut chains = Vec::with_capacity(picks.len());
    for (c, &j) in seeded.into_iter().zip(&picks) {
        chains.push(c?);
        stats.group_chains[j / settings.bootstrap] += 1;
    }
    let mut rngs: Vec<ChainRng> = (0..chains.len())
        .map(|c| substream(settings.seed, CHAINS, c as u64))
        .collect();
    stats.seed_time = t.elapsed();
    // 3. Chains in rounds.
    let t = Instant::now();
    let mut film = Film::new(w, h);
    let total = match settings.budget {
        Budget::MutationsPerPixel(m) => Some((m * pixels).max(1.0) as u64),
        Budget::Time(_) => None,
    };
    let nchains = chains.len() as u64;
    let mut per_round: u64 = match total {
        Some(t) => (t / nchains / 8).clamp(1, 100_000),
        None => 64,
    };
    let split = SPLIT.min(chains.len());
    let size = chains.len().div_ceil(split);
    let b = stats.normalisation;
    let exchange_every = method.exchange_every();
    let mut exchange_rng = substream(settings.seed, EXCHANGE, 0);
    loop {
        let k = match total {
            Some(t) => per_round
                .min((t - stats.mutations).div_ceil(nchains))
                .max(1),
            None => per_round,
        };
        let round_start = Instant::now();
        let mut outputs: Vec<(Vec<Splat>, u64)> =
            vec![Default::default(); chains.len().div_ceil(size)];
        let mut left = k;
        while left > 0 {
            let step = exchange_every.map_or(left, |e| e.clamp(1, left));
            chains
                .par_chunks_mut(size)
                .zip(rngs.par_chunks_mut(size))
                .zip(outputs.par_iter_mut())
                .for_each(|((cs, rs), (splats, rays))| {
                    crate::accel::take_ray_count();
                    let mut rec = SplatRecorder { splats, b };
                    for (chain, rng) in cs.iter_mut().zip(rs.iter_mut()) {
                        method.mutate(scene, chain, step, rng, &mut rec);
                    }
                    *rays += crate::accel::take_ray_count();
                });
            left -= step;
            if exchange_every.is_some() {
                method.exchange(scene, &mut chains, &mut exchange_rng);
            }
        }
        for (splats, rays) in outputs {
            for (r, v) in splats {
                film.add_splat(r, v);
            }
            stats.rays += rays;
        }
        stats.mutations += k * nchains;
        film.splat_scale = stats.mutations as f64 / pixels;
        let elapsed = t.elapsed();
        let go_on = progress(&film, stats.mutations, elapsed);
        let done = match (settings.budget, total) {
            (_, Some(t)) => stats.mutations >= t,
            (Budget::Time(limit), None) => elapsed >= limit,
            _ => true,
        };
        if done || !go_on {
            break;
        }
        if total.is_none() {
            // Aim at rounds of about half a second.
            let secs = round_start.elapsed().as_secs_f64().max(1e-3);
            per_round = ((per_round as f64) * (0.5 / secs)).clamp(16.0, 1e6) as u64;
        }
    }
    stats.chain_time = t.elapsed();
    for c in &chains {
        stats.stats.merge(&c.stats);
    }
    Ok((film, stats))
}
