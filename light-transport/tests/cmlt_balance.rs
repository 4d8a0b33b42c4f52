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
//! Checks (seeded; α = 1e-4 each, Bonferroni within a check, so a false failure of the eight
//! checks of correct kernels has probability ≤ 8e-4 for the file): invariance of (chart, raster
//! position, floor point) after 3 steps from exact draws, and exchangeability of one step on
//! (raster cell × chart). Tests of the tests: a chart swap that forgets its proposal ratio
//! `q(s)/q(s')` (with a skewed swap proposal) and an IPSM that forgets the density ratio
//! `p_j(x̄)/p_j(ȳ)` are caught by the invariance check.
//!
//! The chart-keeping moves of replica exchange are checked on the built-in caustic instead, in
//! single charts of paths of four edges (exact draws of one chart's law by rejection, with a bound
//! of eight times a pilot's largest value): the glass sphere makes the charts' weights differ
//! most there. A chart-keeping IPSM that accepts for the paths' law instead of the chart's is
//! caught.

use light_transport::Rgb;
use light_transport::cmlt::{
    Cmlt, CmltMove, CmltSettings, CmltState, DensityEstimation, LightVertices, MergeSampler,
    TechniqueJoint,
};
use light_transport::math::DVec3;
use light_transport::metropolis::ImportanceKind;
use light_transport::metropolis::Method;
use light_transport::pathspace::PathState;
use light_transport::scene::Scene;
use light_transport::scene::builtin::SceneBuilder;
use mcmc_charts::Joint;
use mcmc_charts::moves::{ChartIndependence, FROM_SAMPLER, IndependenceRule, PointSampler};
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
    exact_draw_in(joint, m, None, rng)
}

/// Exact draws of the joint target, or of its conditional law in `chart`, by rejection.
fn exact_draw_in(
    joint: &TechniqueJoint<'_>,
    m: f64,
    chart: Option<usize>,
    rng: &mut ChainRng,
) -> CmltState {
    loop {
        let s = chart.unwrap_or_else(|| uniform_index(uniform(rng), K + 1));
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

/// The largest `π_s(u)` over `draws` uniform points of a pilot, each in the chart `chart` picks
/// from `rng` (asserting that some point carries light).
fn pilot_max(
    joint: &TechniqueJoint<'_>,
    rng: &mut ChainRng,
    draws: usize,
    mut chart: impl FnMut(&mut ChainRng) -> usize,
) -> f64 {
    let mut top: f64 = 0.0;
    for _ in 0..draws {
        let s = chart(rng);
        let dim = joint.target.atlas.dim(s);
        let mut state = CmltState::in_chart(s, (0..dim).map(|_| uniform(rng)).collect());
        let l = joint.evaluate(&mut state);
        if l.is_finite() {
            top = top.max(l.exp());
        }
    }
    assert!(top > 0.0, "no light in the pilot");
    top
}

/// Twice the largest `π_s(u)` in a pilot.
fn bound(joint: &TechniqueJoint<'_>) -> f64 {
    let pick = |rng: &mut ChainRng| uniform_index(uniform(rng), K + 1);
    2.0 * pilot_max(joint, &mut stream(0xB0, 0), 200_000, pick)
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
    steps(joint, kernel, s, rng, 1, &mut mcmc_core::Stats::default());
}

/// `n` kernel steps from `s`, their move statistics added to `stats`.
fn steps<K2: Kernel<CmltState>>(
    joint: &TechniqueJoint<'_>,
    kernel: &mut K2,
    s: &mut CmltState,
    rng: &mut ChainRng,
    n: usize,
    stats: &mut mcmc_core::Stats,
) {
    let l = joint.evaluate(s);
    let mut c = Chain::unchecked(std::mem::take(s), l);
    for _ in 0..n {
        kernel.step(&mut c, rng, &mut ());
    }
    stats.merge(&c.stats);
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
        |s: &mut CmltState, rng: &mut ChainRng| steps(&joint, &mut kernel, s, rng, 1, &mut stats),
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

// ---------------------------------------------------------------------------------------------
// Density estimation as an independence sampler (charted-MLT paper §5.3, eqs. 28–29).

/// Merge settings for the balance checks: a radius of 2% of the bounding-sphere radius (0.044
/// here; `π r² p_→` is then within 0.1% of the merge probability on the floor, see
/// `the_merge_probability_approximation_shrinks_with_the_radius`), 4000 light subpaths per map
/// (5.3 vertices per lookup on average at the floor's centre, fewer elsewhere), cap 16 (a
/// lookup finds more with probability below 3e-5).
fn merge_settings(share: f64, rule: IndependenceRule) -> DensityEstimation {
    DensityEstimation {
        probability: 0.7,
        merge_share: share,
        radius: 0.02,
        light_paths: 4000,
        cap: 16,
        rule,
        ..Default::default()
    }
}

fn merge_sampler(settings: &DensityEstimation) -> MergeSampler<'static> {
    MergeSampler {
        scene: scene(),
        k: K,
        importance: ImportanceKind::Luminance,
        settings: settings.clone(),
        vertices: LightVertices::FreshPerProposal,
        counters: None,
    }
}

/// A merge sampler that reports the connection density for its candidates (eq. 28 with the merge
/// probability forgotten: merges treated as connections). Deliberately wrong.
struct MergeAsConnection(MergeSampler<'static>);

impl PointSampler<PathState> for MergeAsConnection {
    fn draw(&self, s: usize, y: &mut PathState, rng: &mut ChainRng) -> bool {
        self.0.draw(s, y, rng)
    }
    fn ln_density(&self, s: usize, x: &PathState) -> f64 {
        let m = self.0.ln_merge_factor(s, x);
        self.0.ln_density(s, x) - if m.is_finite() { m } else { 0.0 }
    }
    fn name(&self) -> String {
        "merge as connection".into()
    }
}

/// In-chart steps (30%) and the density-estimation independence sampler (70%; 80% merges), with
/// a fresh light-vertex map for every merge (so the only approximation left is `π r² p_→`,
/// 0.1% here), four steps from exact draws of chart `s = 1` (the only chart of these two-edge
/// paths a merge can make; the kernel keeps the chart, so it must keep the chart's conditional
/// law): eq. 29 and eq. 28 keep it (the per-component rule is equivalent in law, as Tierney
/// 1998's mixtures of kernels are; eq. 29 dominates it in Peskun's order); a merge accepted as if
/// it were a connection is caught (with 10 000 replicates: the merges are a small part of the
/// moves). α = 1e-4 per check.
#[test]
fn density_estimation_keeps_the_joint_target() {
    let m = cmlt();
    let scene = scene();
    let atlas = m.atlas(scene, K);
    let target = Cmlt::target(&atlas);
    let joint = Joint::new(&target);
    let bound = bound(&joint);
    let in_chart = || m.moves(scene, &target, K).expect("moves").swap_remove(0).1;
    let run = |merge: CmltMove<'_>, seed: u64, replicates: usize| {
        let mix = Mixture::new(
            vec![(0.3, in_chart()), (0.7, merge)],
            MixtureRule::PerComponent,
        )
        .expect("mixture");
        let mut kernel = MetropolisHastings::new(&joint, mix);
        let mut stats = mcmc_core::Stats::default();
        let r = invariance(
            |rng: &mut ChainRng| exact_draw_in(&joint, bound, Some(1), rng),
            |s: &mut CmltState, rng: &mut ChainRng| {
                steps(&joint, &mut kernel, s, rng, 4, &mut stats)
            },
            features,
            &InvarianceConfig {
                replicates,
                steps: 1,
                alpha: ALPHA,
                categorical: vec![0],
            },
            &mut stream(seed, 0),
        )
        .expect("check runs");
        let k = |i: usize| stats.kinds.get(i).cloned().unwrap_or_default();
        // Kinds: small step, large step, then the independence sampler's merge and connection.
        let (merge, conn) = (k(2), k(3));
        let rate = |s: &mcmc_core::KindStats| s.accepted as f64 / s.proposed.max(1) as f64;
        let made = merge.proposed - merge.failed;
        let line = format!(
            "merges: {} proposed, {} made, {} accepted ({:.1}% of those made); connections: {:.1}% accepted",
            merge.proposed,
            made,
            merge.accepted,
            100.0 * merge.accepted as f64 / made.max(1) as f64,
            100.0 * rate(&conn),
        );
        (r.passed, format!("{r}\n  {line}"), merge.accepted)
    };
    let expected = merge_settings(0.8, IndependenceRule::Expected);
    let per_component = merge_settings(0.8, IndependenceRule::PerComponent);
    // The three checks are independent (own seeds): run them side by side.
    let ((eq29, eq28), broken) = rayon::join(
        || {
            rayon::join(
                || {
                    run(
                        Box::new(ChartIndependence::new(
                            &target,
                            merge_sampler(&expected),
                            0.8,
                            expected.rule,
                        )),
                        31,
                        4000,
                    )
                },
                || {
                    run(
                        Box::new(ChartIndependence::new(
                            &target,
                            merge_sampler(&per_component),
                            0.8,
                            per_component.rule,
                        )),
                        32,
                        4000,
                    )
                },
            )
        },
        || {
            run(
                Box::new(ChartIndependence::new(
                    &target,
                    MergeAsConnection(merge_sampler(&expected)),
                    0.8,
                    expected.rule,
                )),
                33,
                10_000,
            )
        },
    );
    let (ok, report, accepted) = eq29;
    println!("eq. 29: {report}");
    assert!(ok, "{report}");
    assert!(
        accepted > 500,
        "too few merges accepted ({accepted}) for the check to see them"
    );
    let (ok, report, _) = eq28;
    println!("eq. 28: {report}");
    assert!(ok, "{report}");
    let (ok, report, _) = broken;
    println!("merges taken for connections: {report}");
    assert!(
        !ok,
        "a merge accepted as a connection was not caught: {report}"
    );
}

/// The density the eq. 29 rule uses, `Q_s = p_s/I(f) · (λ m + 1 − λ)`, against an independent
/// computation of the merge factor `m = π r² p_→ N / cap` from the geometry: the emitter's
/// cosine lobe `cos θ_y / π`, and `cos θ_z / d²` at the floor. 2000 paths of chart `s = 1`.
#[test]
fn the_expected_density_of_eq_29_matches_an_independent_computation() {
    let m = cmlt();
    let scene = scene();
    let atlas = m.atlas(scene, K);
    let target = Cmlt::target(&atlas);
    let settings = merge_settings(0.3, IndependenceRule::Expected);
    let move_ = ChartIndependence::new(&target, merge_sampler(&settings), 0.3, settings.rule);
    let r = settings.radius_in(scene);
    let mut rng = stream(41, 0);
    let (mut checked, mut worst) = (0, 0.0f64);
    while checked < 2000 {
        let dim = atlas.dim(1);
        let mut state = CmltState::in_chart(1, (0..dim).map(|_| uniform(&mut rng)).collect());
        target.refresh(&mut state);
        if !(state.valid && state.importance > 0.0) {
            continue;
        }
        let v = &state.x.path.vertices;
        let (y, z) = (&v[0], &v[1]);
        let d = z.p() - y.p();
        let w = d.normalize();
        let p_to = (y.n().dot(w).max(0.0) / std::f64::consts::PI) * z.n().dot(-w).abs()
            / d.length_squared();
        let merge = std::f64::consts::PI * r * r * p_to * 4000.0 / 16.0;
        let independent = state.ln_p[1] + (0.3 * merge + 0.7).ln();
        let from_move = move_.ln_proposal_density(1, &state, FROM_SAMPLER);
        worst = worst.max((independent - from_move).abs());
        checked += 1;
    }
    println!("2000 paths: max |Δ ln Q| = {worst:.2e}");
    assert!(worst < 1e-9, "max |Δ ln Q| = {worst}");
}

/// The approximation `P_merge ≈ π r² p_→(y → z)` against the merge probability itself,
/// estimated by tracing the light's emission from a fixed point `y` of the emitter 4 million
/// times and counting the floor hits within `r` of `z` (normals agree there). At the floor's
/// centre and 0.02 from its edge; radii 0.5%–32% of the bounding-sphere radius. The relative
/// error shrinks with `r` (at the edge, half the disc hangs off the floor: the approximation is
/// twice the probability until `r` drops below the distance to the edge). 5σ bounds on the
/// counts.
#[test]
fn the_merge_probability_approximation_shrinks_with_the_radius() {
    use light_transport::path::light_subpath;
    use light_transport::sampler::ReplayStream;
    let scene = scene();
    let n = 4_000_000usize;
    // Emission from the light's centre: the light stream's choice/position numbers are fixed.
    let mut hits = Vec::with_capacity(n);
    let mut rng = stream(51, 0);
    let mut sub = light_transport::path::Subpath::new();
    let mut y = None;
    for _ in 0..n {
        let nums = [0.5, 0.5, 0.5, uniform(&mut rng), uniform(&mut rng)];
        light_subpath(scene, &mut ReplayStream::new(&[], &nums, &[]), 2, &mut sub);
        if y.is_none() {
            y = sub.first().cloned();
        }
        if let Some(v) = sub.get(1) {
            hits.push(v.p());
        }
    }
    let y = y.expect("light vertex");
    let bound_r = 0.5 * (scene.bounds.1 - scene.bounds.0).length();
    println!("fraction   r      point   approx      measured    rel. error");
    let mut errors = Vec::new();
    for (name, z) in [
        ("centre", DVec3::new(0.1, 0.0, -0.05)),
        ("edge", DVec3::new(1.48, 0.0, 0.3)),
    ] {
        let d = z - y.p();
        let w = d.normalize();
        let p_to = (y.n().dot(w).max(0.0) / std::f64::consts::PI) * w.y.abs() / d.length_squared();
        let mut errs = Vec::new();
        for fraction in [0.32, 0.08, 0.02, 0.005] {
            let r = fraction * bound_r;
            let approx = std::f64::consts::PI * r * r * p_to;
            let count = hits.iter().filter(|h| (**h - z).length() < r).count() as f64;
            let measured = count / n as f64;
            let sigma = (approx * n as f64).sqrt() / n as f64;
            let rel = approx / measured - 1.0;
            println!(
                "{fraction:<8} {r:<6.4} {name:<7} {approx:.4e}  {measured:.4e}  {rel:+.4} (±{:.4})",
                5.0 * sigma / measured
            );
            errs.push((rel, 5.0 * sigma / measured));
        }
        errors.push(errs);
    }
    // Centre: the error falls with r and is within noise at the two smallest radii.
    let centre = &errors[0];
    assert!(centre[0].0.abs() > centre[1].0.abs(), "{centre:?}");
    for &(rel, tol) in &centre[2..] {
        assert!(rel.abs() < tol.max(0.005), "{centre:?}");
    }
    // Edge: twice the probability while the disc overhangs (r ≥ 0.02 from the edge), exact below.
    let edge = &errors[1];
    assert!(edge[1].0 > 0.5, "{edge:?}");
    assert!(edge[3].0.abs() < edge[3].1.max(0.005), "{edge:?}");
}

// ---------------------------------------------------------------------------------------------
// Chart-keeping moves on a caustic (replica exchange: every chain keeps its chart).

/// The built-in caustic at 36×30 (a glass sphere focusing a small light onto the floor).
fn caustic() -> &'static Scene {
    static S: OnceLock<Scene> = OnceLock::new();
    S.get_or_init(|| {
        Scene::new(
            &light_transport::scene::builtin::builtin("caustic").expect("built-in"),
            Some((36, 30)),
        )
        .expect("scene")
    })
}

/// Path length of the caustic checks: chart `s = 4` (light tracing, `t = 1`) holds the caustic
/// `L S S D E` beside diffuse paths.
const CAUSTIC_K: usize = 4;

/// Eight times the largest `π_s(u)` of a pilot of 400 000 uniform draws in chart `chart` (every
/// value met later is checked against it by [`exact_draw_in`]).
fn chart_bound(joint: &TechniqueJoint<'_>, chart: usize) -> f64 {
    8.0 * pilot_max(joint, &mut stream(0xB1, chart as u64), 400_000, |_| chart)
}

/// Raster block (6×5 of the 36×30 image) and number of specular vertices, both categorical; the
/// first camera number and the first light-position number of the chart's coordinates; the
/// chart's balance weight `ln w_s = ln p_s − ln Σ p` at the path.
fn caustic_features(s: &CmltState) -> Vec<f64> {
    let r = s.x.path.raster(caustic()).unwrap_or([f64::NAN; 2]);
    let block = (r[1] / 6.0).floor().clamp(0.0, 4.0) * 6.0 + (r[0] / 6.0).floor().clamp(0.0, 5.0);
    let specular = s.x.path.vertices.iter().filter(|v| v.delta).count() as f64;
    let t = CAUSTIC_K + 1 - s.chart;
    let light =
        light_transport::cmlt::camera_numbers(t) + light_transport::sampler::layout::LIGHT_POSITION;
    let ln_w = s.ln_p[s.chart] - mcmc_core::proposals::log_sum_exp(&s.ln_p);
    vec![
        block,
        specular,
        s.u[0],
        s.u.get(light).copied().unwrap_or(f64::NAN),
        ln_w,
    ]
}

/// The moves a chain of replica-exchange CMLT makes in its chart — small and large steps, IPSM
/// through any chart and path-space mutations, the last two keeping the chart
/// ([`Refresh::KeepChart`]) — keep that chart's conditional law `π̄_s` on the caustic: chart 4,
/// the caustic's own technique, and chart 1 (next-event estimation). From exact draws of the
/// chart, 4 steps; invariance of raster block, number of specular vertices and two coordinates
/// (α = 1e-4 each). A chart-keeping IPSM that forgets `p_j(x̄)/p_j(ȳ)` is caught.
#[test]
fn chart_keeping_moves_keep_each_charts_law_on_a_caustic() {
    let scene = caustic();
    let m = Cmlt::new(
        scene,
        CmltSettings {
            max_edges: CAUSTIC_K,
            swaps: light_transport::cmlt::SwapKind::ReplicaExchange,
            ipsm: 0.3,
            pathspace: 0.3,
            pilot: 500,
            ..Default::default()
        },
    )
    .expect("settings");
    let atlas = m.atlas(scene, CAUSTIC_K);
    let target = Cmlt::target(&atlas);
    let joint = Joint::new(&target);
    let check = |kernel: &mut dyn FnMut(&mut CmltState, &mut ChainRng), chart: usize, seed: u64| {
        let bound = chart_bound(&joint, chart);
        invariance(
            |rng: &mut ChainRng| exact_draw_in(&joint, bound, Some(chart), rng),
            |s: &mut CmltState, rng: &mut ChainRng| kernel(s, rng),
            caustic_features,
            &InvarianceConfig {
                replicates: 4000,
                steps: 1,
                alpha: ALPHA,
                categorical: vec![0, 1],
            },
            &mut stream(seed, 0),
        )
        .expect("check runs")
    };
    for (chart, seed) in [(4, 41), (1, 42)] {
        let mut kernel = m.kernel(scene, &target, &joint, CAUSTIC_K).expect("kernel");
        let mut stats = mcmc_core::Stats::default();
        let r = check(
            &mut |s, rng| steps(&joint, &mut kernel, s, rng, 4, &mut stats),
            chart,
            seed,
        );
        println!("chart {chart}: {r}");
        print!("{}", stats.table(&m.kinds()));
        assert!(r.passed, "chart {chart}: {r}");
        // IPSM and the path-space moves were accepted often enough to matter.
        for kind in ["ipsm", "path: "] {
            let accepted: u64 = m
                .kinds()
                .iter()
                .zip(&stats.kinds)
                .filter(|(name, _)| name.starts_with(kind))
                .map(|(_, k)| k.accepted)
                .sum();
            assert!(
                accepted > 500,
                "chart {chart}: {kind} accepted {accepted} times"
            );
        }
    }
    // IPSM through chart 4 with a large step (so that the chain equilibrates within the 64 steps
    // checked) keeps chart 4's law; accepted as if the chain sampled the paths' law `f` (the
    // Gibbs rule's acceptance), with the factor `w_s(ȳ)/w_s(x̄)` of the chart's balance weight
    // forgotten, it is caught.
    let ipsm = InversePerturbation::new(&target, 4, Independence::new(UniformCube))
        .with_refresh(Refresh::KeepChart);
    let mut correct = MetropolisHastings::new(&joint, &ipsm);
    let r = check(
        &mut |s, rng| {
            steps(
                &joint,
                &mut correct,
                s,
                rng,
                64,
                &mut mcmc_core::Stats::default(),
            )
        },
        4,
        43,
    );
    println!("chart-keeping IPSM with large steps: {r}");
    assert!(r.passed, "{r}");
    let broken = WithoutChartWeight(&ipsm);
    let mut kernel = MetropolisHastings::new(&joint, &broken);
    let r = check(
        &mut |s, rng| {
            steps(
                &joint,
                &mut kernel,
                s,
                rng,
                64,
                &mut mcmc_core::Stats::default(),
            )
        },
        4,
        44,
    );
    println!("chart-keeping IPSM without the chart's weight: {r}");
    assert!(
        !r.passed,
        "the broken chart-keeping IPSM was not caught: {r}"
    );
}

/// A chart-keeping move whose ratio has `ln w_s(ȳ) − ln w_s(x̄)` taken back out (`w_s = p_s / Σ p`,
/// the chain's chart `s`): it accepts for the path marginal `f` instead of the chart's `f w_s`.
struct WithoutChartWeight<'a, P>(&'a P);

impl<P: Proposal<CmltState>> Proposal<CmltState> for WithoutChartWeight<'_, P> {
    fn propose(&self, x: &CmltState, y: &mut CmltState, rng: &mut ChainRng) -> Proposed {
        let p = self.0.propose(x, y, rng);
        if p.failure.is_some() || !p.ln_ratio.is_finite() {
            return p;
        }
        let ln_w = |s: &CmltState| s.ln_p[s.chart] - mcmc_core::proposals::log_sum_exp(&s.ln_p);
        Proposed::new(p.ln_ratio - (ln_w(y) - ln_w(x)), p.kind)
    }
}
