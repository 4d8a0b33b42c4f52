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
//! which is the mutation's density `T̃` in the common measure of [`super::mutation`] (its record
//! is `(l, m, n)`). The acceptance is the ratio of the reverse move's `T̃` (delete the new
//! vertices of `ȳ`, add back the `k_d − 1` deleted ones) to this one. Strategies that cannot make
//! the path (a connection through a delta lobe) drop out of the sums.

use super::mutation::{Change, Mutation, Registration};
use super::state::PathState;
use super::walk::{Toward, extend_in_place, lens_endpoint, light_endpoint};
use crate::bsdf::TransportMode;
use crate::metropolis::ImportanceKind;
use crate::scene::Scene;
use mcmc_core::rng::{uniform, uniform_index};
use mcmc_core::{ChainRng, Failure};

/// The registration of the bidirectional mutation.
pub const REGISTRATION: Registration = Registration {
    name: "bidirectional",
    default_weight: 0.25,
    build: |c| {
        Box::new(BidirectionalMutation {
            bidirectional: Bidirectional {
                max_edges: c.settings.max_edges,
            },
            scene: c.scene,
            importance: c.settings.importance,
        })
    },
};

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
        let weight = |kd: usize| deletion_weight(kd) * deletion_count(k, kd) as f64;
        let total: f64 = (1..=k + 2).map(weight).sum();
        let mut v = uniform(rng) * total;
        let kd = (1..=k + 2)
            .find(|&kd| {
                let w = weight(kd);
                let hit = w > 0.0 && v < w;
                v -= w;
                hit
            })
            .unwrap_or(k + 2);
        let count = deletion_count(k, kd).max(1);
        let pick = uniform_index(uniform(rng), count);
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
        // Unnormalised weights 2^{−|n − (k_d − 1)|} (addition_probability normalises them).
        let target = d.kd() as f64 - 1.0;
        let weight = |n: usize| 0.5f64.powf((n as f64 - target).abs());
        let total: f64 = (lo..=hi).map(weight).sum();
        let mut v = uniform(rng) * total;
        Some(
            (lo..=hi)
                .find(|&n| {
                    let hit = v < weight(n);
                    v -= weight(n);
                    hit
                })
                .unwrap_or(hi),
        )
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

    /// Propose `y` from `x` (evaluated, with its record); `Err` when no candidate was made.
    pub fn propose(
        &self,
        scene: &Scene,
        importance: ImportanceKind,
        x: &PathState,
        rng: &mut ChainRng,
        y: &mut PathState,
    ) -> Result<(), Failure> {
        let xp = &x.path;
        let k = xp.edges();
        if k < 1 {
            return Err(Failure::NotApplicable);
        }
        // The deletion and the number of new vertices are the first draws (tests replay them).
        let d = self.sample_deletion(k, rng);
        let n = self
            .sample_addition(k, d, rng)
            .ok_or(Failure::NotApplicable)?;
        let splits = Self::splits(k, d, n);
        let a = uniform_index(uniform(rng), splits);
        let b = n - a;
        // Both subpaths are walked in the candidate's own slots: it keeps x̄'s v_0 … v_l at its
        // start and v_m … v_k at its end, with room for a light and b camera vertices between.
        let kept_light = (d.l + 1) as usize;
        let kept_camera = (k + 1).saturating_sub(d.m);
        let s = kept_light + a;
        let len = s + b + kept_camera;
        y.path.splice_from(xp, kept_light, len, kept_camera);
        let yv = &mut y.path.vertices;
        let light_walked = if kept_light > 0 {
            extend_in_place(
                scene,
                yv,
                kept_light - 1,
                a,
                Toward::Camera,
                TransportMode::Importance,
                rng,
            )
        } else if a > 0 {
            yv[0] = light_endpoint(scene, rng).ok_or(Failure::Failed)?;
            extend_in_place(
                scene,
                yv,
                0,
                a - 1,
                Toward::Camera,
                TransportMode::Importance,
                rng,
            )
        } else {
            true
        };
        if !light_walked {
            return Err(Failure::Failed);
        }
        let camera_walked = if kept_camera > 0 {
            extend_in_place(
                scene,
                yv,
                s + b,
                b,
                Toward::Light,
                TransportMode::Radiance,
                rng,
            )
        } else {
            // A new lens point and b − 1 vertices (b ≥ 1 when the lens was deleted).
            let walked = b.checked_sub(1).ok_or(Failure::Failed)?;
            yv[len - 1] = lens_endpoint(scene, rng).ok_or(Failure::Failed)?;
            extend_in_place(
                scene,
                yv,
                len - 1,
                walked,
                Toward::Light,
                TransportMode::Radiance,
                rng,
            )
        };
        if !camera_walked {
            return Err(Failure::Failed);
        }
        let change = Change {
            l: d.l,
            m: d.m,
            added: n,
            pivot: 0,
        };
        if y.path.closed_at(scene, s).is_some() {
            y.finish_candidate(scene, importance, x, change, s);
        } else {
            y.change = Some(change);
            y.discard();
        }
        Ok(())
    }

    /// `ln T̃` of making `y` from `x` by the change `c` (module docs; `−∞` when no deletion and
    /// addition of this mutation does it).
    pub fn ln_density(&self, x: &PathState, y: &PathState, c: Change) -> f64 {
        let k = x.path.edges();
        let d = Deletion { l: c.l, m: c.m };
        if k < 1 || !d.allowed(k) || c.result_edges(k) != Some(y.path.edges()) {
            return f64::NEG_INFINITY;
        }
        let w = self.move_weight(k, d, c.added, y);
        if w > 0.0 { w.ln() } else { f64::NEG_INFINITY }
    }
}

/// The bidirectional mutation on a scene.
struct BidirectionalMutation<'a> {
    bidirectional: Bidirectional,
    scene: &'a Scene,
    importance: ImportanceKind,
}

impl Mutation for BidirectionalMutation<'_> {
    fn name(&self) -> &'static str {
        REGISTRATION.name
    }

    fn suitability(&self, x: &PathState) -> f64 {
        (x.path.edges() >= 1) as u8 as f64
    }

    fn propose(&self, x: &PathState, rng: &mut ChainRng, y: &mut PathState) -> Result<(), Failure> {
        self.bidirectional
            .propose(self.scene, self.importance, x, rng, y)
    }

    fn ln_density(&self, x: &PathState, y: &PathState, change: Change) -> f64 {
        self.bidirectional.ln_density(x, y, change)
    }
}
