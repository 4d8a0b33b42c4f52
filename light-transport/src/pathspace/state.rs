//! The chain state of path-space MLT: a full path, the scalar importance `I(C*_s)` of each of its
//! strategies (what every mutation's acceptance ratio is made of), and the splat it records.
//!
//! The target of the chains is `I(f(x̄))` in path space. A state records the colour
//! `f / Σ_s p_s` (the balance-heuristic estimate of the path), whose direction is that of `f`:
//! the driver scales it by `b / I(colour)`, so only its direction matters.

use super::mutation::Change;
use super::path::{FullPath, Resume, Walks};
use crate::metropolis::{BootstrapSample, Contribution, ImportanceKind, Recordable};
use crate::scene::Scene;
use crate::spectrum::Rgb;
use std::cell::RefCell;
use std::sync::atomic::{AtomicU16, AtomicU64, Ordering};

/// Most mutations the suitability cache holds (the registry's size is checked against it).
pub const CACHED_MUTATIONS: usize = 16;

/// The suitabilities of the registered mutations for one path, each computed on first use: the
/// mixture asks for every mutation's at every step, and a path's do not change until it is
/// evaluated anew (which empties the cache). Atomics (relaxed) keep states shareable between
/// threads; a value is a deterministic function of the path, so races could only recompute it.
#[derive(Debug, Default)]
pub struct SuitabilityCache {
    known: AtomicU16,
    values: [AtomicU64; CACHED_MUTATIONS],
}

impl Clone for SuitabilityCache {
    fn clone(&self) -> Self {
        let out = Self::default();
        out.known
            .store(self.known.load(Ordering::Relaxed), Ordering::Relaxed);
        for (a, b) in out.values.iter().zip(&self.values) {
            a.store(b.load(Ordering::Relaxed), Ordering::Relaxed);
        }
        out
    }
}

impl SuitabilityCache {
    /// The cached value of mutation `index`, or `compute()` stored.
    pub fn get_or(&self, index: usize, compute: impl FnOnce() -> f64) -> f64 {
        if index >= CACHED_MUTATIONS {
            return compute();
        }
        let bit = 1u16 << index;
        if self.known.load(Ordering::Relaxed) & bit != 0 {
            return f64::from_bits(self.values[index].load(Ordering::Relaxed));
        }
        let v = compute();
        self.values[index].store(v.to_bits(), Ordering::Relaxed);
        self.known.fetch_or(bit, Ordering::Relaxed);
        v
    }

    /// Forget every value.
    pub fn clear(&self) {
        self.known.store(0, Ordering::Relaxed);
    }
}

/// A path-space chain state.
#[derive(Debug, Default)]
pub struct PathState {
    /// The path.
    pub path: FullPath,
    /// `I(C*_s)` for `s = 0 … k` (0 where strategy `s` cannot produce the path).
    pub strategy: Vec<f64>,
    /// Splat and importance.
    pub contribution: Contribution,
    /// How the mutation that proposed this state changed its source path (see
    /// [`super::mutation`]); `None` for states not made by a mutation.
    pub change: Option<Change>,
    /// The registered mutations' suitabilities for this path (filled on use).
    pub suitability: SuitabilityCache,
    /// For a candidate of the new-path mutation: the probability with which the mixture chose
    /// that mutation from the state it was proposed from ([`Recordable::proposal_probability`];
    /// set by [`super::mutations::Mutations::run`], stale on other candidates).
    pub chosen_with: Option<f64>,
    /// The walks of the path's last evaluation: a candidate made from this state resumes them
    /// ([`PathState::finish_candidate`]).
    pub walks: Walks,
}

impl Clone for PathState {
    fn clone(&self) -> Self {
        Self {
            path: self.path.clone(),
            strategy: self.strategy.clone(),
            contribution: self.contribution.clone(),
            change: self.change,
            suitability: self.suitability.clone(),
            chosen_with: self.chosen_with,
            walks: self.walks.clone(),
        }
    }

    /// Field by field, keeping the vectors' storage: charted MLT's moves copy the current state
    /// into the chain's candidate.
    fn clone_from(&mut self, source: &Self) {
        self.path.clone_from(&source.path);
        self.strategy.clone_from(&source.strategy);
        self.contribution
            .splats
            .clone_from(&source.contribution.splats);
        self.contribution.importance = source.contribution.importance;
        self.change = source.change;
        self.suitability.clone_from(&source.suitability);
        self.chosen_with = source.chosen_with;
        self.walks.clone_from(&source.walks);
    }
}

impl Recordable for PathState {
    fn contribution(&self) -> &Contribution {
        &self.contribution
    }

    /// A new path of `k` edges is drawn as a bootstrap sample of length `k` is (strategy
    /// uniform in `0 … k`; [`super::new_path`]), whatever the chance of its length: the bootstrap
    /// weight `(k + 1) I` of group `k − 1`. A new path whose walk failed has no vertices left
    /// but carries its length in its change (`added = k + 1` vertices), and weight 0.
    fn independent_weight(&self) -> BootstrapSample {
        let k = self.drawn_edges();
        BootstrapSample {
            group: k.saturating_sub(1),
            stratum: 0,
            weight: (k + 1) as f64 * self.contribution.importance,
        }
    }

    fn proposal_probability(&self) -> Option<f64> {
        self.chosen_with
    }
}

thread_local! {
    static VALUES: RefCell<Vec<Option<Rgb>>> = const { RefCell::new(Vec::new()) };
}

impl PathState {
    /// The number of edges this path was drawn with: its own, or, for a path whose walk failed
    /// (no vertices left), the length its change records (`added = k + 1` vertices).
    pub fn drawn_edges(&self) -> usize {
        match (self.path.vertices.is_empty(), self.change) {
            (true, Some(c)) => c.added.saturating_sub(1),
            _ => self.path.edges(),
        }
    }

    /// Mark this state as a walk of `k` edges that failed: no vertices, nothing carried, and the
    /// length in its change ([`PathState::drawn_edges`]), so that what is read of it later (the
    /// bootstrap group of a failed independent sample) is the length it was drawn for, not what
    /// the state held before.
    pub fn fail_walk(&mut self, k: usize) {
        self.path.vertices.clear();
        self.discard();
        self.change = Some(Change {
            l: -1,
            m: 0,
            added: k + 1,
            pivot: 0,
        });
    }

    /// Evaluate the path: per-strategy importances and the recorded colour `scale · f / Σ_s p_s`.
    /// Returns whether the path carries light (some strategy has a positive contribution).
    pub fn evaluate(&mut self, scene: &Scene, importance: ImportanceKind, scale: f64) -> bool {
        self.evaluate_resumed(scene, importance, scale, None)
    }

    /// [`PathState::evaluate`] for a candidate made from `source` by `change`: the walks of the
    /// vertices it kept are resumed from the source's ([`FullPath::strategies_resumed`]).
    fn evaluate_resumed(
        &mut self,
        scene: &Scene,
        importance: ImportanceKind,
        scale: f64,
        source: Option<(&PathState, Change)>,
    ) -> bool {
        self.suitability.clear();
        self.strategy.clear();
        self.contribution.splats.clear();
        self.contribution.importance = 0.0;
        let resume = source.map(|(x, c)| Resume {
            walks: &x.walks,
            light: (c.l + 1).max(0) as usize,
            camera: x.path.vertices.len().saturating_sub(c.m),
        });
        let best = VALUES.with(|cell| {
            let values = &mut *cell.borrow_mut();
            self.path
                .strategies_resumed(scene, resume, &mut self.walks, values);
            let mut best: Option<(Rgb, f64)> = None;
            for v in values.iter() {
                let i = v.map_or(0.0, |c| importance.of(c));
                let i = if i.is_finite() && i > 0.0 { i } else { 0.0 };
                self.strategy.push(i);
                if let Some(c) = v
                    && i > 0.0
                    && best.is_none_or(|(_, b)| i > b)
                {
                    best = Some((*c, i));
                }
            }
            best
        });
        let inverse_sum = self.inverse_sum(0, self.strategy.len());
        let (Some((c, i)), Some(raster)) = (best, self.path.raster(scene)) else {
            return false;
        };
        if !(inverse_sum > 0.0) {
            return false;
        }
        // f / Σ_s p_s = C*_u / (I(C*_u) Σ_s 1/I(C*_s)) for any valid u.
        let colour = c * (scale / (i * inverse_sum));
        if !colour.is_finite() {
            return false;
        }
        self.contribution.splats.push((raster, colour));
        self.contribution.importance = importance.of(colour);
        true
    }

    /// Where the path crosses the image (cached by the evaluation; `None` when it carries no
    /// light).
    pub fn raster(&self) -> Option<[f64; 2]> {
        self.contribution.splats.first().map(|s| s.0)
    }

    /// Whether the path carries light (its evaluation found a strategy with a positive
    /// contribution).
    pub fn carries_light(&self) -> bool {
        self.contribution.importance > 0.0
    }

    /// Finish a candidate whose vertices a mutation just placed, made from `source` by `change`:
    /// record `change`, and evaluate it (resuming the source's walks over the vertices it kept)
    /// unless the edge `v_{connection−1} → v_connection` it made by connecting two subpaths is
    /// occluded (then it carries no light and is rejected). `connection = 0`: nothing to test
    /// (the camera walk reached the light itself).
    pub fn finish_candidate(
        &mut self,
        scene: &Scene,
        importance: ImportanceKind,
        source: &PathState,
        change: Change,
        connection: usize,
    ) {
        self.change = Some(change);
        let v = &self.path.vertices;
        let clear = connection == 0
            || (connection < v.len()
                && crate::path::unoccluded(scene, &v[connection - 1], &v[connection]));
        if !clear || !self.evaluate_resumed(scene, importance, 1.0, Some((source, change))) {
            self.discard();
        }
    }

    /// Mark the state as carrying no light (a candidate whose connection is occluded).
    pub fn discard(&mut self) {
        self.walks.forget();
        self.suitability.clear();
        self.strategy.clear();
        self.contribution.splats.clear();
        self.contribution.importance = 0.0;
    }

    /// `Σ 1/I(C*_s)` over strategies `s ∈ [from, to)` that can produce the path (0 if none).
    pub fn inverse_sum(&self, from: usize, to: usize) -> f64 {
        self.strategy
            .get(from..to.min(self.strategy.len()))
            .unwrap_or(&[])
            .iter()
            .filter(|&&i| i > 0.0)
            .map(|&i| 1.0 / i)
            .sum()
    }

    /// The balance-heuristic weight `w_s = p_s / Σ_{s'} p_{s'} = (1/I(C*_s)) / Σ_{s'} 1/I(C*_{s'})`
    /// of strategy `s` (0 when it cannot produce the path).
    pub fn balance_weight(&self, s: usize) -> f64 {
        let i = self.strategy_importance(s);
        let sum = self.inverse_sum(0, self.strategy.len());
        if i > 0.0 && sum > 0.0 {
            1.0 / (i * sum)
        } else {
            0.0
        }
    }

    /// `I(C*_s)` (0 when invalid or out of range).
    pub fn strategy_importance(&self, s: usize) -> f64 {
        self.strategy.get(s).copied().unwrap_or(0.0)
    }
}
