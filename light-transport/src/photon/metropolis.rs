//! Metropolis photon sampling (Fan, Chenney & Lai 2005): photon maps filled from Metropolis chains
//! over complete light-to-eye paths, so photons land where the final gather reads them.
//!
//! **Sampling (§4).** Path-space MLT chains ([`crate::pathspace::PathMlt`]) with the target
//! `I(f_eye)` (eq. 2, `I` the luminance by default), started from paths resampled from the
//! bootstrap (no start-up bias), with the bidirectional mutation, the caustic and lens
//! perturbations, the lens-subpath mutation, the photon-map proposal (§5.3) and the user-path
//! proposal (§5.1–5.2) mixed with the bidirectional mutation by eq. 7.
//!
//! **Storage points (§3.1).** A path `L (D|S)* D S* D E` stores a global photon at its second
//! non-specular vertex from the eye `x_j`; a path `L S+ D E` stores a caustic photon at `x_d`.
//! The photon records `x_j`, the direction toward `x_{j−1}`, the normal, and its power.
//!
//! **Power (§3.2), corrected.** The paper's `Φ = B_eye f_map(x̄_map) / (N f_eye(x̄))` is not a
//! power: `f_eye` has more vertices than `f_map`, so the sum of such photons over a region
//! integrates the eye vertices `x_{j+1} … x_k` against area measure, and its expectation is the
//! flux times the measure of the eye subpaths that reach `x_j` (dimensioned `m^{2(k−j)}`). The
//! importance weight needs a density `w` over those eye vertices that integrates to one. We take
//! the light walk's own continuation from `x_j` (its BSDF sample, specular bounces as sampled, to
//! the first surface that scatters diffusely, connected to a lens point), restricted to the set
//! `Q(x̄_map)` of continuations that make a storing path carrying light, of probability
//! `A(x̄_map)`. Then
//!
//! `Φ = (B / N) · f_map w / (I(f_eye) A) = (B / N) · β_L(x_j) · Â⁻¹ / I(C*_{k}(x̄))`,
//!
//! with `β_L(x_j)` the light subpath's throughput arriving at `x_j` (what a photon tracer stores),
//! `C*_k` the path's `t = 1` strategy ratio (the chain's state holds it), and `Â⁻¹` an unbiased
//! estimate of `1/A`: continuations are drawn independently until `r` of them land in `Q`, and
//! with `N` drawn, `N/r` has mean `1/A` (negative binomial, `E[N] = r/A`; `r = 4` by default,
//! relative variance `(1 − A)/r`; Qin et al. 2015 use the `r = 1` count for inverse
//! probabilities). (`(N − 1)/(r − 1)` — Haldane's unbiased estimator of `A` turned upside down — is
//! biased high by up to `r/(r − 1)`: the first version here used it, and the long comparison below
//! caught it.) Then `E[Σ_R Φ] = ∫_{Ω_R} f_map dμ` for every region `R` of storage points with
//! `A > 0`: the photon map is a particle map as a light tracer's is, but only where a gather can
//! read it. For caustic photons on a pinhole camera `A ∈ {0, 1}`. Consequences: eye subpaths
//! through specular surfaces before `x_d` (a diffuse point seen in a mirror) have `w = 0` and store
//! nothing; a point that a gather reaches only through such a view gets no photons.
//!
//! **Recording.** Every proposal deposits `1 − a` times the current path's photon and `a` times the
//! candidate's (the expected values of §6). A path's photon is computed once per chunk and its
//! repeats are added to it; deposits at the same storage point and incoming direction accumulate in
//! one photon (§3.2).

use super::map::Photon;
use super::mapper::{PhotonMapper, PhotonMapping, PhotonMappingError};
use crate::Result;
use crate::bsdf::TransportMode;
use crate::metropolis::{MetropolisSettings, MetropolisStats, Recorder, Sink, run_with};
use crate::path::{Vertex, connect_unoccluded, unoccluded};
use crate::pathspace::path::retrace;
use crate::pathspace::perturbation::specular_only;
use crate::pathspace::walk::{lens_endpoint, trace};
use crate::pathspace::{FullPath, MutationProbabilities, PathMlt, PathState};
use crate::scene::Scene;
use crate::spectrum::Rgb;
use mcmc_core::ChainRng;
use mcmc_core::rng::uniform;
use std::collections::HashMap;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// Which map a path stores into, and where.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StoragePoint {
    /// The global map, at vertex `j` (the second non-specular vertex from the eye).
    Global(usize),
    /// The caustic map, at vertex `d` (the first from the eye, after `L S+`).
    Caustic(usize),
}

impl StoragePoint {
    /// The vertex index.
    pub fn index(self) -> usize {
        match self {
            Self::Global(j) | Self::Caustic(j) => j,
        }
    }
}

fn diffuse(v: &Vertex) -> bool {
    v.bsdf
        .as_ref()
        .is_some_and(|b| !b.is_delta_only() && !b.is_black())
}

/// Where `path` stores its photon (module docs), or `None`.
pub fn storage_point(path: &FullPath) -> Option<StoragePoint> {
    let k = path.edges();
    if k < 2 {
        return None;
    }
    let d = k - 1;
    let v = &path.vertices;
    if path.specular(d) || !diffuse(&v[d]) {
        return None;
    }
    let j = (0..d).rev().find(|&i| !path.specular(i))?;
    if j == 0 {
        // L S* D E: direct light (nothing) or a caustic.
        return (d >= 2 && (1..d).all(|i| specular_only(&v[i])))
            .then_some(StoragePoint::Caustic(d));
    }
    let ok = diffuse(&v[j]) && (j + 1..d).all(|i| specular_only(&v[i]));
    ok.then_some(StoragePoint::Global(j))
}

/// One continuation of the light walk from the storage point: whether it lands in `Q` (module
/// docs). `prefix` is `x_0 … x_j` with throughputs; `scratch` is reused.
fn continuation_succeeds(
    scene: &Scene,
    prefix: &[Vertex],
    global: bool,
    max_edges: usize,
    rng: &mut ChainRng,
    scratch: &mut Vec<Vertex>,
) -> bool {
    scratch.clear();
    scratch.extend_from_slice(prefix);
    if global {
        // The BSDF sample at x_j, then surfaces that only scatter specularly, to a diffuse one.
        let mut first = true;
        loop {
            if scratch.len() > max_edges {
                return false;
            }
            let Some(v) = scratch.last_mut() else {
                return false;
            };
            let Some(b) = v.bsdf.as_ref() else {
                return false;
            };
            let Some(s) = b.sample(
                v.wo,
                uniform(rng),
                [uniform(rng), uniform(rng)],
                TransportMode::Importance,
            ) else {
                return false;
            };
            // x_j must scatter through a non-delta lobe, the specular surfaces through delta ones.
            if !(s.pdf > 0.0) || s.f.is_black() || s.delta == first {
                return false;
            }
            v.delta = s.delta;
            let Some(next) = trace(scene, v, s.wi) else {
                return false;
            };
            first = false;
            let stop = !specular_only(&next);
            scratch.push(next);
            if stop {
                break;
            }
        }
        if !diffuse(scratch.last().unwrap_or(&prefix[0])) {
            return false;
        }
    }
    // Connect the last vertex to a lens point (strategy t = 1).
    if scratch.len() > max_edges {
        return false;
    }
    let Some(lens) = lens_endpoint(scene, rng) else {
        return false;
    };
    let mut camera = [lens];
    let s = scratch.len();
    if retrace(scene, scratch, TransportMode::Importance) < s
        || retrace(scene, &mut camera, TransportMode::Radiance) < 1
    {
        return false;
    }
    let ok = connect_unoccluded(scene, scratch, &camera, s, 1)
        .is_some_and(|c| c.raster.is_some() && !c.value.is_black() && c.value.is_finite());
    ok && unoccluded(scene, &scratch[s - 1], &camera[0])
}

/// The photon a path stores per unit of deposit weight `b/I(state)` and per mutation: its storage
/// point, and `I(state) β_L(x_j) Â⁻¹ / I(C*_k)` (module docs) with `Â⁻¹` from continuations drawn
/// until `successes` of them land in `Q` — `None` when it stores nothing. The flag tells whether
/// `max_trials` cut the count short.
pub fn path_photon(
    scene: &Scene,
    state: &PathState,
    max_edges: usize,
    max_trials: u64,
    successes: u64,
    seed: u64,
    scratch: &mut Vec<Vertex>,
) -> Option<(StoragePoint, Photon, bool)> {
    // The top bit of `successes` asks for the defect `MpsDefect::HaldaneInverse`.
    let haldane = successes & HALDANE != 0;
    let successes = successes & !HALDANE;
    let path = &state.path;
    let at = storage_point(path)?;
    let j = at.index();
    let k = path.edges();
    let i_t1 = state.strategy_importance(k);
    let i_state = state.contribution.importance;
    if !(i_t1 > 0.0 && i_state > 0.0) {
        return None;
    }
    let mut prefix: Vec<Vertex> = path.vertices[..=j].to_vec();
    if retrace(scene, &mut prefix, TransportMode::Importance) <= j {
        return None;
    }
    let v = &prefix[j];
    let beta = v.beta;
    // 1/A: continuations drawn until `successes` land in Q (deterministic in the path: seeded by
    // its hash); the count N of draws is negative binomial with mean r/A, so N/r is unbiased.
    let mut rng = mcmc_core::rng::stream(seed, path_hash(path));
    let global = matches!(at, StoragePoint::Global(_));
    let (mut trials, mut hits) = (0u64, 0u64);
    while trials < max_trials && hits < successes {
        trials += 1;
        hits += continuation_succeeds(scene, &prefix, global, max_edges, &mut rng, scratch) as u64;
    }
    let capped = hits < successes;
    let inverse_a = match (successes, haldane) {
        (0, _) => 1.0, // MpsDefect::WithoutContinuationProbability
        (r, true) if r >= 2 => (trials - 1) as f64 / (r - 1) as f64,
        (r, _) => trials as f64 / r as f64,
    };
    let power = beta * (i_state * inverse_a / i_t1);
    if !power.is_finite() || power.is_black() {
        return None;
    }
    let wi = (path.vertices[j - 1].p() - v.p()).normalize_or_zero();
    let n = if v.point.n.dot(wi) >= 0.0 {
        v.point.n
    } else {
        -v.point.n
    };
    Some((
        at,
        Photon {
            p: v.p(),
            wi,
            power,
            n,
        },
        capped,
    ))
}

const HALDANE: u64 = 1 << 63;

/// A hash of a path's vertex positions (its identity for repeated states).
pub fn path_hash(path: &FullPath) -> u64 {
    let mut h: u64 = 0x9E37_79B9_7F4A_7C15;
    for v in &path.vertices {
        for c in v.p().to_array() {
            h = (h ^ c.to_bits()).wrapping_mul(0x100_0000_01B3);
            h ^= h >> 29;
        }
    }
    h
}

fn storage_key(map: bool, p: &Photon) -> [u64; 7] {
    [
        map as u64,
        p.p.x.to_bits(),
        p.p.y.to_bits(),
        p.p.z.to_bits(),
        p.wi.x.to_bits(),
        p.wi.y.to_bits(),
        p.wi.z.to_bits(),
    ]
}

/// Photons deposited by one group of chains in one round.
pub struct PhotonChunk<'a> {
    scene: Option<&'a Scene>,
    max_edges: usize,
    max_trials: u64,
    successes: u64,
    seed: u64,
    /// Per path: the photon (unit power), its map, and whether its `1/A` count was cut at the cap.
    paths: HashMap<u64, Option<(bool, Photon)>>,
    /// Accumulated photons by storage key.
    photons: HashMap<[u64; 7], (bool, Photon)>,
    scratch: Vec<Vertex>,
    capped: u64,
    deposits: u64,
}

impl Default for PhotonChunk<'_> {
    fn default() -> Self {
        Self {
            scene: None,
            max_edges: 0,
            max_trials: 0,
            successes: 1,
            seed: 0,
            paths: HashMap::new(),
            photons: HashMap::new(),
            scratch: Vec::new(),
            capped: 0,
            deposits: 0,
        }
    }
}

impl Recorder<PathState> for PhotonChunk<'_> {
    fn record(&mut self, state: &PathState, weight: f64) {
        let Some(scene) = self.scene else {
            return;
        };
        if !(weight > 0.0) {
            return;
        }
        let h = path_hash(&state.path);
        let (max_edges, max_trials, successes, seed) =
            (self.max_edges, self.max_trials, self.successes, self.seed);
        let entry = match self.paths.get(&h) {
            Some(e) => *e,
            None => {
                let e = path_photon(
                    scene,
                    state,
                    max_edges,
                    max_trials,
                    successes,
                    seed,
                    &mut self.scratch,
                )
                .map(|(at, photon, capped)| {
                    self.capped += capped as u64;
                    (matches!(at, StoragePoint::Caustic(_)), photon)
                });
                self.paths.insert(h, e);
                e
            }
        };
        let Some((caustic, unit)) = entry else {
            return;
        };
        self.deposits += 1;
        let add = unit.power * weight;
        self.photons
            .entry(storage_key(caustic, &unit))
            .and_modify(|(_, p)| p.power += add)
            .or_insert((caustic, Photon { power: add, ..unit }));
    }
}

/// Where the chains' photons go: accumulated by storage point, scaled by `1/N` at the end.
pub struct PhotonSink<'a> {
    scene: &'a Scene,
    max_edges: usize,
    max_trials: u64,
    successes: u64,
    seed: u64,
    photons: HashMap<[u64; 7], (bool, Photon)>,
    mutations: u64,
    /// The refined normalisation over the bootstrap's (every photon is the chains' deposit).
    chain_scale: f64,
    capped: u64,
    deposits: u64,
}

impl<'a> Sink<PathState> for PhotonSink<'a> {
    type Chunk = PhotonChunk<'a>;

    fn chunk(&self) -> PhotonChunk<'a> {
        PhotonChunk {
            scene: Some(self.scene),
            max_edges: self.max_edges,
            max_trials: self.max_trials,
            successes: self.successes,
            seed: self.seed,
            ..Default::default()
        }
    }

    fn absorb(&mut self, chunk: &mut PhotonChunk<'a>) {
        self.capped += std::mem::take(&mut chunk.capped);
        self.deposits += std::mem::take(&mut chunk.deposits);
        for (key, (caustic, p)) in chunk.photons.drain() {
            self.photons
                .entry(key)
                .and_modify(|(_, q)| q.power += p.power)
                .or_insert((caustic, p));
        }
    }

    fn mutations_done(&mut self, mutations: u64, _pixels: f64) {
        self.mutations = mutations;
    }

    fn chain_scales(&mut self, scales: &[f64]) {
        // Path-space chains span the path lengths: one scale, of group 0, where they record.
        self.chain_scale = scales.first().copied().unwrap_or(1.0);
    }
}

/// Settings of Metropolis photon sampling.
#[derive(Clone, Debug)]
pub struct MpsSettings {
    /// The chains (mutations: see [`MpsSettings::new`]); the budget is in mutations per pixel.
    pub metropolis: MetropolisSettings,
    /// The final gather (the photon counts are unused).
    pub gather: PhotonMapping,
    /// Continuations that must land in `Q` before a photon's `1/A` is estimated (`r`; the
    /// estimate `N/r` from the `N` drawn has relative variance `(1 − A)/r`).
    pub continuations: u64,
    /// Most continuations drawn per photon (one whose count reaches it keeps the estimate at the
    /// cap — biased low — and is counted).
    pub max_trials: u64,
    /// A deliberate defect (tests of the tests only).
    pub defect: Option<MpsDefect>,
}

/// Deliberately wrong photon powers, kept to show that the tests catch them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MpsDefect {
    /// `1/A = 1`: the photon power without the inverse continuation probability.
    WithoutContinuationProbability,
    /// `1/A` estimated by `(N − 1)/(r − 1)` (Haldane's unbiased estimator of `A`, inverted): high
    /// by up to `r/(r − 1)`.
    HaldaneInverse,
}

impl MpsSettings {
    /// Defaults for paths of at most `max_edges` edges: 1000 chains, 100 000 bootstrap samples per
    /// path length, 4 mutations per pixel, the final gather's defaults, at most 10 000
    /// continuations per photon.
    pub fn new(max_edges: usize) -> Self {
        Self {
            metropolis: MetropolisSettings {
                budget: crate::Budget::SamplesPerPixel(4.0),
                ..MetropolisSettings::default()
            },
            gather: PhotonMapping::new(max_edges),
            continuations: 4,
            max_trials: 10_000,
            defect: None,
        }
    }
}

/// The paper's proposal probabilities without user paths (its Lantern scene): bidirectional 0.4,
/// photon map 0.2, lens 0.2, lens subpath 0.2.
pub fn proposals() -> MutationProbabilities {
    MutationProbabilities::of(&[
        ("bidirectional", 0.4),
        ("photon-map", 0.2),
        ("lens", 0.2),
        ("lens-subpath", 0.2),
    ])
    .unwrap_or_default()
}

/// The paper's proposal probabilities with user paths (its Box scene): user path 0.1,
/// bidirectional 0.3, photon map 0.2, caustic 0.12, lens 0.08, lens subpath 0.2.
pub fn proposals_with_user_paths() -> MutationProbabilities {
    MutationProbabilities::of(&[
        ("user-path", 0.1),
        ("bidirectional", 0.3),
        ("photon-map", 0.2),
        ("caustic", 0.12),
        ("lens", 0.08),
        ("lens-subpath", 0.2),
    ])
    .unwrap_or_default()
}

/// What Metropolis photon sampling did.
#[derive(Clone, Debug, Default)]
pub struct MpsStats {
    /// The chains' statistics (bootstrap = the estimate of `B_eye`).
    pub chains: MetropolisStats,
    /// Time to estimate `B_eye` (the bootstrap).
    pub t_b: Duration,
    /// Time to sample the photons (seeding and chains).
    pub t_map: Duration,
    /// Photons in the global and the caustic map.
    pub photons: (usize, usize),
    /// Deposits (path photons recorded with positive weight).
    pub deposits: u64,
    /// Photons whose `1/A` count reached the cap.
    pub capped: u64,
}

impl MpsStats {
    /// Report lines.
    pub fn summary(&self) -> Vec<String> {
        vec![
            format!(
                "mps        t_B {:.2} s (B_eye = {:.5e}), t_map {:.2} s, {} mutations, {:.2} M mutations/s",
                self.t_b.as_secs_f64(),
                self.chains.normalisation,
                self.t_map.as_secs_f64(),
                self.chains.mutations,
                self.chains.mutations as f64 / self.chains.chain_time.as_secs_f64().max(1e-9) / 1e6
            ),
            format!(
                "mps        photons global {} caustic {} from {} deposits{}",
                self.photons.0,
                self.photons.1,
                self.deposits,
                if self.capped > 0 {
                    format!(", {} with 1/A at the continuation cap (biased low)", self.capped)
                } else {
                    String::new()
                }
            ),
        ]
        .into_iter()
        .chain(
            self.chains
                .stats
                .table(&self.chains.kinds)
                .to_string()
                .lines()
                .filter(|l| !l.trim().is_empty())
                .map(|l| format!("mps        {l}")),
        )
        .collect()
    }
}

/// Run the chains of `method` and return the photons `(global, caustic)` with their statistics.
pub fn sample_photons(
    scene: &Scene,
    method: &PathMlt,
    settings: &MpsSettings,
    stop: Option<&AtomicBool>,
    mut progress: impl FnMut(u64, Duration) -> bool,
) -> Result<(Vec<Photon>, Vec<Photon>, MpsStats)> {
    let t = Instant::now();
    let mut sink = PhotonSink {
        scene,
        max_edges: method.mutations.max_edges,
        max_trials: settings.max_trials.max(1),
        successes: match settings.defect {
            Some(MpsDefect::WithoutContinuationProbability) => 0,
            Some(MpsDefect::HaldaneInverse) => settings.continuations.max(1) | HALDANE,
            None => settings.continuations.max(1),
        },
        seed: settings.metropolis.seed ^ 0x3F5,
        photons: HashMap::new(),
        mutations: 0,
        chain_scale: 1.0,
        capped: 0,
        deposits: 0,
    };
    let chains = run_with(
        scene,
        method,
        &settings.metropolis,
        &mut sink,
        stop,
        |_, m, e| progress(m, e),
    )?;
    let scale = sink.chain_scale / sink.mutations.max(1) as f64;
    let (mut global, mut caustic) = (Vec::new(), Vec::new());
    // A fixed order (the hash map's is not).
    let mut all: Vec<([u64; 7], (bool, Photon))> = sink.photons.into_iter().collect();
    all.sort_unstable_by_key(|(k, _)| *k);
    for (_, (is_caustic, mut p)) in all {
        p.power *= scale;
        if !p.power.is_finite() || p.power.is_black() {
            continue;
        }
        if is_caustic {
            caustic.push(p);
        } else {
            global.push(p);
        }
    }
    let stats = MpsStats {
        t_b: chains.bootstrap_time,
        t_map: t.elapsed().saturating_sub(chains.bootstrap_time),
        photons: (global.len(), caustic.len()),
        deposits: sink.deposits,
        capped: sink.capped,
        chains,
    };
    Ok((global, caustic, stats))
}

/// Metropolis photon sampling and its final gather, ready to render.
pub fn mps_mapper(
    scene: &Scene,
    method: &PathMlt,
    settings: &MpsSettings,
    stop: Option<&AtomicBool>,
    progress: impl FnMut(u64, Duration) -> bool,
) -> Result<(PhotonMapper, MpsStats)> {
    let (global, caustic, stats) = sample_photons(scene, method, settings, stop, progress)?;
    let mapper =
        PhotonMapper::from_photons(scene, settings.gather, global, caustic, stats.summary())
            .map_err(|e: PhotonMappingError| crate::Error::InvalidParameter {
                name: "mps".into(),
                reason: e.to_string(),
            })?;
    Ok((mapper, stats))
}

/// Photon colour helper for tests: the summed power of photons inside an axis-aligned box.
pub fn power_in_box(photons: &[Photon], lo: crate::math::DVec3, hi: crate::math::DVec3) -> Rgb {
    photons
        .iter()
        .filter(|p| p.p.cmpge(lo).all() && p.p.cmple(hi).all())
        .fold(Rgb::BLACK, |a, p| a + p.power)
}
