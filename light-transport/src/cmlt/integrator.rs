//! Charted Metropolis light transport (charted-MLT paper, Algorithms 1–2) on the shared
//! Metropolis driver, with the moves of `mcmc-charts`.
//!
//! Chains are grouped by path length `k`. A state is an `mcmc_charts` [`ChartState`]: the
//! technique chart `s` of length `k` ([`TechniqueChart`]), its primary numbers `u`, and the path
//! `x̄ = T_s(u)`. The charts report densities in the measure `I(f) dμ`, in which the integrand is
//! the constant 1 ([`unit_integrand`]); the family is `mcmc_charts`' weighted target (eq. 16),
//! `π_s(u) = f(x̄) / Σ_{s'} p_{s'}(x̄)` — the same value in every chart at the same path (eq. 17)
//! — with pseudo-priors `c_s = 1`, so the path marginal is `f` and, given the path, the chart is
//! distributed by the balance weights `w_s = p_s/Σ p` and `u` by the chart's exact inverse. Every
//! step is one Metropolis–Hastings step of the [`Joint`] target with a mixture of `mcmc-charts`
//! moves (their derivations are in `mcmc_charts::moves`):
//!
//! * **small / large step** in the current chart ([`InChart`]): Kelemen's exponential (or
//!   Gaussian) offsets of every coordinate, or a uniform `u`.
//! * **chart swap** by serial tempering ([`ChartSwap`], on average one every `swap_every`
//!   mutations, default 16 as in the paper): `s'` proposed with probability `q(s')` proportional
//!   to the technique's energy (a deterministic pilot, mixed with 10% uniform), `u' ~ κ_{s'}(·|x̄)`
//!   by the charts' partial inverse (only the vertices whose numbers differ are inverted, §6.1);
//!   accepted with `min(1, p_{s'}(x̄) q(s) / (p_s(x̄) q(s')))` — no evaluation of `f`.
//! * **IPSM** (inverse primary-space perturbation, optional; [`InversePerturbation`] through a
//!   uniformly chosen chart): the path moves by a small step in another chart's numbers, accepted
//!   for the path marginal with `I(C*_j(ȳ)) / I(C*_j(x̄))` (eq. 26), then `(s, u)` is redrawn from
//!   its conditional given `ȳ` ([`Refresh::Gibbs`]).
//! * **path-space mutations** (optional; [`PointMove`]): the mixture of
//!   [`crate::pathspace::mutations`] moves `x̄` with target `f`, then `(s, u)` is redrawn.
//!
//! With replica exchange instead of serial tempering ([`super::replica`]) every chain keeps its
//! chart: no swap move, and IPSM and path-space moves keep the chart ([`Refresh::KeepChart`],
//! acceptance × `w_s(ȳ)/w_s(x̄)`).
//!
//! The recorded colour is the path's balance-heuristic value `f / Σ p` (importance `π_s(u)`), as
//! for path-space MLT.
//!
//! The bootstrap's sample `i` of every length holds one key's numbers ([`KeyedStream`], in the
//! chart its technique number picks), so the forward maps of all lengths walk the first vertices
//! of one pair of subpaths, which are walked once ([`Method::independent_all`]).
//!
//! With direct lighting rendered apart ([`crate::metropolis::SeparateDirect`]) the lengths of at
//! most two edges get no bootstrap weight, hence no chains ([`CmltSettings::min_edges`]).

use super::density_estimation::{DensityEstimation, LightVertices, MergeCounters, MergeSampler};
use super::light_vertex_map::LightVertexMap;
use super::technique::{TechniqueChart, unit_integrand};
use crate::metropolis::{
    BootstrapSample, DIRECT_EDGES, DirectApart, ImportanceKind, Method, Recordable,
};
use crate::pathspace::walk::sample_paths_every_length;
use crate::pathspace::{
    MutationProbabilities, Mutations, NewPath, PathState, PerturbationSettings,
};
use crate::sampler::{KeyedStream, TECHNIQUE_STREAM, layout};
use crate::scene::Scene;
use crate::{Error, Result};
use mcmc_charts::moves::{
    ChartIndependence, ChartSwap, InChart, InversePerturbation, PointMove, Refresh,
};
use mcmc_charts::{Atlas, Chart, ChartState, ChartedTarget, Joint, TargetKind};
use mcmc_core::kernel::Observer;
use mcmc_core::proposals::{CubeWalk, Independence, Mixture, MixtureRule, SmallStep, UniformCube};
use mcmc_core::rng::{stream, uniform, uniform_index};
use mcmc_core::tempering::LevelProposal;
use mcmc_core::{Chain, ChainRng, Family, Kernel, MetropolisHastings, Proposal, Target};
use std::sync::atomic::Ordering;
use std::sync::{Arc, RwLock};

thread_local! {
    /// The state the bootstrap samples of a thread are evaluated in (its vectors reused).
    static STATE: std::cell::RefCell<CmltState> =
        std::cell::RefCell::new(CmltState::in_chart(0, Vec::new()));
    /// The path the bootstrap's walks of a thread make (its vertices reused).
    static PATH: std::cell::RefCell<PathState> = std::cell::RefCell::new(PathState::default());
}

/// A CMLT chain state: technique chart, numbers and path.
pub type CmltState = ChartState<PathState>;

impl Recordable for CmltState {
    fn contribution(&self) -> &crate::metropolis::Contribution {
        &self.x.contribution
    }

    /// Path length − 1: the length the candidate was drawn for ([`PathState::drawn_edges`]; a
    /// failed technique walk records its chart's), never a fragment a failed or rejected move
    /// left behind.
    fn group(&self) -> usize {
        self.x.drawn_edges().saturating_sub(1)
    }

    /// A large step's candidate: coordinates uniform in the chain's chart `s`, so a sample of
    /// the bootstrap's stratum `s` (`Cmlt::sample_independent`), of bootstrap weight
    /// `(k + 1) π_s(u)` (0 where the chart's map failed).
    fn independent_weight(&self) -> BootstrapSample {
        let k = self.x.path.edges();
        let valid = self.valid && self.fresh;
        BootstrapSample {
            group: self.group(),
            stratum: self.chart,
            weight: if valid {
                (k + 1) as f64 * self.x.contribution.importance
            } else {
                0.0
            },
        }
    }
}

/// The integrand of the technique charts, as a function pointer (one type for every target).
pub type UnitIntegrand = fn(&PathState) -> f64;

/// The technique charts of one path length.
pub type TechniqueAtlas<'a> = Atlas<PathState, TechniqueChart<'a>>;

/// The weighted targets over a [`TechniqueAtlas`].
pub type TechniqueTarget<'a> = ChartedTarget<'a, PathState, UnitIntegrand, TechniqueChart<'a>>;

/// The joint target of a chain over technique charts.
pub type TechniqueJoint<'a> = Joint<'a, PathState, UnitIntegrand, TechniqueChart<'a>>;

/// A move of a CMLT chain.
pub type CmltMove<'a> = Box<dyn Proposal<CmltState> + Send + Sync + 'a>;

/// The kernel of a CMLT chain.
pub type CmltKernel<'a> = MetropolisHastings<&'a TechniqueJoint<'a>, Mixture<'a, CmltState>>;

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
    /// Longest path (edges); chains exist for every length `min_edges ..= max_edges`.
    pub max_edges: usize,
    /// Shortest path (edges) the chains sample: 1, or 3 when direct lighting is rendered apart
    /// ([`crate::metropolis::SeparateDirect`]); shorter lengths get no bootstrap weight.
    pub min_edges: usize,
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
    /// Probability of a path-space mutation per mutation.
    pub pathspace: f64,
    /// The path-space mutations used when `pathspace > 0` (their weights, offsets, mixture rule
    /// and selection; length limit and importance are CMLT's).
    pub mutations: Mutations,
    /// Uniform samples per technique chart in the pilot estimating technique energies.
    pub pilot: usize,
    /// Density estimation as an independence sampler (§5.3; off when its probability is 0).
    pub density_estimation: DensityEstimation,
}

impl Default for CmltSettings {
    /// The paper's configuration: serial-tempering swaps every 16 mutations, 30% large steps,
    /// paths of up to 8 edges.
    fn default() -> Self {
        Self {
            max_edges: 8,
            min_edges: 1,
            importance: ImportanceKind::Luminance,
            small_step: SmallStep::default(),
            large_step: 0.3,
            swaps: SwapKind::SerialTempering,
            swap_every: 16.0,
            ipsm: 0.0,
            pathspace: 0.0,
            mutations: Mutations::new(8),
            pilot: 1000,
            density_estimation: DensityEstimation::default(),
        }
    }
}

impl CmltSettings {
    /// Mutation probabilities of the path-space moves (shorthand).
    pub fn with_mutations(
        mut self,
        probabilities: MutationProbabilities,
        perturbation: PerturbationSettings,
    ) -> Self {
        self.mutations.probabilities = probabilities;
        self.mutations.perturbation = perturbation;
        self
    }
}

/// The CMLT integrator: settings and the swap proposal from the pilot.
#[derive(Clone, Debug)]
pub struct Cmlt {
    /// Settings.
    pub settings: CmltSettings,
    /// Swap proposal `q(s | k)`, index `[k − 1][s]`.
    pub swap_proposal: Vec<Vec<f64>>,
    /// The light-vertex map of density estimation (rebuilt every round; built on first use).
    light_vertices: Arc<RwLock<Option<Arc<LightVertexMap>>>>,
    /// Merge counters.
    merges: Arc<MergeCounters>,
}

/// Move kinds, in statistics order (the path-space mutations follow).
pub const KINDS: [&str; 4] = ["small step", "large step", "chart swap", "ipsm"];
/// Kinds of the density-estimation move (after the path-space mutations).
pub const MERGE_KINDS: [&str; 2] = [
    "density estimation: merge",
    "density estimation: connection",
];
/// The large step's kind (in [`KINDS`]).
pub const LARGE_STEP: usize = 1;
pub(super) const SWAP: usize = 2;
const PILOT: u64 = 0xC417;
const LIGHT_VERTICES: u64 = 0x11_6487;

impl Cmlt {
    /// CMLT on `scene`: validates the settings and runs the pilot that estimates the energy of
    /// every technique (`settings.pilot` uniform samples per chart).
    pub fn new(scene: &Scene, mut settings: CmltSettings) -> Result<Self> {
        let bad = |name: &str, reason: String| Error::InvalidParameter {
            name: name.into(),
            reason,
        };
        settings
            .small_step
            .validate()
            .map_err(|e| bad("small step", e.to_string()))?;
        let CmltSettings {
            max_edges,
            min_edges,
            importance,
            large_step,
            swap_every,
            ipsm,
            pathspace,
            ..
        } = settings;
        if max_edges == 0 {
            return Err(bad(
                "max depth",
                "CMLT needs paths of at least one edge".into(),
            ));
        }
        if !(1..=max_edges).contains(&min_edges) {
            return Err(bad(
                "shortest path",
                format!("CMLT chains on paths of {min_edges} to {max_edges} edges sample nothing"),
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
        let de = settings.density_estimation.probability;
        settings.density_estimation.validate()?;
        if ipsm + pathspace + de > 1.0 {
            return Err(bad(
                "ipsm + pathspace + density estimation",
                format!("probabilities sum to {} > 1", ipsm + pathspace + de),
            ));
        }
        if !(swap_every == 0.0 || (swap_every >= 1.0 && swap_every.is_finite())) {
            return Err(bad(
                "swap every",
                format!("must be 0 (no swaps) or at least 1, got {swap_every}"),
            ));
        }
        settings.mutations.max_edges = max_edges;
        settings.mutations.min_edges = min_edges;
        settings.mutations.importance = importance;
        if pathspace > 0.0 {
            settings.mutations.validate()?;
        }
        let pilot = settings.pilot.max(1);
        let swap_proposal = (1..=max_edges)
            .map(|k| {
                let energy: Vec<f64> = (0..=k)
                    .map(|s| {
                        if k < min_edges {
                            return 0.0; // no chains of this length
                        }
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
            light_vertices: Arc::default(),
            merges: Arc::default(),
        })
    }

    /// Build the light-vertex map of density estimation from stream key `seed` (replacing the
    /// current one).
    pub fn rebuild_light_vertices(&self, scene: &Scene, seed: u64) -> Result<Arc<LightVertexMap>> {
        let st = &self.settings;
        let map = Arc::new(LightVertexMap::build(
            scene,
            st.max_edges.saturating_sub(1).max(1),
            st.density_estimation.light_paths,
            seed,
        )?);
        if let Ok(mut m) = self.light_vertices.write() {
            *m = Some(map.clone());
        }
        Ok(map)
    }

    /// The current light-vertex map (built from a fixed key if no round has built one yet).
    pub fn light_vertex_map(&self, scene: &Scene) -> Result<Arc<LightVertexMap>> {
        let current = self.light_vertices.read().ok().and_then(|m| m.clone());
        match current {
            Some(m) => Ok(m),
            None => self.rebuild_light_vertices(scene, LIGHT_VERTICES),
        }
    }

    /// The technique chart `s` of paths of `k` edges.
    pub fn chart<'a>(&self, scene: &'a Scene, k: usize, s: usize) -> Option<TechniqueChart<'a>> {
        TechniqueChart::new(scene, k, s, self.settings.importance)
    }

    /// The chart of paths of `k` edges that an independent sample of key `seed` picks (uniform
    /// in `0 … k`, by the technique substream's number), `None` for a length the chains leave
    /// alone.
    fn keyed_chart(&self, k: usize, seed: u64) -> Option<usize> {
        let u = KeyedStream::new(seed).number(TECHNIQUE_STREAM, layout::TECHNIQUE);
        (k >= self.settings.min_edges).then(|| uniform_index(u, k + 1))
    }

    /// An independent sample of path length `g + 1` from key `seed` ([`KeyedStream`]), evaluated
    /// in `state` (whatever it held before): a chart `s` uniform in `0 … k`, coordinates uniform
    /// in it. Returns the bootstrap weight `(k + 1) π_s(u)` (the chart was chosen with
    /// probability `1/(k + 1)`); the chart is the state's.
    fn sample_independent(&self, scene: &Scene, g: usize, seed: u64, state: &mut CmltState) -> f64 {
        let k = g + 1;
        let Some(s) = self.keyed_chart(k, seed) else {
            state.move_to(0, std::iter::empty());
            return 0.0;
        };
        let atlas = self.atlas(scene, k);
        let target = Self::target(&atlas);
        match atlas.chart(s) {
            Some(chart) => state.move_to(s, chart.keyed_coordinates(seed)),
            None => state.move_to(s, std::iter::empty()),
        }
        state.x.change = None;
        state.x.suitability = Default::default();
        Self::weight(&target, k, s, state)
    }

    /// The bootstrap weight `(k + 1) π_s(u)` of a state of chart `s` of length `k`.
    fn weight(target: &TechniqueTarget<'_>, k: usize, s: usize, state: &mut CmltState) -> f64 {
        let ln = target.ln_density(s, state);
        if ln.is_finite() {
            (k + 1) as f64 * ln.exp()
        } else {
            0.0
        }
    }

    /// The technique charts of paths of `k` edges (`s = 0 … k`).
    pub fn atlas<'a>(&self, scene: &'a Scene, k: usize) -> TechniqueAtlas<'a> {
        Atlas::of((0..=k).filter_map(|s| self.chart(scene, k, s)).collect())
    }

    /// The weighted targets over `atlas`.
    pub fn target<'a>(atlas: &'a TechniqueAtlas<'a>) -> TechniqueTarget<'a> {
        ChartedTarget::new(atlas, unit_integrand as UnitIntegrand, TargetKind::Weighted)
    }

    /// How the chart follows a move of the path.
    fn refresh(&self, target: &TechniqueTarget<'_>) -> Refresh {
        match self.settings.swaps {
            SwapKind::SerialTempering => Refresh::Gibbs {
                ln_weights: vec![0.0; target.atlas.levels()],
            },
            SwapKind::ReplicaExchange => Refresh::KeepChart,
        }
    }

    /// Probability of a serial-tempering chart swap per mutation.
    fn swap_probability(&self) -> f64 {
        let st = &self.settings;
        if st.swap_every > 0.0 && st.swaps == SwapKind::SerialTempering {
            1.0 / st.swap_every
        } else {
            0.0
        }
    }

    /// The moves of a chain of paths of `k` edges, with their selection weights, in statistics
    /// order: in-chart (small and large steps), chart swap, IPSM, path-space mutations. Public so
    /// that tests can run them through the balance checks, or replace one.
    pub fn moves<'a>(
        &self,
        scene: &'a Scene,
        target: &'a TechniqueTarget<'a>,
        k: usize,
    ) -> Result<Vec<(f64, CmltMove<'a>)>> {
        let st = &self.settings;
        let bad = |e: mcmc_core::McmcError| Error::InvalidParameter {
            name: "cmlt".into(),
            reason: e.to_string(),
        };
        let small = || CubeWalk::new(st.small_step).map_err(bad);
        let in_chart: Mixture<'a, Vec<f64>> = Mixture::new(
            vec![
                (1.0 - st.large_step, Box::new(small()?) as _),
                (st.large_step, Box::new(Independence::new(UniformCube)) as _),
            ],
            MixtureRule::PerComponent,
        )
        .map_err(bad)?;
        let p_swap = self.swap_probability();
        let q = self
            .swap_proposal
            .get(k - 1)
            .cloned()
            .unwrap_or_else(|| vec![1.0; k + 1]);
        let refresh = self.refresh(target);
        let path_moves: CmltMove<'a> = if st.pathspace > 0.0 {
            let mix = st
                .mutations
                .proposal(scene, NewPath::only(k, st.max_edges))?;
            Box::new(PointMove::new(target, mix, refresh.clone()))
        } else {
            // Never chosen: only its kinds keep the statistics' layout.
            Box::new(Unused(crate::pathspace::REGISTRY.len()))
        };
        let rest = 1.0 - p_swap;
        let de = &st.density_estimation;
        let merges: CmltMove<'a> = if de.probability > 0.0 {
            let sampler = MergeSampler {
                scene,
                k,
                importance: st.importance,
                settings: de.clone(),
                vertices: LightVertices::Shared(self.light_vertex_map(scene)?),
                counters: Some(self.merges.clone()),
            };
            Box::new(ChartIndependence::new(
                target,
                sampler,
                de.merge_share,
                de.rule,
            ))
        } else {
            Box::new(Unused(MERGE_KINDS.len()))
        };
        Ok(vec![
            (
                rest * (1.0 - st.ipsm - st.pathspace - st.density_estimation.probability),
                Box::new(InChart::new(in_chart)),
            ),
            (
                p_swap,
                Box::new(ChartSwap::new(target, LevelProposal::Independent(q))),
            ),
            (
                rest * st.ipsm,
                Box::new(
                    InversePerturbation::through_any_chart(target, small()?)
                        .with_refresh(refresh.clone()),
                ),
            ),
            (rest * st.pathspace, path_moves),
            (rest * de.probability, merges),
        ])
    }

    /// The Metropolis–Hastings kernel of a chain of paths of `k` edges: the [`Joint`] target and
    /// the mixture of [`Cmlt::moves`] (each move's own ratio).
    pub fn kernel<'a>(
        &self,
        scene: &'a Scene,
        target: &'a TechniqueTarget<'a>,
        joint: &'a TechniqueJoint<'a>,
        k: usize,
    ) -> Result<CmltKernel<'a>> {
        let mix = Mixture::new(self.moves(scene, target, k)?, MixtureRule::PerComponent).map_err(
            |e| Error::InvalidParameter {
                name: "cmlt".into(),
                reason: e.to_string(),
            },
        )?;
        Ok(MetropolisHastings::new(joint, mix))
    }
}

/// A move of weight zero that keeps a place in the statistics (`.0` kinds).
struct Unused(usize);

impl Proposal<CmltState> for Unused {
    fn propose(&self, x: &CmltState, y: &mut CmltState, _: &mut ChainRng) -> mcmc_core::Proposed {
        y.clone_from(x);
        mcmc_core::Proposed::failed(0, mcmc_core::Failure::NotApplicable)
    }

    fn kind_count(&self) -> usize {
        self.0
    }

    fn kinds(&self) -> Vec<String> {
        vec!["unused".into(); self.0]
    }
}

impl DirectApart for Cmlt {
    /// CMLT without chains on the paths of the direct pass (the technique pilot of their
    /// lengths, already run by [`Cmlt::new`], is simply not used).
    fn without_direct(mut self) -> Self {
        self.settings.min_edges = DIRECT_EDGES + 1;
        self.settings.mutations.min_edges = DIRECT_EDGES + 1;
        self
    }
    fn max_edges(&self) -> usize {
        self.settings.max_edges
    }
}

impl Method for Cmlt {
    type State = CmltState;

    fn groups(&self) -> usize {
        self.settings.max_edges
    }

    fn independent(&self, scene: &Scene, g: usize, seed: u64) -> (CmltState, f64) {
        let mut state = CmltState::in_chart(0, Vec::new());
        let w = self.sample_independent(scene, g, seed, &mut state);
        (state, w)
    }

    fn independent_weight(&self, scene: &Scene, g: usize, seed: u64) -> f64 {
        self.independent_in_stratum(scene, g, seed).1
    }

    fn independent_in_stratum(&self, scene: &Scene, g: usize, seed: u64) -> (usize, f64) {
        STATE.with_borrow_mut(|state| {
            let w = self.sample_independent(scene, g, seed, state);
            (state.chart, w)
        })
    }

    fn shares_bootstrap_keys(&self) -> bool {
        true
    }

    /// Every length's sample of key `seed`, each in its chart, from one camera and one light
    /// subpath walked to the longest length ([`sample_paths_every_length`]): a chart's forward
    /// map of its keyed coordinates walks their first vertices
    /// ([`TechniqueChart::keyed_coordinates`]), so the path each length's sample maps to is made
    /// from them and evaluated as the forward map evaluates it.
    fn independent_all(&self, scene: &Scene, seed: u64, out: &mut [(usize, f64)]) {
        for (g, o) in out.iter_mut().enumerate() {
            *o = (self.keyed_chart(g + 1, seed).unwrap_or(0), 0.0);
        }
        let mut keyed = KeyedStream::new(seed);
        let max_edges = self.settings.max_edges.min(out.len());
        let strategy = |k| self.keyed_chart(k, seed);
        STATE.with_borrow_mut(|state| {
            PATH.with_borrow_mut(|path| {
                sample_paths_every_length(scene, max_edges, strategy, &mut keyed, path, |k, x| {
                    let s = out[k - 1].0;
                    let atlas = self.atlas(scene, k);
                    let Some(chart) = atlas.chart(s) else {
                        return;
                    };
                    state.move_to(s, chart.keyed_coordinates(seed));
                    // The path in the state, its storage in the walks' (both reused).
                    std::mem::swap(&mut state.x, x);
                    state.x.change = None;
                    state.x.suitability = Default::default();
                    if chart.evaluate_path(&mut state.x) {
                        let target = Self::target(&atlas);
                        target.refresh_point(state);
                        out[k - 1].1 = Self::weight(&target, k, s, state);
                    }
                })
            })
        });
    }

    /// The bootstrap picks a chart uniformly: its `k + 1` charts are the strata of length `k`.
    fn strata(&self, g: usize) -> usize {
        g + 2
    }

    /// The large step, whose candidate is uniform in the chain's chart: a bootstrap sample of
    /// that chart's stratum. None without large steps.
    fn independent_proposals(&self) -> Option<usize> {
        (self.settings.large_step > 0.0).then_some(LARGE_STEP)
    }

    fn ln_density(&self, scene: &Scene, state: &CmltState) -> f64 {
        let atlas = self.atlas(scene, state.x.path.edges());
        let target = Self::target(&atlas);
        Joint::new(&target).ln_density(state)
    }

    fn mutate<O: Observer<CmltState>>(
        &self,
        scene: &Scene,
        chain: &mut Chain<CmltState>,
        n: u64,
        rng: &mut ChainRng,
        observer: &mut O,
    ) {
        let k = chain.state.x.path.edges();
        let atlas = self.atlas(scene, k);
        let target = Self::target(&atlas);
        let joint = Joint::new(&target);
        // Validated in `new`: building the moves cannot fail.
        let Ok(mut kernel) = self.kernel(scene, &target, &joint, k) else {
            return;
        };
        for _ in 0..n {
            kernel.step(chain, rng, observer);
        }
    }

    fn mutate_chunk<O: Observer<CmltState>>(
        &self,
        scene: &Scene,
        chains: &mut [Chain<CmltState>],
        rngs: &mut [ChainRng],
        n: u64,
        observer: &mut O,
    ) {
        // The kernels of the path lengths present in the group, built once.
        let max = self.settings.max_edges;
        let atlases: Vec<TechniqueAtlas<'_>> = (1..=max).map(|k| self.atlas(scene, k)).collect();
        let targets: Vec<TechniqueTarget<'_>> = atlases.iter().map(Self::target).collect();
        let joints: Vec<TechniqueJoint<'_>> = targets.iter().map(Joint::new).collect();
        let mut kernels: Vec<Option<CmltKernel<'_>>> = (0..max).map(|_| None).collect();
        for (chain, rng) in chains.iter_mut().zip(rngs.iter_mut()) {
            let k = chain.state.x.path.edges();
            if !(1..=max).contains(&k) {
                continue;
            }
            if kernels[k - 1].is_none() {
                // Validated in `new`: building the moves cannot fail.
                kernels[k - 1] = self.kernel(scene, &targets[k - 1], &joints[k - 1], k).ok();
            }
            if let Some(kernel) = kernels[k - 1].as_mut() {
                for _ in 0..n {
                    kernel.step(chain, rng, observer);
                }
            }
        }
    }

    fn new_round(&self, scene: &Scene, round: u64, seed: u64) -> Result<()> {
        if self.settings.density_estimation.probability > 0.0 {
            self.rebuild_light_vertices(scene, seed ^ LIGHT_VERTICES ^ round.rotate_left(32))?;
        }
        Ok(())
    }

    fn details(&self) -> Vec<String> {
        let de = &self.settings.density_estimation;
        if de.probability == 0.0 {
            return Vec::new();
        }
        let c = &self.merges;
        let n = c.proposals.load(Ordering::Relaxed).max(1) as f64;
        let found = c.found.load(Ordering::Relaxed) as f64;
        let vertices = self
            .light_vertices
            .read()
            .ok()
            .and_then(|m| m.as_ref().map(|m| m.vertices()))
            .unwrap_or(0);
        vec![format!(
            "density estimation (approximate merge density: slightly biased, more so at larger radii): {} light paths ({} vertices) per map, radius {}, cap {}; {:.1}% of merges found a vertex, {:.2} on average, {:.3}% over the cap",
            de.light_paths,
            vertices,
            de.radius,
            de.cap,
            100.0 * found / n,
            c.vertices.load(Ordering::Relaxed) as f64 / n,
            100.0 * c.overflows.load(Ordering::Relaxed) as f64 / n,
        )]
    }

    fn exchange_every(&self) -> Option<u64> {
        let st = &self.settings;
        (st.swaps == SwapKind::ReplicaExchange && st.swap_every > 0.0)
            .then(|| st.swap_every.round().max(1.0) as u64)
    }

    fn exchange(
        &self,
        scene: &Scene,
        chains: &mut [Chain<CmltState>],
        groups: &[usize],
        rng: &mut ChainRng,
    ) {
        self.exchange_round(scene, chains, groups, rng);
    }

    fn kinds(&self) -> Vec<String> {
        KINDS
            .iter()
            .map(|&s| match (s, self.settings.swaps) {
                ("chart swap", SwapKind::ReplicaExchange) => "replica exchange".to_string(),
                _ => s.to_string(),
            })
            .chain(
                crate::pathspace::mutations::names()
                    .into_iter()
                    .map(|k| format!("path: {k}")),
            )
            .chain(MERGE_KINDS.iter().map(|k| k.to_string()))
            .collect()
    }
}
