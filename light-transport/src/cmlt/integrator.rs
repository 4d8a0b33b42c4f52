//! Charted Metropolis light transport (charted-MLT paper, Algorithms 1–2) on the shared
//! Metropolis driver.
//!
//! Chains are grouped by path length `k`. A state is `(s, u, x̄)`: the technique chart `s` of
//! length `k`, its primary numbers `u`, and the path `x̄ = T_s(u)`. The joint target is the
//! weighted one (eq. 16), `π_s(u) = f(x̄) / Σ_{s'} p_{s'}(x̄)` — the same value in every chart at
//! the same path (eq. 17) — with pseudo-prior weights `c_s = 1`, so the path marginal is `f` and,
//! given the path, the chart is distributed by the balance weights `w_s = p_s/Σ p` and `u` by the
//! chart's exact inverse. Moves (each preserves the joint target; see `mcmc_charts::moves` for the
//! derivations):
//!
//! * **small / large step** in the current chart: Kelemen's exponential (or Gaussian) offsets of
//!   every coordinate, or a uniform `u`; accepted with `π_s(u')/π_s(u)`.
//! * **chart swap** by serial tempering (on average one every `swap_every` mutations, default 16
//!   as in the paper): propose `s'` with probability `q(s')` proportional to the technique's energy
//!   (a deterministic pilot, mixed with 10% uniform), keep `x̄`, draw `u' ~ κ_{s'}(·|x̄)` (only
//!   the vertices whose numbers differ between the two charts are inverted); accept
//!   with `min(1, p_{s'}(x̄) q(s) / (p_s(x̄) q(s')))` — no evaluation of `f`.
//! * **IPSM** (inverse primary-space perturbation, optional): in a uniformly chosen other chart
//!   `j`, draw `u_j ~ κ_j(·|x̄)`, take a small step, map to `ȳ`; the path marginal `f` is preserved
//!   by accepting with `I(C*_j(ȳ)) / I(C*_j(x̄))` (eq. 26), after which `(s, u)` is redrawn from its
//!   conditional given `ȳ` (chart by balance weight, numbers by the exact inverse).
//! * **path-space mutations** (optional, the identity chart): any mutation of
//!   [`crate::pathspace`] moves `x̄` with target `f`; `(s, u)` is then redrawn given the new path.
//!
//! The recorded colour is the path's balance-heuristic value `f / Σ p` (importance `π_s(u)`), as
//! for path-space MLT.

use super::technique::TechniqueChart;
use crate::metropolis::{Contribution, ImportanceKind, Method, Recordable};
use crate::pathspace::{
    MutationKind, MutationProbabilities, Mutations, NewPath, PathState, PerturbationSettings,
};
use crate::scene::Scene;
use crate::{Error, Result};
use mcmc_charts::Chart;
use mcmc_core::kernel::Observer;
use mcmc_core::proposals::SmallStep;
use mcmc_core::rng::{categorical, stream, uniform};
use mcmc_core::{Chain, ChainRng, Failure};

/// A CMLT chain state.
#[derive(Clone, Debug, Default)]
pub struct CmltState {
    /// Path length (edges).
    pub k: usize,
    /// The current technique chart: light vertices `s`.
    pub chart: usize,
    /// Its primary numbers.
    pub u: Vec<f64>,
    /// The path and its strategies; its contribution is the recorded splat.
    pub x: PathState,
    /// Whether the contribution still carries the bootstrap's factor `k + 1`.
    pub bootstrap_scaled: bool,
}

impl Recordable for CmltState {
    fn contribution(&self) -> &Contribution {
        &self.x.contribution
    }
}

/// How chart swaps are made.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SwapKind {
    /// Serial tempering: a chain moves its own path to another chart (`q(s')` by technique
    /// energy; accepted with `p_{s'} q(s) / (p_s q(s'))`).
    #[default]
    SerialTempering,
    /// Replica exchange: every chain keeps the chart it was seeded in; chains of the same path
    /// length in different charts exchange paths (accepted with eq. 24). See [`super::replica`].
    ReplicaExchange,
}

/// CMLT settings (validated by [`Cmlt::new`]).
#[derive(Clone, Debug)]
pub struct CmltSettings {
    /// Longest path (edges); chains exist for every length `1 ..= max_edges`.
    pub max_edges: usize,
    /// Colour to scalar.
    pub importance: ImportanceKind,
    /// Small-step kernel in primary space.
    pub small_step: SmallStep,
    /// Probability of a large step among in-chart moves.
    pub large_step: f64,
    /// Serial tempering or replica exchange.
    pub swaps: SwapKind,
    /// Serial tempering: mean mutations between chart swaps. Replica exchange: mutations per
    /// chain between exchange rounds (rounded to a whole number). 0: never swap.
    pub swap_every: f64,
    /// Probability of an inverse primary-space perturbation per mutation.
    pub ipsm: f64,
    /// Probability of a path-space mutation per mutation (the identity chart).
    pub pathspace: f64,
    /// Mix of path-space mutations used when `pathspace > 0`.
    pub probabilities: MutationProbabilities,
    /// Their perturbation offsets.
    pub perturbation: PerturbationSettings,
    /// Uniform samples per technique chart in the pilot estimating technique energies.
    pub pilot: usize,
}

impl Default for CmltSettings {
    /// The paper's configuration: serial-tempering swaps every 16 mutations, 30% large steps,
    /// paths of up to 8 edges.
    fn default() -> Self {
        Self {
            max_edges: 8,
            importance: ImportanceKind::Luminance,
            small_step: SmallStep::default(),
            large_step: 0.3,
            swaps: SwapKind::SerialTempering,
            swap_every: 16.0,
            ipsm: 0.0,
            pathspace: 0.0,
            probabilities: MutationProbabilities::default(),
            perturbation: PerturbationSettings::default(),
            pilot: 1000,
        }
    }
}

/// The CMLT integrator: settings, the swap proposal from the pilot, the path-space mutations.
#[derive(Clone, Debug)]
pub struct Cmlt {
    /// Settings.
    pub settings: CmltSettings,
    /// Swap proposal `q(s | k)`, index `[k − 1][s]`.
    pub swap_proposal: Vec<Vec<f64>>,
    /// Path-space mutations (from the settings).
    pub mutations: Mutations,
}

/// Move kinds, in statistics order.
pub const KINDS: [&str; 4] = ["small step", "large step", "chart swap", "ipsm"];
pub(super) const SMALL: usize = 0;
pub(super) const LARGE: usize = 1;
pub(super) const SWAP: usize = 2;
pub(super) const IPSM: usize = 3;
pub(super) const PATHSPACE: usize = 4;
const PILOT: u64 = 0xC417;

impl Cmlt {
    /// CMLT on `scene`: validates the settings and runs the pilot that estimates the energy of
    /// every technique (`settings.pilot` uniform samples per chart).
    pub fn new(scene: &Scene, settings: CmltSettings) -> Result<Self> {
        let bad = |name: &str, reason: String| Error::InvalidParameter {
            name: name.into(),
            reason,
        };
        let CmltSettings {
            max_edges,
            importance,
            small_step,
            large_step,
            swap_every,
            ipsm,
            pathspace,
            ..
        } = settings;
        small_step
            .validate()
            .map_err(|e| bad("small step", e.to_string()))?;
        if max_edges == 0 {
            return Err(bad(
                "max depth",
                "CMLT needs paths of at least one edge".into(),
            ));
        }
        for (name, p) in [
            ("large step", large_step),
            ("ipsm", ipsm),
            ("pathspace", pathspace),
        ] {
            if !(0.0..=1.0).contains(&p) {
                return Err(bad(name, format!("must be a probability, got {p}")));
            }
        }
        if ipsm + pathspace > 1.0 {
            return Err(bad(
                "ipsm + pathspace",
                format!("probabilities sum to {} > 1", ipsm + pathspace),
            ));
        }
        if !(swap_every == 0.0 || (swap_every >= 1.0 && swap_every.is_finite())) {
            return Err(bad(
                "swap every",
                format!("must be 0 (no swaps) or at least 1, got {swap_every}"),
            ));
        }
        let mutations = Mutations {
            max_edges,
            importance,
            probabilities: settings.probabilities,
            perturbation: settings.perturbation,
        };
        if pathspace > 0.0 {
            mutations.probabilities.validate()?;
            mutations.perturbation.validate()?;
        }
        let pilot = settings.pilot.max(1);
        let swap_proposal = (1..=max_edges)
            .map(|k| {
                let energy: Vec<f64> = (0..=k)
                    .map(|s| {
                        let Some(chart) = TechniqueChart::new(scene, k, s, importance) else {
                            return 0.0;
                        };
                        let mut rng = stream(PILOT ^ (k as u64) << 8 ^ s as u64, 0);
                        let mut u = vec![0.0; chart.dim()];
                        let mut x = PathState::default();
                        (0..pilot)
                            .map(|_| {
                                u.iter_mut().for_each(|v| *v = uniform(&mut rng));
                                if chart.forward(&u, &mut x) {
                                    x.contribution.importance
                                } else {
                                    0.0
                                }
                            })
                            .sum::<f64>()
                            / pilot as f64
                    })
                    .collect();
                let total: f64 = energy.iter().sum();
                let n = energy.len() as f64;
                energy
                    .iter()
                    .map(|e| {
                        if total > 0.0 {
                            0.9 * e / total + 0.1 / n
                        } else {
                            1.0 / n
                        }
                    })
                    .collect()
            })
            .collect();
        Ok(Self {
            settings,
            swap_proposal,
            mutations,
        })
    }

    pub(super) fn chart<'a>(
        &self,
        scene: &'a Scene,
        k: usize,
        s: usize,
    ) -> Option<TechniqueChart<'a>> {
        TechniqueChart::new(scene, k, s, self.settings.importance)
    }

    /// Put `state` in chart `s` at its path: `u` from the exact inverse.
    fn reparameterise(
        &self,
        scene: &Scene,
        state: &mut CmltState,
        s: usize,
        rng: &mut ChainRng,
    ) -> bool {
        let Some(chart) = self.chart(scene, state.k, s) else {
            return false;
        };
        state.u.resize(chart.dim(), 0.0);
        if !chart.invert(&state.x, &mut state.u, rng) {
            return false;
        }
        state.chart = s;
        true
    }

    /// Redraw `(s, u)` given the path: `s` by balance weight `p_s/Σp ∝ 1/I(C*_s)`, `u` by the
    /// inverse.
    fn refresh(&self, scene: &Scene, state: &mut CmltState, rng: &mut ChainRng) -> bool {
        let weights: Vec<f64> = (0..=state.k).map(|s| state.x.balance_weight(s)).collect();
        categorical(&weights, uniform(rng))
            .is_some_and(|s| self.reparameterise(scene, state, s, rng))
    }

    /// After a move of the path from `x` to `y.x` that preserves the path marginal `f`: put
    /// `(s, u)` at the new path. Serial tempering redraws the chart by balance weight (Gibbs, no
    /// ratio). Under replica exchange the chain keeps its chart `chart`, whose path-space target
    /// is `f w_chart`: the numbers come from the inverse and the returned log ratio
    /// `ln w_chart(ȳ) − ln w_chart(x̄)` joins the acceptance. `None`: reject.
    fn settle(
        &self,
        scene: &Scene,
        y: &mut CmltState,
        chart: usize,
        x: &PathState,
        rng: &mut ChainRng,
    ) -> Option<f64> {
        match self.settings.swaps {
            SwapKind::SerialTempering => self.refresh(scene, y, rng).then_some(0.0),
            SwapKind::ReplicaExchange => {
                let (wy, wx) = (y.x.balance_weight(chart), x.balance_weight(chart));
                (wy > 0.0 && wx > 0.0 && self.reparameterise(scene, y, chart, rng))
                    .then(|| wy.ln() - wx.ln())
            }
        }
    }

    fn ln_target(state: &CmltState) -> f64 {
        let i = state.x.contribution.importance;
        if i > 0.0 && i.is_finite() {
            i.ln()
        } else {
            f64::NEG_INFINITY
        }
    }

    /// One move of this kind (see the module docs); public so that schedules can be composed.
    pub fn in_chart<O: Observer<CmltState>>(
        &self,
        scene: &Scene,
        chain: &mut Chain<CmltState>,
        rng: &mut ChainRng,
        observer: &mut O,
    ) {
        let large = uniform(rng) < self.settings.large_step;
        let kind = if large { LARGE } else { SMALL };
        let (k, s) = (chain.state.k, chain.state.chart);
        let Some(chart) = self.chart(scene, k, s) else {
            chain.fail(kind, Failure::NotApplicable, observer);
            return;
        };
        let y = &mut chain.candidate;
        y.k = k;
        y.chart = s;
        y.u.resize(chain.state.u.len(), 0.0);
        for (b, &a) in y.u.iter_mut().zip(&chain.state.u) {
            *b = if large {
                uniform(rng)
            } else {
                self.settings.small_step.perturb(a, rng)
            };
        }
        let ln = if chart.forward(&y.u, &mut y.x) {
            Self::ln_target(y)
        } else {
            f64::NEG_INFINITY
        };
        chain.decide(ln, 0.0, kind, rng, observer);
    }

    /// One move of this kind (see the module docs); public so that schedules can be composed.
    pub fn swap<O: Observer<CmltState>>(
        &self,
        scene: &Scene,
        chain: &mut Chain<CmltState>,
        rng: &mut ChainRng,
        observer: &mut O,
    ) {
        let (k, i) = (chain.state.k, chain.state.chart);
        let q = &self.swap_proposal[k - 1];
        let j = categorical(q, uniform(rng)).unwrap_or(q.len() - 1);
        let (pi, pj) = (
            chain.state.x.strategy_importance(i),
            chain.state.x.strategy_importance(j),
        );
        if !(pj > 0.0) {
            // x̄ is outside the image of chart j: p_j(x̄) = 0, the swap is rejected.
            chain.fail(SWAP, Failure::NotApplicable, observer);
            return;
        }
        let (Some(from), Some(to)) = (self.chart(scene, k, i), self.chart(scene, k, j)) else {
            chain.fail(SWAP, Failure::NotApplicable, observer);
            return;
        };
        chain.candidate.clone_from(&chain.state);
        let y = &mut chain.candidate;
        y.u.resize(to.dim(), 0.0);
        // Only the vertices whose numbers differ between the charts are inverted (§6.1).
        if !to.reparameterise(&chain.state.x, &from, &chain.state.u, &mut y.u, rng) {
            chain.fail(SWAP, Failure::Failed, observer);
            return;
        }
        y.chart = j;
        // p_j/p_i = I(C*_i)/I(C*_j); the target value is the same in both charts (eq. 17).
        let ln_ratio = pi.ln() - pj.ln() + q[i].ln() - q[j].ln();
        let ln = chain.ln_density;
        chain.decide(ln, ln_ratio, SWAP, rng, observer);
    }

    /// One move of this kind (see the module docs); public so that schedules can be composed.
    pub fn ipsm<O: Observer<CmltState>>(
        &self,
        scene: &Scene,
        chain: &mut Chain<CmltState>,
        rng: &mut ChainRng,
        observer: &mut O,
    ) {
        let k = chain.state.k;
        let j = ((uniform(rng) * (k + 1) as f64) as usize).min(k);
        let x = &chain.state.x;
        let ix = x.strategy_importance(j);
        let Some(chart) = self.chart(scene, k, j) else {
            chain.fail(IPSM, Failure::NotApplicable, observer);
            return;
        };
        if !(ix > 0.0) {
            chain.fail(IPSM, Failure::NotApplicable, observer);
            return;
        }
        let mut u = vec![0.0; chart.dim()];
        if !chart.invert(x, &mut u, rng) {
            chain.fail(IPSM, Failure::Failed, observer);
            return;
        }
        u.iter_mut()
            .for_each(|v| *v = self.settings.small_step.perturb(*v, rng));
        let y = &mut chain.candidate;
        y.k = k;
        if !chart.forward(&u, &mut y.x) {
            let ln = f64::NEG_INFINITY;
            chain.decide(ln, 0.0, IPSM, rng, observer);
            return;
        }
        let iy = y.x.strategy_importance(j);
        y.chart = j;
        y.u = u;
        let settled = if iy > 0.0 {
            self.settle(scene, y, chain.state.chart, &chain.state.x, rng)
        } else {
            None
        };
        let Some(ln_w) = settled else {
            chain.decide(f64::NEG_INFINITY, 0.0, IPSM, rng, observer);
            return;
        };
        // Path marginal f: a = I(C*_j(ȳ))/I(C*_j(x̄)) (times w_s(ȳ)/w_s(x̄) when the chart is
        // kept); the chain's own density follows ȳ.
        let ln_y = Self::ln_target(y);
        let ln_ratio = iy.ln() - ix.ln() + ln_w - (ln_y - chain.ln_density);
        chain.decide(ln_y, ln_ratio, IPSM, rng, observer);
    }

    /// One move of this kind (see the module docs); public so that schedules can be composed.
    pub fn path_space<O: Observer<CmltState>>(
        &self,
        scene: &Scene,
        chain: &mut Chain<CmltState>,
        rng: &mut ChainRng,
        observer: &mut O,
    ) {
        let kind = self.mutations.probabilities.pick(rng);
        let slot = PATHSPACE + kind as usize;
        let k = chain.state.k;
        // Chains keep their path length: the new-path mutation draws length k only.
        let mut lengths = vec![0.0; self.settings.max_edges];
        lengths[k - 1] = 1.0;
        let np = NewPath {
            length_probability: lengths,
        };
        let y = &mut chain.candidate;
        match self
            .mutations
            .propose(scene, kind, &np, &chain.state.x, rng, &mut y.x)
        {
            Ok(r) => {
                if y.x.path.edges() != k {
                    chain.decide(f64::NEG_INFINITY, 0.0, slot, rng, observer);
                    return;
                }
                y.k = k;
                let Some(ln_w) = self.settle(scene, y, chain.state.chart, &chain.state.x, rng)
                else {
                    chain.decide(f64::NEG_INFINITY, 0.0, slot, rng, observer);
                    return;
                };
                let ln_y = Self::ln_target(y);
                let ln_ratio = r + ln_w - (ln_y - chain.ln_density);
                chain.decide(ln_y, ln_ratio, slot, rng, observer);
            }
            Err(why) => chain.fail(slot, why, observer),
        }
    }
}

impl Method for Cmlt {
    type State = CmltState;

    fn groups(&self) -> usize {
        self.settings.max_edges
    }

    fn independent(&self, scene: &Scene, g: usize, seed: u64) -> CmltState {
        let k = g + 1;
        let mut rng = stream(seed, 0);
        let s = ((uniform(&mut rng) * (k + 1) as f64) as usize).min(k);
        let mut state = CmltState {
            k,
            chart: s,
            ..Default::default()
        };
        let Some(chart) = self.chart(scene, k, s) else {
            return state;
        };
        state.u = (0..chart.dim()).map(|_| uniform(&mut rng)).collect();
        if chart.forward(&state.u, &mut state.x) {
            // Bootstrap weight (k + 1) π_s(u): the chart was chosen with probability 1/(k + 1).
            let c = &mut state.x.contribution;
            c.importance *= (k + 1) as f64;
            for (_, v) in &mut c.splats {
                *v *= (k + 1) as f64;
            }
            state.bootstrap_scaled = true;
        } else {
            state.x = PathState::default();
        }
        state
    }

    fn mutate<O: Observer<CmltState>>(
        &self,
        scene: &Scene,
        chain: &mut Chain<CmltState>,
        n: u64,
        rng: &mut ChainRng,
        observer: &mut O,
    ) {
        // The chain's density is π_s(u), without the bootstrap's factor k + 1.
        let state = &mut chain.state;
        if state.bootstrap_scaled {
            let f = 1.0 / (state.k + 1) as f64;
            let c = &mut state.x.contribution;
            c.importance *= f;
            for (_, v) in &mut c.splats {
                *v *= f;
            }
            state.bootstrap_scaled = false;
        }
        chain.ln_density = Self::ln_target(&chain.state);
        let st = &self.settings;
        // Replica exchange happens between chains, in `exchange` (below).
        let p_swap = if st.swap_every > 0.0 && st.swaps == SwapKind::SerialTempering {
            1.0 / st.swap_every
        } else {
            0.0
        };
        for _ in 0..n {
            let v = uniform(rng);
            if v < p_swap {
                self.swap(scene, chain, rng, observer);
            } else if v < p_swap + (1.0 - p_swap) * st.ipsm {
                self.ipsm(scene, chain, rng, observer);
            } else if v < p_swap + (1.0 - p_swap) * (st.ipsm + st.pathspace) {
                self.path_space(scene, chain, rng, observer);
            } else {
                self.in_chart(scene, chain, rng, observer);
            }
        }
    }

    fn exchange_every(&self) -> Option<u64> {
        let st = &self.settings;
        (st.swaps == SwapKind::ReplicaExchange && st.swap_every > 0.0)
            .then(|| st.swap_every.round().max(1.0) as u64)
    }

    fn exchange(&self, scene: &Scene, chains: &mut [Chain<CmltState>], rng: &mut ChainRng) {
        self.exchange_round(scene, chains, rng);
    }

    fn kinds(&self) -> Vec<String> {
        KINDS
            .iter()
            .map(|&s| match (s, self.settings.swaps) {
                ("chart swap", SwapKind::ReplicaExchange) => "replica exchange".to_string(),
                _ => s.to_string(),
            })
            .chain(
                MutationKind::ALL
                    .iter()
                    .map(|k| format!("path: {}", k.name())),
            )
            .collect()
    }
}
