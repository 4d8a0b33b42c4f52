//! The new-path mutation (practical-MLT paper §3.2), an independence sampler that keeps the chain
//! ergodic, and the bootstrap sampler of path-space MLT: a whole new path by one bidirectional
//! strategy — length `k` with probability `P_len(k)`, then `s` uniform in `0 … k` — with
//! `T(ȳ) = P_len(k') / (k' + 1) · Σ_s p_s(ȳ)`. Nothing is kept (record `(−1, k + 1, k' + 1)`),
//! so in the common measure `T̃ = P_len(k') / (k' + 1) · Σ_s 1/I(C*_s(ȳ))`.

use super::mutation::{Change, Mutation, Registration};
use super::state::PathState;
use super::walk::{sample_path, sample_paths_every_length};
use crate::metropolis::ImportanceKind;
use crate::sampler::{IndependentStream, KeyedStream, SampleStream, TECHNIQUE_STREAM, layout};
use crate::scene::Scene;
use mcmc_core::rng::{categorical, uniform, uniform_index};
use mcmc_core::{ChainRng, Failure};

const NEW_PATH_STREAM: u64 = 0x4e57_9a7f;

/// The registration of the new-path mutation.
pub const REGISTRATION: Registration = Registration {
    name: "new-path",
    default_weight: 0.1,
    build: |c| {
        Box::new(NewPathMutation {
            new_path: c.settings.new_path.clone(),
            scene: c.scene,
            importance: c.settings.importance,
        })
    },
};

/// The length distribution of new paths.
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

    /// Only paths of `k` edges (`1 ≤ k ≤ max_edges`).
    pub fn only(k: usize, max_edges: usize) -> Self {
        let mut length_probability = vec![0.0; max_edges.max(k)];
        length_probability[k - 1] = 1.0;
        Self { length_probability }
    }

    /// Lengths from `min_edges` on in proportion to the energy `b_k` of each length, mixed with
    /// 20% uniform over those lengths so that every one stays reachable (shorter lengths get
    /// probability 0: chains that leave them to another estimator).
    pub fn from_energies(energies: &[f64], min_edges: usize) -> Self {
        let n = energies.len().max(1);
        let first = min_edges.clamp(1, n) - 1;
        let allowed = (n - first) as f64;
        let energy = |i: usize, e: f64| {
            if i >= first && e.is_finite() && e > 0.0 {
                e
            } else {
                0.0
            }
        };
        let total: f64 = energies
            .iter()
            .enumerate()
            .map(|(i, &e)| energy(i, e))
            .sum();
        let length_probability = (0..n)
            .map(|i| match energies.get(i) {
                _ if i < first => 0.0,
                Some(&e) if total > 0.0 => 0.8 * energy(i, e) / total + 0.2 / allowed,
                _ => 1.0 / allowed,
            })
            .collect();
        Self { length_probability }
    }

    /// `P_len(k)`.
    pub fn probability(&self, k: usize) -> f64 {
        k.checked_sub(1)
            .and_then(|i| self.length_probability.get(i))
            .copied()
            .unwrap_or(0.0)
    }

    /// A path of `k` edges from the numbers of `stream` (strategy from the technique stream),
    /// evaluated; `false` when it carries no light (a walk that failed leaves the state marked
    /// by [`PathState::fail_walk`]). Deterministic in the stream. Its importance weight within its length is `(k + 1) I(f / Σ_s p_s)`.
    pub fn sample<S: SampleStream>(
        scene: &Scene,
        importance: ImportanceKind,
        k: usize,
        stream: &mut S,
        out: &mut PathState,
    ) -> bool {
        stream.start_stream(TECHNIQUE_STREAM);
        stream.seek(layout::TECHNIQUE);
        let s = uniform_index(stream.next_1d(), k + 1);
        if sample_path(scene, k, s, stream, out).is_none() {
            out.fail_walk(k);
            return false;
        }
        out.evaluate(scene, importance, 1.0)
    }

    /// [`NewPath::sample`] of every length `k` from `min_edges` to `max_edges` on the numbers of
    /// key `seed` ([`KeyedStream`]), the two subpaths walked once for all lengths
    /// ([`sample_paths_every_length`]): `each(k, out)` for every length whose path was made,
    /// evaluated in `out`, bit for bit `NewPath::sample(.., k, &mut KeyedStream::new(seed), ..)`.
    /// The lengths not reported carry no light.
    pub fn sample_every_length(
        scene: &Scene,
        importance: ImportanceKind,
        (min_edges, max_edges): (usize, usize),
        seed: u64,
        out: &mut PathState,
        mut each: impl FnMut(usize, &PathState),
    ) {
        let mut stream = KeyedStream::new(seed);
        stream.start_stream(TECHNIQUE_STREAM);
        stream.seek(layout::TECHNIQUE);
        let u = stream.next_1d();
        let strategy = |k: usize| (k >= min_edges).then(|| uniform_index(u, k + 1));
        sample_paths_every_length(scene, max_edges, strategy, &mut stream, out, |k, state| {
            state.evaluate(scene, importance, 1.0);
            each(k, state);
        });
    }

    /// `ln T̃(ȳ)`: `ln(P_len(k') / (k' + 1) · Σ_s 1/I(C*_s(ȳ)))`.
    pub fn ln_density(&self, y: &PathState) -> f64 {
        let k = y.path.edges();
        let w = self.probability(k) / (k + 1) as f64 * y.inverse_sum(0, k + 1);
        if w > 0.0 { w.ln() } else { f64::NEG_INFINITY }
    }
}

/// The new-path mutation on a scene.
struct NewPathMutation<'a> {
    new_path: NewPath,
    scene: &'a Scene,
    importance: ImportanceKind,
}

impl Mutation for NewPathMutation<'_> {
    fn name(&self) -> &'static str {
        REGISTRATION.name
    }

    fn suitability(&self, _: &PathState) -> f64 {
        1.0
    }

    fn propose(&self, x: &PathState, rng: &mut ChainRng, y: &mut PathState) -> Result<(), Failure> {
        let lengths = &self.new_path.length_probability;
        let k = categorical(lengths, uniform(rng)).map_or(lengths.len(), |i| i + 1);
        // A generator of its own, seeded from the chain's: cheap to set up for the few dozen
        // numbers one new path reads (`FastRng`).
        let mut stream = IndependentStream::new(mcmc_core::rng::fast_stream(
            rand::Rng::next_u64(rng),
            NEW_PATH_STREAM,
        ));
        NewPath::sample(self.scene, self.importance, k, &mut stream, y);
        y.change = Some(Change {
            l: -1,
            m: x.path.edges() + 1,
            added: k + 1,
            pivot: 0,
        });
        Ok(())
    }

    fn ln_density(&self, x: &PathState, y: &PathState, c: Change) -> f64 {
        let whole = Change {
            l: -1,
            m: x.path.edges() + 1,
            added: y.path.edges() + 1,
            pivot: 0,
        };
        if c != whole {
            return f64::NEG_INFINITY;
        }
        self.new_path.ln_density(y)
    }
}

#[cfg(test)]
mod tests {
    use super::NewPath;

    /// Lengths below `min_edges` are never drawn, the others keep the 80/20 mix of energy and
    /// uniform, and the probabilities sum to 1 (also with no energy at all).
    #[test]
    fn lengths_from_energies_skip_the_shorter_ones() {
        let p = NewPath::from_energies(&[5.0, 3.0, 2.0, 0.0, 2.0], 3);
        let expected = [
            0.0,
            0.0,
            0.8 * 0.5 + 0.2 / 3.0,
            0.2 / 3.0,
            0.8 * 0.5 + 0.2 / 3.0,
        ];
        for (k, e) in (1..=5).zip(expected) {
            assert!((p.probability(k) - e).abs() < 1e-15, "P_len({k})");
        }
        let none = NewPath::from_energies(&[0.0; 4], 2);
        assert_eq!(
            none.length_probability,
            [0.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0]
        );
        let all = NewPath::from_energies(&[1.0, 3.0], 1);
        assert_eq!(all.length_probability, [0.8 * 0.25 + 0.1, 0.8 * 0.75 + 0.1]);
    }
}
