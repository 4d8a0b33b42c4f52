//! The one interface of every path-space move (in the spirit of Mitsuba 0.6's `Mutator`): whether
//! it suits a path, how it proposes a new one, and the density of doing so — and how a mutation
//! joins `mcmc_core` as a [`Proposal`].
//!
//! **The record.** A move keeps a prefix `v_0 … v_l` and a suffix `v_m … v_k` of the current path
//! `x̄` and puts `added` new vertices between them; [`Change`] records `(l, m, added)` and knows
//! the reverse move's record. The candidate carries the record of the move that made it
//! ([`super::PathState::change`]), so every mutation can evaluate its density of making that same
//! change — what the combined mixture rule `Σ_k P_k T_k(ȳ|x̄)` needs (seed 002 §4.1, eq. 4).
//!
//! **The common measure.** Paths through specular vertices have no density with respect to area
//! measure, but a mutation's density relative to the path's own importance does: every mutation
//! reports
//!
//! `T̃(ȳ|x̄) = T(ȳ|x̄) · K_L K_C / I(f(ȳ))`,
//!
//! with `K_L`, `K_C` the densities of the kept light-side and camera-side vertices as the light and
//! camera walks would generate them (the same for `x̄ → ȳ` and `ȳ → x̄`, and for every mutation
//! making the same change). Relative to the measure `I(f) dμ / (K_L K_C)` the target is the
//! constant 1, and `T̃` is assembled from the ratios `C*_s = f/p_s` the bidirectional machinery
//! computes exactly, delta factors included — as for the technique charts of charted MLT. Then the
//! Metropolis–Hastings ratio of one mutation is `T̃(x̄|ȳ) / T̃(ȳ|x̄)` and that of a combined mixture
//! `Σ_k P_k(ȳ) T̃_k(x̄|ȳ) / Σ_k P_k(x̄) T̃_k(ȳ|x̄)`.

use super::mutations::MutationSettings;
use super::state::PathState;
use crate::scene::Scene;
use mcmc_core::{ChainRng, Failure, Proposal, Proposed};

/// Which vertices a move changed: `x̄` keeps `v_0 ..= v_l` (none when `l = −1`) and
/// `v_m ..= v_k` (none when `m = k + 1`), and `added` new vertices stand between them in `ȳ`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Change {
    /// Last kept light-side vertex (−1: none).
    pub l: isize,
    /// First kept camera-side vertex of the *source* path (`k + 1`: none).
    pub m: usize,
    /// New vertices.
    pub added: usize,
    /// The vertex `x_b` whose position (and glossy offset) a manifold perturbation moved freely
    /// — the one that tells its strategies apart when glossy vertices on offset manifolds lie
    /// between its ends (Jakob & Marschner 2012, §5.2); 0 for every other move.
    pub pivot: usize,
}

impl Change {
    /// Vertices of the source path that are replaced.
    pub fn removed(&self) -> usize {
        (self.m as isize - self.l - 1) as usize
    }

    /// The record of the reverse move (from the result back to the source).
    pub fn reverse(&self) -> Change {
        Change {
            l: self.l,
            m: (self.l + 1) as usize + self.added,
            added: self.removed(),
            pivot: self.pivot,
        }
    }

    /// Edges of the result of applying this change to a path of `k` edges.
    pub fn result_edges(&self, k: usize) -> Option<usize> {
        (k + 1 + self.added).checked_sub(self.removed() + 1)
    }
}

/// A path-space mutation.
///
/// Implementations hold the scene and their settings, and must be exact in this sense: for every
/// `x̄` and every candidate `ȳ` with record `c` that [`Mutation::propose`] can produce,
/// [`Mutation::ln_density`] returns `ln T̃(ȳ, c | x̄)` in the common measure (module docs), and
/// `−∞` for pairs it cannot produce. The acceptance is then built from `ln_density` alone, in
/// both directions.
pub trait Mutation: Send + Sync {
    /// The name used on the command line and in statistics.
    fn name(&self) -> &'static str;

    /// 1 when the mutation can move `x̄`, 0 when it does not apply (the path lacks the vertices it
    /// needs). Suitability-weighted selection never chooses a mutation of suitability 0.
    fn suitability(&self, x: &PathState) -> f64;

    /// Draw a candidate into `y`, evaluated, with its record in `y.change`. A candidate that
    /// carries no light (an occluded connection, a zero BSDF) is returned as such (it is
    /// rejected); `Err` when no candidate could be made.
    fn propose(&self, x: &PathState, rng: &mut ChainRng, y: &mut PathState) -> Result<(), Failure>;

    /// `ln T̃(ȳ, change | x̄)` (module docs); `−∞` when this mutation cannot make `ȳ` from `x̄`
    /// with that change.
    fn ln_density(&self, x: &PathState, y: &PathState, change: Change) -> f64;

    /// The log acceptance ratio of a candidate this mutation made:
    /// `ln T̃(x̄|ȳ) − ln T̃(ȳ|x̄)` (`−∞` when `ȳ` carries no light or cannot be reversed).
    fn ln_ratio(&self, x: &PathState, y: &PathState) -> f64 {
        let Some(c) = y.change else {
            return f64::NEG_INFINITY;
        };
        if !y.carries_light() {
            return f64::NEG_INFINITY;
        }
        let fwd = self.ln_density(x, y, c);
        if !(fwd > f64::NEG_INFINITY) {
            return f64::NEG_INFINITY;
        }
        self.ln_density(y, x, c.reverse()) - fwd
    }

    /// Propose and return the log acceptance ratio (a convenience for tests and single-mutation
    /// chains).
    fn propose_ratio(
        &self,
        x: &PathState,
        rng: &mut ChainRng,
        y: &mut PathState,
    ) -> Result<f64, Failure> {
        self.propose(x, rng, y)?;
        Ok(self.ln_ratio(x, y))
    }
}

/// What a mutation is built from (it keeps the scene and copies the settings it needs).
#[derive(Clone, Copy)]
pub struct MutationContext<'a, 's> {
    /// The scene.
    pub scene: &'a Scene,
    /// Settings of every mutation (path length limit, importance, offsets, new-path lengths).
    pub settings: &'s MutationSettings,
    /// Where mutations that walk specular manifolds add their walk statistics (`None`: nowhere).
    pub walks: Option<&'a std::sync::Mutex<crate::manifold::WalkStats>>,
}

/// A registered mutation: its name, its default selection weight in path-space MLT, and its
/// constructor. `super::mutations::REGISTRY` lists them; adding a mutation is one file and one
/// line there.
#[derive(Clone, Copy)]
pub struct Registration {
    /// Name (command line, statistics).
    pub name: &'static str,
    /// Default weight in path-space MLT's mixture.
    pub default_weight: f64,
    /// Build the mutation.
    pub build: for<'a, 's> fn(&MutationContext<'a, 's>) -> Box<dyn Mutation + 'a>,
}

impl std::fmt::Debug for Registration {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Registration")
            .field("name", &self.name)
            .field("default_weight", &self.default_weight)
            .finish()
    }
}

/// A mutation as an `mcmc_core` proposal on path states, whose target is the constant 1 in the
/// common measure ([`super::mutations::ln_target`]).
pub struct MutationProposal<'a> {
    /// The mutation.
    pub mutation: Box<dyn Mutation + 'a>,
    /// Its index in [`super::mutations::REGISTRY`], under which states cache its suitability
    /// (`None`: no caching).
    pub index: Option<usize>,
}

impl<'a> MutationProposal<'a> {
    /// A mutation without suitability caching.
    pub fn new(mutation: Box<dyn Mutation + 'a>) -> Self {
        Self {
            mutation,
            index: None,
        }
    }
}

impl Proposal<PathState> for MutationProposal<'_> {
    fn propose(&self, x: &PathState, y: &mut PathState, rng: &mut ChainRng) -> Proposed {
        y.change = None;
        match self.mutation.propose(x, rng, y) {
            Err(why) => Proposed::failed(0, why),
            Ok(()) => Proposed::with_ratio(self.mutation.ln_ratio(x, y)),
        }
    }

    fn ln_pair_densities(&self, x: &PathState, y: &PathState) -> Option<(f64, f64)> {
        let c = y.change?;
        if !y.carries_light() {
            return Some((f64::NEG_INFINITY, f64::NEG_INFINITY));
        }
        let m = &self.mutation;
        Some((m.ln_density(x, y, c), m.ln_density(y, x, c.reverse())))
    }

    fn suitability(&self, x: &PathState) -> f64 {
        match self.index {
            Some(i) => x.suitability.get_or(i, || self.mutation.suitability(x)),
            None => self.mutation.suitability(x),
        }
    }

    fn kinds(&self) -> Vec<String> {
        vec![self.mutation.name().to_string()]
    }

    fn kind_count(&self) -> usize {
        1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_change_reversed_twice_is_itself() {
        for c in [
            Change {
                l: -1,
                m: 4,
                added: 5,
                pivot: 0,
            },
            Change {
                l: 1,
                m: 3,
                added: 0,
                pivot: 0,
            },
            Change {
                l: 0,
                m: 2,
                added: 3,
                pivot: 0,
            },
        ] {
            assert_eq!(c.reverse().reverse(), c);
            let k = 3;
            let k2 = c.result_edges(k).unwrap();
            assert_eq!(c.reverse().result_edges(k2), Some(k));
        }
    }
}
