//! The moves charted MLT runs — in-chart small and large steps, serial-tempering chart swaps,
//! inverse primary-space perturbations and path-space mutations, each with the chart refreshed
//! by its conditional law — checked as one kernel with `mcmc-core`'s balance checks, on the real
//! technique charts of a small scene where the joint target can be sampled exactly.
//!
//! The scene: a diffuse floor under a small square emitter, seen by a pinhole camera; paths of
//! two edges (light → floor → lens) in the three technique charts `s = 0, 1, 2`. The joint target
//! of a chain over (chart, numbers) is `π_s(u) = f / Σ p` (weighted, equal pseudo-priors). Exact
//! draws come by rejection: `s` uniform, `u` uniform, accepted with `π_s(u) / M`, where the bound
//! `M` is twice the largest value seen in a pilot of 200 000 draws — and every value met during
//! the tests is checked against it (a violation fails the test, it would make the draws inexact).
//!
//! Checks (seeded; α = 1e-4 each, Bonferroni within a check, so a false failure of the correct
//! kernel has probability ≤ 4e-4 for the file): invariance of (chart, raster position, floor
//! point) after 3 steps from exact draws, and exchangeability of one step on (raster cell ×
//! chart). Tests of the tests: a chart swap that forgets its proposal ratio `q(s)/q(s')` (with a
//! skewed swap proposal) and an IPSM that forgets the density ratio `p_j(x̄)/p_j(ȳ)` are caught by
//! the invariance check.

use light_transport::Rgb;
use light_transport::cmlt::{Cmlt, CmltSettings, CmltState, TechniqueJoint};
use light_transport::math::DVec3;
use light_transport::metropolis::Method;
use light_transport::scene::Scene;
use light_transport::scene::builtin::SceneBuilder;
use mcmc_charts::Joint;
use mcmc_charts::moves::{InversePerturbation, Refresh};
use mcmc_core::balance::exchangeability::{ExchangeabilityConfig, QuantileGrid, exchangeability};
use mcmc_core::balance::invariance::{InvarianceConfig, invariance};
use mcmc_core::proposals::{Independence, Mixture, MixtureRule, UniformCube};
use mcmc_core::rng::{stream, uniform, uniform_index};
use mcmc_core::{Chain, ChainRng, Kernel, MetropolisHastings, Proposal, Proposed, Target};
use std::sync::OnceLock;

const ALPHA: f64 = 1e-4;
const K: usize = 2;

fn scene() -> &'static Scene {
    static S: OnceLock<Scene> = OnceLock::new();
    S.get_or_init(|| {
        let mut b = SceneBuilder::new(
            48,
            36,
            DVec3::new(0.0, 1.6, 2.5),
            DVec3::new(0.0, 0.0, 0.0),
            50.0,
        );
        let floor = b.matte(0.7, 0.6, 0.5);
        let black = b.matte(0.0, 0.0, 0.0);
        b.quad(
            DVec3::new(-1.5, 0.0, -1.5),
            DVec3::Z * 3.0,
            DVec3::X * 3.0,
            floor,
            None,
        );
        b.quad(
            DVec3::new(-0.2, 1.2, -0.2),
            DVec3::X * 0.4,
            DVec3::Z * 0.4,
            black,
            Some(Rgb::new(8.0, 7.0, 6.0)),
        );
        Scene::new(&b.finish(), None).expect("scene")
    })
}

/// CMLT with every move: chart swaps every 4 mutations on average, 20% IPSM, 20% path-space
/// mutations.
fn cmlt() -> Cmlt {
    Cmlt::new(
        scene(),
        CmltSettings {
            max_edges: K,
            swap_every: 4.0,
            ipsm: 0.2,
            pathspace: 0.2,
            pilot: 2000,
            ..Default::default()
        },
    )
    .expect("settings")
}

/// Exact draws of the joint target by rejection under the bound `m`.
fn exact_draw(joint: &TechniqueJoint<'_>, m: f64, rng: &mut ChainRng) -> CmltState {
    loop {
        let s = uniform_index(uniform(rng), K + 1);
        let dim = joint.target.atlas.dim(s);
        let mut state = CmltState::in_chart(s, (0..dim).map(|_| uniform(rng)).collect());
        let l = joint.evaluate(&mut state);
        if !l.is_finite() {
            continue;
        }
        let v = l.exp();
        assert!(v <= m, "rejection bound violated: π = {v} > M = {m}");
        if uniform(rng) * m < v {
            return state;
        }
    }
}

/// Twice the largest `π_s(u)` in a pilot.
fn bound(joint: &TechniqueJoint<'_>) -> f64 {
    let mut rng = stream(0xB0, 0);
    let mut top: f64 = 0.0;
    for _ in 0..200_000 {
        let s = uniform_index(uniform(&mut rng), K + 1);
        let dim = joint.target.atlas.dim(s);
        let mut state = CmltState::in_chart(s, (0..dim).map(|_| uniform(&mut rng)).collect());
        let l = joint.evaluate(&mut state);
        if l.is_finite() {
            top = top.max(l.exp());
        }
    }
    assert!(top > 0.0, "no light in the pilot");
    2.0 * top
}

/// Chart, raster position, floor point.
fn features(s: &CmltState) -> Vec<f64> {
    let v = &s.x.path.vertices;
    let r = s.x.path.raster(scene()).unwrap_or([f64::NAN; 2]);
    vec![s.chart as f64, r[0], r[1], v[1].p().x, v[1].p().z]
}

fn step<K2: Kernel<CmltState>>(
    joint: &TechniqueJoint<'_>,
    kernel: &mut K2,
    s: &mut CmltState,
    rng: &mut ChainRng,
) {
    let l = joint.evaluate(s);
    let mut c = Chain::unchecked(std::mem::take(s), l);
    kernel.step(&mut c, rng, &mut ());
    *s = c.state;
}

fn invariance_passes<K2: Kernel<CmltState>>(
    joint: &TechniqueJoint<'_>,
    m: f64,
    kernel: &mut K2,
    seed: u64,
    steps: usize,
) -> (bool, String) {
    let r = invariance(
        |rng: &mut ChainRng| exact_draw(joint, m, rng),
        |s: &mut CmltState, rng: &mut ChainRng| step(joint, kernel, s, rng),
        features,
        &InvarianceConfig {
            replicates: 4000,
            steps,
            alpha: ALPHA,
            categorical: vec![0],
        },
        &mut stream(seed, 0),
    )
    .expect("check runs");
    (r.passed, r.to_string())
}

#[test]
fn the_cmlt_move_set_keeps_the_joint_target() {
    let m = cmlt();
    let scene = scene();
    let atlas = m.atlas(scene, K);
    let target = Cmlt::target(&atlas);
    let joint = Joint::new(&target);
    let bound = bound(&joint);
    let mut kernel = m.kernel(scene, &target, &joint, K).expect("kernel");
    let (ok, report) = invariance_passes(&joint, bound, &mut kernel, 1, 3);
    println!("invariance: {report}");
    assert!(ok, "{report}");
    // Every move was made.
    let mut rng = stream(2, 0);
    let pilot: Vec<[f64; 2]> = (0..3000)
        .map(|_| {
            let f = features(&exact_draw(&joint, bound, &mut rng));
            [f[1], f[2]]
        })
        .collect();
    let grid = QuantileGrid::fit(&pilot, 4);
    let cell = |s: &CmltState| {
        let f = features(s);
        grid.cell(&[f[1], f[2]]).map(|c| c * (K + 1) + s.chart)
    };
    let mut stats = mcmc_core::Stats::default();
    let r = exchangeability(
        |rng: &mut ChainRng| exact_draw(&joint, bound, rng),
        |s: &mut CmltState, rng: &mut ChainRng| {
            let l = joint.evaluate(s);
            let mut c = Chain::unchecked(std::mem::take(s), l);
            kernel.step(&mut c, rng, &mut ());
            stats.merge(&c.stats);
            *s = c.state;
        },
        cell,
        grid.cells() * (K + 1),
        &ExchangeabilityConfig {
            replicates: 20_000,
            alpha: ALPHA,
        },
        &mut stream(3, 0),
    )
    .expect("check runs");
    println!("exchangeability: {r}");
    print!("{}", stats.table(&m.kinds()));
    assert!(r.passed, "{r}");
    for (kind, k) in m.kinds().iter().zip(&stats.kinds) {
        if k.proposed > 0 {
            assert!(k.accepted > 0, "{kind} never accepted");
        }
    }
    assert!(stats.kinds.iter().filter(|k| k.accepted > 0).count() >= 6);
}

/// The swap with its proposal ratio `ln q(i) − ln q(j)` taken back out.
struct SwapWithoutRatio<'a> {
    swap: Box<dyn Proposal<CmltState> + Send + Sync + 'a>,
    q: Vec<f64>,
}

impl Proposal<CmltState> for SwapWithoutRatio<'_> {
    fn propose(&self, x: &CmltState, y: &mut CmltState, rng: &mut ChainRng) -> Proposed {
        let p = self.swap.propose(x, y, rng);
        Proposed::new(
            p.ln_ratio - (self.q[x.chart].ln() - self.q[y.chart].ln()),
            p.kind,
        )
    }
}

#[test]
fn a_broken_swap_and_a_broken_ipsm_are_caught() {
    let mut m = cmlt();
    // A swap proposal far from the technique energies, so that forgetting it matters.
    m.swap_proposal[K - 1] = vec![0.05, 0.15, 0.8];
    let scene = scene();
    let atlas = m.atlas(scene, K);
    let target = Cmlt::target(&atlas);
    let joint = Joint::new(&target);
    let bound = bound(&joint);
    let mut moves = m.moves(scene, &target, K).expect("moves").into_iter();
    let in_chart = moves.next().expect("in-chart").1;
    let swap = moves.next().expect("swap").1;
    // In-chart steps and swaps only, half each.
    let broken = Mixture::new(
        vec![
            (0.5, in_chart),
            (
                0.5,
                Box::new(SwapWithoutRatio {
                    swap,
                    q: m.swap_proposal[K - 1].clone(),
                }) as _,
            ),
        ],
        MixtureRule::PerComponent,
    )
    .expect("mixture");
    let mut kernel = MetropolisHastings::new(&joint, broken);
    let (ok, report) = invariance_passes(&joint, bound, &mut kernel, 4, 3);
    println!("swap without q ratio: {report}");
    assert!(!ok, "the broken swap was not caught: {report}");

    // IPSM through a uniformly chosen chart with the Gibbs refresh, forgetting p_j(x̄)/p_j(ȳ):
    // with small steps the two densities are nearly equal, so the kernel in the chart's numbers
    // is a large step (uniform), where the ratio is the whole correction.
    let mut ipsm = InversePerturbation::through_any_chart(&target, Independence::new(UniformCube))
        .with_refresh(Refresh::Gibbs {
            ln_weights: vec![0.0; K + 1],
        });
    let mut correct = MetropolisHastings::new(&joint, &ipsm);
    let (ok, report) = invariance_passes(&joint, bound, &mut correct, 5, 4);
    println!("ipsm alone: {report}");
    assert!(ok, "{report}");
    ipsm.forget_density_ratio = true;
    let mut kernel = MetropolisHastings::new(&joint, &ipsm);
    let (ok, report) = invariance_passes(&joint, bound, &mut kernel, 5, 4);
    println!("ipsm without the density ratio: {report}");
    assert!(!ok, "the broken IPSM was not caught: {report}");
}
