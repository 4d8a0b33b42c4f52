//! The bidirectional mutation (Veach & Guibas 1997, §5.3.1) and the new-path mutation.
//!
//! **Deletion.** Number the `k + 2` "edges" of `x̄ = v_0 … v_k` including a virtual edge before
//! `v_0` and one after `v_k`. The mutation deletes `k_d` consecutive ones, i.e. the vertices
//! strictly between `v_l` and `v_m` (`m = l + k_d`, `−1 ≤ l < m ≤ k + 1`; `l = −1` deletes the
//! light endpoint, `m = k + 1` the lens point), with probability `P_d(l, m | k) ∝ w(k_d)`,
//! `w = 1/4, 1/2, 1/4, 1/8, …` for `k_d = 1, 2, 3, 4, …` (Veach's preference for short deletions).
//! Kept endpoints keep their roles: nothing is inserted before a kept light endpoint or after a
//! kept lens point.
//!
//! **Addition.** `n` new vertices, `P_a(n | k_d) ∝ 2^{−|n − (k_d − 1)|}` on the lengths allowed by
//! the path length limit (at least one new vertex where an endpoint was deleted, two for a whole
//! new path); a split `a + b = n` chosen uniformly (`b ≥ 1` when the lens point must be made):
//! `a` vertices continue the light part by a random walk (a new light endpoint first if it was
//! deleted), `b` continue the camera part, and the two are connected — strategy `s = l + 1 + a`.
//!
//! **Density.** The same `ȳ` arises from every split, so
//! `T(ȳ|x̄) = P_d P_a / N_split · Σ_a p_{l+1+a}(ȳ) / (K_L K_C)` where `K_L`, `K_C` are the densities
//! of the kept vertices (equal for `x̄` and `ȳ`). With `p_s = I(f)/I(C*_s)`:
//!
//! `I(f(ȳ)) / T(ȳ|x̄) = K_L K_C / (P_d P_a / N_split · Σ_a 1/I(C*_{l+1+a}(ȳ)))`
//!
//! and the acceptance is the ratio of this to the same quantity of the reverse move (delete the
//! new vertices of `ȳ`, add back the `k_d − 1` deleted ones). Strategies that cannot make the path
//! (a connection through a delta lobe) drop out of the sums.
//!
//! **New path** (practical-MLT paper §3.2): a whole new path by one bidirectional strategy —
//! length `k` with probability `P_len(k)`, then `s` uniform in `0 … k` — with
//! `T(ȳ) = P_len(k') / (k' + 1) · Σ_s p_s(ȳ)`.

use super::perturbation::connection_clear;
use super::state::PathState;
use super::walk::{extend, lens_endpoint, light_endpoint};
use crate::bsdf::TransportMode;
use crate::metropolis::ImportanceKind;
use crate::path::{Vertex, camera_subpath, connect, light_subpath};
use crate::sampler::{IndependentStream, SampleStream, TECHNIQUE_STREAM};
use crate::scene::Scene;
use mcmc_core::rng::{categorical, uniform};
use mcmc_core::{ChainRng, Failure};

const NEW_PATH_STREAM: u64 = 0x4e57_9a7f;

/// Weight of deleting `kd` virtual edges.
fn deletion_weight(kd: usize) -> f64 {
    match kd {
        0 => 0.0,
        1 => 0.25,
        2 => 0.5,
        _ => 0.5f64.powi(kd as i32 - 1),
    }
}

/// Number of allowed deletions of `kd` edges from a path of `k` edges.
fn deletion_count(k: usize, kd: usize) -> usize {
    match kd {
        0 => 0,
        1 => k,
        _ if kd <= k + 2 => k + 3 - kd,
        _ => 0,
    }
}

/// The deletion and addition probabilities of the bidirectional mutation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bidirectional {
    /// Longest path allowed (edges).
    pub max_edges: usize,
}

/// A deletion: vertices strictly between `l` and `m` go (`l = −1`: the light endpoint too;
/// `m = k + 1`: the lens point too).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Deletion {
    /// Last kept light-side vertex (−1: none).
    pub l: isize,
    /// First kept camera-side vertex (`k + 1`: none).
    pub m: usize,
}

impl Deletion {
    /// Deleted virtual edges `k_d = m − l`.
    pub fn kd(&self) -> usize {
        (self.m as isize - self.l) as usize
    }
    /// Whether the deletion is allowed on a path of `k` edges.
    pub fn allowed(&self, k: usize) -> bool {
        self.l >= -1
            && (self.m as isize) > self.l
            && self.m <= k + 1
            && !(self.l == -1 && self.m == 0)
            && !(self.l == k as isize && self.m == k + 1)
    }
}

impl Bidirectional {
    /// `P_d(deletion | k)` (0 when not allowed).
    pub fn deletion_probability(&self, k: usize, d: Deletion) -> f64 {
        if !d.allowed(k) {
            return 0.0;
        }
        let z: f64 = (1..=k + 2)
            .map(|kd| deletion_weight(kd) * deletion_count(k, kd) as f64)
            .sum();
        deletion_weight(d.kd()) / z
    }

    /// Sample a deletion from a path of `k ≥ 1` edges.
    pub fn sample_deletion(&self, k: usize, rng: &mut ChainRng) -> Deletion {
        let weights: Vec<f64> = (1..=k + 2)
            .map(|kd| deletion_weight(kd) * deletion_count(k, kd) as f64)
            .collect();
        let kd = categorical(&weights, uniform(rng)).map_or(k + 2, |i| i + 1);
        let count = deletion_count(k, kd).max(1);
        let pick = ((uniform(rng) * count as f64) as usize).min(count - 1);
        let l = if kd == 1 {
            pick as isize
        } else {
            pick as isize - 1
        };
        Deletion {
            l,
            m: (l + kd as isize) as usize,
        }
    }

    /// Allowed numbers of new vertices after deletion `d` from a path of `k` edges.
    pub fn addition_range(&self, k: usize, d: Deletion) -> (usize, usize) {
        let (light_gone, lens_gone) = (d.l == -1, d.m == k + 1);
        let lo = light_gone as usize + lens_gone as usize;
        let kept = k + 2 - d.kd();
        let hi = (self.max_edges + 1).saturating_sub(kept);
        (lo, hi)
    }

    /// `P_a(n | deletion, k)` (0 outside the allowed range).
    pub fn addition_probability(&self, k: usize, d: Deletion, n: usize) -> f64 {
        let (lo, hi) = self.addition_range(k, d);
        if n < lo || n > hi {
            return 0.0;
        }
        let target = d.kd() as f64 - 1.0;
        let w = |i: usize| 0.5f64.powf((i as f64 - target).abs());
        w(n) / (lo..=hi).map(w).sum::<f64>()
    }

    /// Sample the number of new vertices (`None` when no length is allowed).
    pub fn sample_addition(&self, k: usize, d: Deletion, rng: &mut ChainRng) -> Option<usize> {
        let (lo, hi) = self.addition_range(k, d);
        if lo > hi {
            return None;
        }
        let weights: Vec<f64> = (lo..=hi)
            .map(|n| self.addition_probability(k, d, n))
            .collect();
        Some(categorical(&weights, uniform(rng)).map_or(hi, |i| lo + i))
    }

    /// Number of splits `a = 0 … N − 1` of `n` new vertices (light side `a`, camera side `n − a`).
    pub fn splits(k: usize, d: Deletion, n: usize) -> usize {
        (n + 1).saturating_sub((d.m == k + 1) as usize)
    }

    /// `P_d P_a / N_split · Σ_a 1/I(C*_{l+1+a}(result))`: the move that deletes `d` from a path
    /// of `k` edges and adds the `n` vertices of `result` that follow its vertex `l` (up to the
    /// common constant `K_L K_C`, `T(result|·) / I(f(result))`).
    pub fn move_weight(&self, k: usize, d: Deletion, n: usize, result: &PathState) -> f64 {
        let p = self.deletion_probability(k, d) * self.addition_probability(k, d, n);
        let splits = Self::splits(k, d, n);
        if !(p > 0.0) || splits == 0 {
            return 0.0;
        }
        let from = (d.l + 1) as usize;
        p / splits as f64 * result.inverse_sum(from, from + splits)
    }

    /// Propose `y` from `x`; returns `ln` of the acceptance ratio.
    pub fn propose(
        &self,
        scene: &Scene,
        importance: ImportanceKind,
        x: &PathState,
        rng: &mut ChainRng,
        y: &mut PathState,
    ) -> Result<f64, Failure> {
        let xp = &x.path;
        let k = xp.edges();
        if k < 1 {
            return Err(Failure::NotApplicable);
        }
        let d = self.sample_deletion(k, rng);
        let n = self
            .sample_addition(k, d, rng)
            .ok_or(Failure::NotApplicable)?;
        let splits = Self::splits(k, d, n);
        let a = ((uniform(rng) * splits as f64) as usize).min(splits - 1);
        let b = n - a;
        // Light part.
        let mut light: Vec<Vertex> = Vec::with_capacity(k + n);
        if d.l >= 0 {
            light.extend_from_slice(&xp.vertices[..=d.l as usize]);
            if !extend(scene, &mut light, a, TransportMode::Importance, rng) {
                return Err(Failure::Failed);
            }
        } else if a > 0 {
            light.push(light_endpoint(scene, rng).ok_or(Failure::Failed)?);
            if !extend(scene, &mut light, a - 1, TransportMode::Importance, rng) {
                return Err(Failure::Failed);
            }
        }
        // Camera part (walk order: lens first).
        let mut cam: Vec<Vertex> = Vec::with_capacity(k + n);
        if d.m <= k {
            cam.extend(xp.vertices[d.m..].iter().rev().cloned());
            if !extend(scene, &mut cam, b, TransportMode::Radiance, rng) {
                return Err(Failure::Failed);
            }
        } else {
            cam.push(lens_endpoint(scene, rng).ok_or(Failure::Failed)?);
            if !extend(scene, &mut cam, b - 1, TransportMode::Radiance, rng) {
                return Err(Failure::Failed);
            }
        }
        let (s, t) = (light.len(), cam.len());
        if s > 0 && !connection_clear(scene, &light[s - 1], &cam[t - 1]) {
            return Ok(f64::NEG_INFINITY);
        }
        if y.path
            .set_from_subpaths(scene, &light, &cam, s, t)
            .is_none()
            || !y.evaluate(scene, importance, 1.0)
        {
            return Ok(f64::NEG_INFINITY);
        }
        let forward = self.move_weight(k, d, n, y);
        let k_new = y.path.edges();
        let d_back = Deletion {
            l: d.l,
            m: (d.l + 1) as usize + n,
        };
        let backward = self.move_weight(k_new, d_back, d.kd() - 1, x);
        if !(forward > 0.0) {
            // The strategy that made ȳ contributes nothing: f(ȳ) = 0.
            return Ok(f64::NEG_INFINITY);
        }
        Ok(backward.ln() - forward.ln())
    }
}

/// Sample a whole path of `k` edges by strategy `s` (light vertices) from `stream`, as BDPT would
/// (the connection is tested for visibility); `None` when the subpaths fall short or the
/// connection carries nothing.
pub fn sample_path<S: SampleStream>(
    scene: &Scene,
    k: usize,
    s: usize,
    stream: &mut S,
    buffers: &mut (Vec<Vertex>, Vec<Vertex>),
    out: &mut PathState,
) -> Option<()> {
    let t = k + 1 - s;
    let (light, cam) = buffers;
    camera_subpath(scene, stream, t, None, cam);
    light_subpath(scene, stream, s, light);
    if cam.len() < t || light.len() < s {
        return None;
    }
    connect(scene, light, cam, s, t)?;
    out.path.set_from_subpaths(scene, light, cam, s, t)
}

/// The new-path mutation and the bootstrap sampler: a path of length `k` by a uniformly chosen
/// strategy.
#[derive(Clone, Debug, PartialEq)]
pub struct NewPath {
    /// `P_len(k)` for `k = 1 … max_edges` (index `k − 1`), summing to 1.
    pub length_probability: Vec<f64>,
}

impl NewPath {
    /// Uniform lengths up to `max_edges`.
    pub fn uniform(max_edges: usize) -> Self {
        Self {
            length_probability: vec![1.0 / max_edges.max(1) as f64; max_edges.max(1)],
        }
    }

    /// Lengths in proportion to the energy `b_k` of each length, mixed with 20% uniform so that
    /// every length stays reachable.
    pub fn from_energies(energies: &[f64]) -> Self {
        let n = energies.len().max(1);
        let total: f64 = energies.iter().filter(|e| e.is_finite()).sum();
        if !(total > 0.0) {
            return Self::uniform(n);
        }
        Self {
            length_probability: energies
                .iter()
                .map(|&e| {
                    let e = if e.is_finite() && e > 0.0 { e } else { 0.0 };
                    0.8 * e / total + 0.2 / n as f64
                })
                .collect(),
        }
    }

    fn probability(&self, k: usize) -> f64 {
        k.checked_sub(1)
            .and_then(|i| self.length_probability.get(i))
            .copied()
            .unwrap_or(0.0)
    }

    /// A path of `k` edges from the numbers of `stream` (strategy from the technique stream),
    /// evaluated with colour scaled by `k + 1` (so that `I(colour)` is the importance weight
    /// `I(f)/q_k` of the sample within its length). Deterministic in the stream.
    pub fn sample<S: SampleStream>(
        scene: &Scene,
        importance: ImportanceKind,
        k: usize,
        stream: &mut S,
        out: &mut PathState,
    ) -> bool {
        stream.start_stream(TECHNIQUE_STREAM);
        let u = stream.next_1d();
        let s = ((u * (k + 1) as f64) as usize).min(k);
        let mut buffers = (Vec::new(), Vec::new());
        if sample_path(scene, k, s, stream, &mut buffers, out).is_none() {
            out.path.vertices.clear();
            out.strategy.clear();
            out.contribution = Default::default();
            return false;
        }
        out.evaluate(scene, importance, (k + 1) as f64)
    }

    /// Propose a new path `y`; returns `ln` of the acceptance ratio.
    pub fn propose(
        &self,
        scene: &Scene,
        importance: ImportanceKind,
        x: &PathState,
        rng: &mut ChainRng,
        y: &mut PathState,
    ) -> Result<f64, Failure> {
        let k = categorical(&self.length_probability, uniform(rng))
            .map_or(self.length_probability.len(), |i| i + 1);
        let mut stream = IndependentStream::new(mcmc_core::rng::stream(
            rand::Rng::next_u64(rng),
            NEW_PATH_STREAM,
        ));
        if !Self::sample(scene, importance, k, &mut stream, y) {
            return Ok(f64::NEG_INFINITY);
        }
        let weight = |st: &PathState| {
            let k = st.path.edges();
            self.probability(k) / (k + 1) as f64 * st.inverse_sum(0, k + 1)
        };
        let (forward, backward) = (weight(y), weight(x));
        if !(forward > 0.0) {
            return Ok(f64::NEG_INFINITY);
        }
        Ok(backward.ln() - forward.ln())
    }
}
