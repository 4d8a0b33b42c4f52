//! The driver shared by every Metropolis integrator: bootstrap, unbiased seeding by resampling,
//! chains in parallel, expected-value recording, budgets, statistics.
//!
//! Determinism: bootstrap sample `i` of group `g` and chain `c` draw from their own streams of the
//! master seed; chains are processed in fixed groups whose splats are applied to the film in group
//! order after every round, so the image is identical for any thread count.
//!
//! A method whose groups are path lengths may share one key between the samples `i` of all its
//! groups ([`Method::shares_bootstrap_keys`]: MMLT, path-space MLT, charted MLT): its sample of
//! each length then reads the first vertices of one pair of subpaths walked to the longest
//! length, so the bootstrap walks once per index instead of once per index and length. Within a
//! group the samples stay independent and distributed as before, so each `b_g` and each group's
//! seeding is as unbiased as before; across groups they are correlated, which adds to the
//! variance of the sum `b` (measured in docs/performance.md).

use super::record::{
    BootstrapSample, ExpectedValue, LargeStepMis, NormalisationTally, Recordable, Sink,
};
use crate::budget::Budget;
use crate::film::Film;
use crate::scene::Scene;
use crate::{Error, Result};
use mcmc_core::kernel::Observer;
use mcmc_core::population::systematic_resample;
use mcmc_core::rng::substream;
use mcmc_core::{Chain, ChainRng, Stats};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// A Metropolis method the driver can run.
pub trait Method: Sync {
    /// The chain state.
    type State: Clone + Send + Recordable;
    /// Number of independent groups (e.g. path lengths); chains never leave their group.
    fn groups(&self) -> usize;
    /// An independent sample of group `g` from stream key `seed`, evaluated, with its importance
    /// weight `I / q` (0 when it carries nothing). Must be a deterministic function of
    /// `(g, seed)`: the driver replays seeds this way and checks the weight.
    fn independent(&self, scene: &Scene, g: usize, seed: u64) -> (Self::State, f64);
    /// The weight of [`Method::independent`]`(scene, g, seed)` alone, for the bootstrap, which
    /// keeps no state: a method may compute it in storage it reuses (it must be the same number).
    fn independent_weight(&self, scene: &Scene, g: usize, seed: u64) -> f64 {
        self.independent(scene, g, seed).1
    }
    /// `ln π(state)`: the log density of the chain's target at a state, as the kernel of
    /// [`Method::mutate`] evaluates it (chains start with it).
    fn ln_density(&self, scene: &Scene, state: &Self::State) -> f64;
    /// Run `n` mutations of `chain`, reporting every proposal to `observer`.
    fn mutate<O: Observer<Self::State>>(
        &self,
        scene: &Scene,
        chain: &mut Chain<Self::State>,
        n: u64,
        rng: &mut ChainRng,
        observer: &mut O,
    );
    /// Run `n` mutations of each of `chains` (with its own `rngs[c]`); the driver calls this for
    /// every group of chains it runs in one thread, so a method can build what its kernels share
    /// once per group instead of once per chain. The default calls [`Method::mutate`] per chain.
    fn mutate_chunk<O: Observer<Self::State>>(
        &self,
        scene: &Scene,
        chains: &mut [Chain<Self::State>],
        rngs: &mut [ChainRng],
        n: u64,
        observer: &mut O,
    ) {
        for (chain, rng) in chains.iter_mut().zip(rngs.iter_mut()) {
            self.mutate(scene, chain, n, rng, observer);
        }
    }
    /// Names of the move kinds (for statistics).
    fn kinds(&self) -> Vec<String>;
    /// Called once with the seeded chains before any is run or recorded (e.g. to tune a kernel's
    /// parameter on copies of them and freeze it: the recorded chains then run an ordinary fixed
    /// kernel from their unbiased seeds). `seed` is the render's master seed. Nothing by default.
    fn warm_up(&self, _scene: &Scene, _chains: &[Chain<Self::State>], _seed: u64) -> Result<()> {
        Ok(())
    }
    /// Called before every round of mutations (`round` counts from 0; `seed` is the render's
    /// master seed), e.g. to rebuild a structure the chains share. Nothing by default.
    fn new_round(&self, _scene: &Scene, _round: u64, _seed: u64) -> Result<()> {
        Ok(())
    }
    /// Lines the method adds to the render's summary (e.g. statistics of its moves beyond
    /// acceptance); none by default.
    fn details(&self) -> Vec<String> {
        Vec::new()
    }
    /// The move kind that proposes, with the returned probability, an independent sample of unit
    /// density over its group's space (Kelemen's large step in primary sample space), if the
    /// method wants those samples counted as an estimate of the image of their own, combined with
    /// the chain's by the balance heuristic ([`super::record::LargeStepMis`]). `None` by default:
    /// every proposal is recorded by its expected value alone.
    fn large_steps(&self) -> Option<(usize, f64)> {
        None
    }
    /// `d = b q` per independent group for [`Method::large_steps`] ([`LargeStepMis::density`]):
    /// the normalisation times the density of the independent proposal in the measure in which
    /// the importance `I` is the state's density, given the bootstrap's normalisation per group
    /// and in all (`b`). By default a large step's in primary space, of unit density within its
    /// group: `b_g`.
    fn large_step_density(&self, group_normalisation: &[f64], b: f64) -> Vec<f64> {
        let _ = b;
        group_normalisation.to_vec()
    }
    /// The move kind whose candidates are drawn as bootstrap samples are (Kelemen's large step;
    /// path-space MLT's new path), whether or not they are also counted by
    /// [`Method::large_steps`]: the driver adds their bootstrap weight
    /// ([`Recordable::independent_weight`]) to their group's bootstrap sums to refine its
    /// normalisation ([`MetropolisSettings::refine_normalisation`]). By default the kind of
    /// [`Method::large_steps`].
    fn independent_proposals(&self) -> Option<usize> {
        self.large_steps().map(|(kind, _)| kind)
    }
    /// The number of strata of group `g`'s bootstrap: a method whose independent sample first
    /// picks one of `n` strata uniformly (charted MLT: a technique chart) and whose chains draw
    /// samples of one stratum at a time (a large step in the chain's chart) has its
    /// normalisation refined stratum by stratum ([`super::record::NormalisationTally`]). 1 by
    /// default.
    fn strata(&self, _g: usize) -> usize {
        1
    }
    /// The stratum [`Method::independent`]`(scene, g, seed)` falls in (of [`Method::strata`])
    /// and its weight, as [`Method::independent_weight`] computes it; the driver asks for it
    /// when group `g` has more than one stratum. By default stratum 0.
    fn independent_in_stratum(&self, scene: &Scene, g: usize, seed: u64) -> (usize, f64) {
        (0, self.independent_weight(scene, g, seed))
    }
    /// Whether the bootstrap draws sample `i` of every group from one stream key, evaluating
    /// them together with [`Method::independent_all`] (one pair of walks serving every path
    /// length, [`crate::sampler::KeyedStream`]). Each group's samples stay independent of each
    /// other and distributed as before; samples of different groups with the same index are
    /// then correlated, which leaves every group's normalisation and seeding unbiased. `false`
    /// by default: every `(group, index)` has a key of its own.
    fn shares_bootstrap_keys(&self) -> bool {
        false
    }
    /// The stratum and weight of [`Method::independent`]`(scene, g, seed)` for every group `g`
    /// at once (`out[g]`, `out.len()` = [`Method::groups`]), bit for bit what
    /// [`Method::independent_in_stratum`] gives group by group (the driver's replay check holds
    /// a method to it). By default group by group.
    fn independent_all(&self, scene: &Scene, seed: u64, out: &mut [(usize, f64)]) {
        for (g, o) in out.iter_mut().enumerate() {
            *o = self.independent_in_stratum(scene, g, seed);
        }
    }
    /// Whether the chains move between groups (path-space MLT's change path length), so that
    /// the groups matter to the bootstrap only: the chains' deposits (all in group 0,
    /// [`Recordable::group`]) are then rescaled by the refined total `b` over the bootstrap's.
    /// `false` by default: chains stay in their group and each group's deposits are rescaled
    /// by its own `b_g`.
    fn chains_span_groups(&self) -> bool {
        false
    }
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
    /// `groups[c]` is the group of chain `c` (fixed for the whole run). The driver does not record
    /// exchanges: each chain records its own mutations, so the number of exchanges a chain takes
    /// part in does not weigh its samples.
    fn exchange(
        &self,
        _scene: &Scene,
        _chains: &mut [Chain<Self::State>],
        _groups: &[usize],
        _rng: &mut ChainRng,
    ) {
    }
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
    /// Chain budget (samples per pixel: mutations per pixel).
    pub budget: Budget,
    /// Master seed.
    pub seed: u64,
    /// Seeding rule.
    pub seeding: Seeding,
    /// Refine each group's normalisation `b_g` with the independent samples the chains draw
    /// ([`Method::independent_proposals`]) as they run, so the image's scale is no longer fixed by
    /// the bootstrap alone: its error then falls with the render's length.
    pub refine_normalisation: bool,
}

impl Default for MetropolisSettings {
    fn default() -> Self {
        Self {
            chains: 1000,
            bootstrap: 100_000,
            budget: Budget::SamplesPerPixel(16.0),
            seed: 1,
            seeding: Seeding::Resample,
            refine_normalisation: true,
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
    /// Per group, refined by the chains' independent samples
    /// ([`MetropolisSettings::refine_normalisation`]; empty when not refined): the normalisation
    /// the image was made with.
    pub refined_normalisation: Vec<f64>,
    /// The chains' independent samples that refined it.
    pub independent_samples: u64,
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
    /// Whether the render stopped early on request (an interrupt): the film holds the mutations
    /// actually made.
    pub interrupted: bool,
}

impl MetropolisStats {
    /// The statistics for people, one line each: bootstrap, chains per path length, chain
    /// throughput, and the acceptance table per move kind (`pixels`: of the image).
    pub fn summary(&self, pixels: f64) -> Vec<String> {
        let mut out = vec![format!(
            "bootstrap  {:.2} s, normalisation b = {:.5e} ({} of the samples carry light{}), seeding {:.2} s",
            self.bootstrap_time.as_secs_f64(),
            self.normalisation,
            self.bootstrap_nonzero,
            if self.bootstrap_discarded > 0 {
                format!(", {} non-finite discarded", self.bootstrap_discarded)
            } else {
                String::new()
            },
            self.seed_time.as_secs_f64()
        )];
        if !self.refined_normalisation.is_empty() {
            let refined: f64 = self.refined_normalisation.iter().sum();
            out.push(format!(
                "refined    b = {refined:.5e} ({:+.2}%) with the chains' {} independent samples",
                100.0 * (refined / self.normalisation - 1.0),
                self.independent_samples
            ));
        }
        if self.group_chains.len() > 1 {
            let groups: Vec<String> = self
                .group_chains
                .iter()
                .enumerate()
                .filter(|(_, c)| **c > 0)
                .map(|(g, c)| format!("k={}:{c}", g + 1))
                .collect();
            out.push(format!("chains     per path length {}", groups.join(" ")));
        }
        let secs = self.chain_time.as_secs_f64().max(1e-9);
        out.push(format!(
            "chains     {:.2} s, {} mutations ({:.1} per pixel), {:.2} M mutations/s, {:.2} M rays/s",
            secs,
            self.mutations,
            self.mutations as f64 / pixels,
            self.mutations as f64 / secs / 1e6,
            self.rays as f64 / secs / 1e6
        ));
        out.extend(
            self.stats
                .table(&self.kinds)
                .to_string()
                .lines()
                .map(str::to_string),
        );
        out
    }
}

const BOOTSTRAP: u64 = 0xB007;
const CHAINS: u64 = 0xC4A1;
/// Most groups of chains a slice is cut into, each a unit of parallel work with its own deposit
/// buffer. Chains of one group (one MMLT path length, say) sit next to each other and cost alike,
/// so a coarse cut leaves a thread waiting at the end of every slice on the group of the longest
/// paths: 16 groups scaled MMLT on `cornell` 1.73–1.78× from one thread to two, 64 groups 1.93×.
const SPLIT: usize = 64;
/// Most slices a round is cut into (the granularity of an interrupt).
const SLICES: u64 = 8;
/// Most mutations (over all chains) a slice makes. A slice's deposits are held in per-chunk
/// buffers until it ends and enter the sink while the next slice runs, so two slices' deposits
/// are held at a time and this bounds that memory: PSSMLT records every strategy of both states
/// at every mutation, and rounds of an eighth of a render once held 0.5 GB of splats at
/// 1920×1080 (docs/performance.md).
const SLICE_MUTATIONS: u64 = 1 << 16;
const EXCHANGE: u64 = 0xE8C4;

fn key(seed: u64, g: usize, i: usize) -> u64 {
    // Distinct stream keys for every (group, index) of the bootstrap.
    mcmc_core::rng::mix64(
        seed ^ (g as u64).wrapping_mul(0xD1B5_4A32_D192_ED03)
            ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ BOOTSTRAP,
    )
}

/// The normalisation of every group from the bootstrap and the chains' independent samples of
/// `tally` (which holds both); a group with a stratum the bootstrap never drew keeps the
/// bootstrap's value.
fn refine(stats: &mut MetropolisStats, tally: &NormalisationTally, bootstrap: u64) {
    stats.refined_normalisation = (0..stats.group_normalisation.len())
        .map(|g| {
            tally
                .normalisation(g)
                .unwrap_or(stats.group_normalisation[g])
        })
        .collect();
    stats.independent_samples = tally.samples() - bootstrap * tally.count.len() as u64;
}

/// Run `method` on `scene` into a film. `progress(film, mutations done, elapsed)` is called
/// after every round and may stop the chains by returning `false`.
pub fn run<M: Method>(
    scene: &Scene,
    method: &M,
    settings: &MetropolisSettings,
    progress: impl FnMut(&Film, u64, Duration) -> bool,
) -> Result<(Film, MetropolisStats)> {
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    let stats = run_with(scene, method, settings, &mut film, None, progress)?;
    Ok((film, stats))
}

/// Run `method` on `scene`, recording into `sink`. `progress(sink, mutations done, elapsed)` is
/// called after every round and may stop the chains by returning `false`; `stop`, when set (by a
/// signal handler, say), stops them at the next slice of a round, every chain having made the
/// same number of mutations, so the sink holds an unbiased estimate of what was done.
pub fn run_with<M: Method, K: Sink<M::State>>(
    scene: &Scene,
    method: &M,
    settings: &MetropolisSettings,
    sink: &mut K,
    stop: Option<&AtomicBool>,
    mut progress: impl FnMut(&K, u64, Duration) -> bool,
) -> Result<MetropolisStats> {
    if settings.chains == 0 || settings.bootstrap == 0 {
        return Err(Error::InvalidParameter {
            name: "chains/bootstrap".into(),
            reason: "need at least one chain and one bootstrap sample".into(),
        });
    }
    settings.budget.validate()?;
    let stopped = || stop.is_some_and(|s| s.load(Ordering::Relaxed));
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
    let strata: Vec<usize> = (0..groups).map(|g| method.strata(g).max(1)).collect();
    let shared = method.shares_bootstrap_keys();
    // The stream key of bootstrap sample `i` of group `g` (replayed by the seeding below).
    let sample_key = |g: usize, i: usize| key(settings.seed, if shared { 0 } else { g }, i);
    let bootstrap = settings.bootstrap;
    // Where sample `i` of group `g` sits in the bootstrap's vectors, and back: index by index
    // when the groups share keys (every group's sample `i` is computed at once), else group by
    // group.
    let locate = |j: usize| {
        if shared {
            (j % groups, j / groups)
        } else {
            (j / bootstrap, j % bootstrap)
        }
    };
    // Each sample's stratum is kept only for a method with strata (a vector as long as the
    // bootstrap's otherwise).
    let with_strata = strata.iter().any(|&n| n > 1);
    let (sample_strata, mut weights): (Vec<usize>, Vec<f64>) = if shared {
        let mut weights = vec![0.0; n];
        let mut sample_strata = vec![0; if with_strata { n } else { 0 }];
        let all = || vec![(0, 0.0); groups];
        let sample = |i: usize, out: &mut Vec<(usize, f64)>| {
            method.independent_all(scene, sample_key(0, i), out);
        };
        if with_strata {
            weights
                .par_chunks_mut(groups)
                .zip(sample_strata.par_chunks_mut(groups))
                .enumerate()
                .for_each_init(all, |out, (i, (w, st))| {
                    sample(i, out);
                    for ((w, st), &(stratum, weight)) in w.iter_mut().zip(st).zip(out.iter()) {
                        (*w, *st) = (weight, stratum);
                    }
                });
        } else {
            weights
                .par_chunks_mut(groups)
                .enumerate()
                .for_each_init(all, |out, (i, w)| {
                    sample(i, out);
                    for (w, &(_, weight)) in w.iter_mut().zip(out.iter()) {
                        *w = weight;
                    }
                });
        }
        (sample_strata, weights)
    } else {
        let sample = |j: usize| {
            let (g, i) = locate(j);
            method.independent_in_stratum(scene, g, sample_key(g, i))
        };
        if with_strata {
            (0..n).into_par_iter().map(sample).unzip()
        } else {
            (
                Vec::new(),
                (0..n).into_par_iter().map(|j| sample(j).1).collect(),
            )
        }
    };
    for wgt in &mut weights {
        if !wgt.is_finite() || *wgt < 0.0 {
            *wgt = 0.0;
            stats.bootstrap_discarded += 1;
        }
    }
    stats.bootstrap_nonzero = weights.iter().filter(|&&v| v > 0.0).count();
    // Each group's sum in order of the index, whatever the layout (bit for bit the same sums).
    let mut sums = vec![0.0; groups];
    for i in 0..bootstrap {
        for (g, sum) in sums.iter_mut().enumerate() {
            *sum += weights[if shared {
                i * groups + g
            } else {
                g * bootstrap + i
            }];
        }
    }
    stats.group_normalisation = sums.iter().map(|s| s / bootstrap as f64).collect();
    stats.normalisation = stats.group_normalisation.iter().sum();
    stats.bootstrap_time = t.elapsed();
    method.bootstrap_done(&stats.group_normalisation);
    if !(stats.normalisation > 0.0) {
        return Err(Error::NoLight { paths: n });
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
            let (g, i) = locate(j);
            let (s, wgt) = method.independent(scene, g, sample_key(g, i));
            if (wgt - weights[j]).abs() > 1e-9 * weights[j].abs().max(1e-300) {
                return Err(Error::InvalidScene(format!("replay of bootstrap path {i} (group {g}) gave importance {wgt}, the bootstrap saw {}: the sampler is not a deterministic function of its numbers", weights[j])));
            }
            let l = method.ln_density(scene, &s);
            Chain::with_density(s, l).map_err(|e| Error::InvalidScene(e.to_string()))
        })
        .collect();
    let mut chains = Vec::with_capacity(picks.len());
    let mut chain_groups = Vec::with_capacity(picks.len());
    for (c, &j) in seeded.into_iter().zip(&picks) {
        chains.push(c?);
        chain_groups.push(locate(j).0);
        stats.group_chains[locate(j).0] += 1;
    }
    let mut rngs: Vec<ChainRng> = (0..chains.len())
        .map(|c| substream(settings.seed, CHAINS, c as u64))
        .collect();
    method.warm_up(scene, &chains, settings.seed)?;
    stats.seed_time = t.elapsed();
    // 3. Chains in rounds; a round is made of slices (at most SLICES, of at most SLICE_MUTATIONS
    //    mutations, and cut at every exchange), so an interrupt stops within a fraction of a
    //    round and the deposits held at a time stay bounded.
    let t = Instant::now();
    let total = match settings.budget {
        Budget::SamplesPerPixel(m) => Some((m * pixels).max(1.0) as u64),
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
    // The bootstrap's normalisation per group, fixed for the weights of the whole run.
    let group_b = stats.group_normalisation.clone();
    let density = method.large_step_density(&group_b, b);
    let large_steps = method
        .large_steps()
        .filter(|&(_, p)| p > 0.0)
        .map(|(kind, probability)| LargeStepMis {
            kind,
            probability,
            density: &density,
        });
    // Bootstrap sums and counts, to which the chains' independent samples are added.
    let tally_kind = method
        .independent_proposals()
        .filter(|_| settings.refine_normalisation);
    let spans = method.chains_span_groups();
    let mut tally = tally_kind.map(|kind| {
        let mut t = NormalisationTally::new(kind, &strata);
        for (j, &weight) in weights.iter().enumerate() {
            t.add(BootstrapSample {
                group: locate(j).0,
                stratum: sample_strata.get(j).copied().unwrap_or(0),
                weight,
            });
        }
        t
    });
    let exchange_every = method.exchange_every();
    let mut exchange_rng = substream(settings.seed, EXCHANGE, 0);
    let mut round = 0;
    loop {
        method.new_round(scene, round, settings.seed)?;
        round += 1;
        let k = match total {
            Some(t) => per_round
                .min((t - stats.mutations).div_ceil(nchains))
                .max(1),
            None => per_round,
        };
        let round_start = Instant::now();
        let n_chunks = chains.len().div_ceil(size);
        let mut counts: Vec<(u64, Option<NormalisationTally>)> = (0..n_chunks)
            .map(|_| {
                (
                    0,
                    tally_kind.map(|kind| NormalisationTally::new(kind, &strata)),
                )
            })
            .collect();
        // Two sets of deposit buffers: the chains record a slice into one while the deposits of
        // the slice before, in the other, enter the sink on the side (in chunk order, so the
        // image does not depend on the thread count). Absorbing them after each slice instead
        // left all threads but one idle meanwhile: 8% of MMLT's time on `cornell` (docs/performance.md).
        let mut recording: Vec<K::Chunk> = (0..n_chunks).map(|_| sink.chunk()).collect();
        let mut absorbing: Vec<K::Chunk> = (0..n_chunks).map(|_| sink.chunk()).collect();
        let slice = k.div_ceil(SLICES).min(SLICE_MUTATIONS / nchains).max(1);
        let mut left = k;
        let mut since_exchange = 0;
        while left > 0 {
            let mut step = slice.min(left);
            if let Some(e) = exchange_every {
                step = step.min(e.max(1) - since_exchange).max(1);
            }
            let absorb = || {
                for chunk in &mut absorbing {
                    sink.absorb(chunk);
                }
            };
            let mutate = || {
                chains
                    .par_chunks_mut(size)
                    .zip(rngs.par_chunks_mut(size))
                    .zip(recording.par_iter_mut().zip(counts.par_iter_mut()))
                    .for_each(|((cs, rs), (chunk, (rays, tally)))| {
                        crate::accel::take_ray_count();
                        let mut rec = ExpectedValue {
                            recorder: chunk,
                            b,
                            large_steps,
                            tally: tally.as_mut(),
                        };
                        method.mutate_chunk(scene, cs, rs, step, &mut rec);
                        *rays += crate::accel::take_ray_count();
                    })
            };
            rayon::join(absorb, mutate);
            std::mem::swap(&mut recording, &mut absorbing);
            left -= step;
            since_exchange += step;
            stats.mutations += step * nchains;
            // Exchanges every `e` mutations, and at the end of a round (as sub-rounds always did).
            if exchange_every.is_some_and(|e| since_exchange >= e.max(1) || left == 0) {
                method.exchange(scene, &mut chains, &chain_groups, &mut exchange_rng);
                since_exchange = 0;
            }
            if stopped() {
                stats.interrupted = true;
                break;
            }
        }
        // The round's last slice (or the one an interrupt ended).
        for chunk in &mut absorbing {
            sink.absorb(chunk);
        }
        for (rays, round_tally) in counts {
            stats.rays += rays;
            if let (Some(t), Some(r)) = (tally.as_mut(), round_tally) {
                t.merge(&r);
            }
        }
        if let Some(t) = &tally {
            refine(&mut stats, t, settings.bootstrap as u64);
            let refined: f64 = stats.refined_normalisation.iter().sum();
            let scales: Vec<f64> = if spans {
                vec![refined / b]
            } else {
                (0..groups)
                    .map(|g| {
                        let c = group_b[g];
                        if c > 0.0 {
                            stats.refined_normalisation[g] / c
                        } else {
                            1.0
                        }
                    })
                    .collect()
            };
            sink.chain_scales(&scales);
        }
        sink.mutations_done(stats.mutations, pixels);
        let elapsed = t.elapsed();
        let go_on = progress(sink, stats.mutations, elapsed);
        let done = match (settings.budget, total) {
            (_, Some(t)) => stats.mutations >= t,
            (Budget::Time(limit), None) => elapsed >= limit,
            _ => true,
        };
        if done || !go_on || stats.interrupted {
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
    Ok(stats)
}
