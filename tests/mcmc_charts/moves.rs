//! Every charted move keeps its target, checked with `mcmc-core`'s balance checks from exact
//! draws; and the broken variants the paper's derivations warn about are caught.
//!
//! Exact draws use the charts' own exact inverses: `x` from the target-space law by rejection from
//! the piecewise-constant `f`, then `u ~ κ_i(·|x)`.
//!
//! Every statistical check here runs at α = 1e-4; about 150 checks run in all (union bound: false
//! failure ≤ 1.5%; seeds are fixed so the outcome is the same on every run).

use crate::charts::*;
use mcmc_charts::moves::{InChart, InversePerturbation, TargetSpace};
use mcmc_charts::{Atlas, ChartState, ChartedTarget, TargetKind};
use mcmc_core::balance::exchangeability::{ExchangeabilityConfig, QuantileGrid, exchangeability};
use mcmc_core::balance::invariance::{InvarianceConfig, invariance};
use mcmc_core::proposals::{
    CubeWalk, GaussianRandomWalk, Independence, Mixture, MixtureRule, SmallStep, UniformCube,
};
use mcmc_core::rng::{stream, uniform};
use mcmc_core::tempering::{LevelProposal, ReplicaExchange, SerialTempering, SwapSchedule};
use mcmc_core::{Chain, ChainRng, Family, Kernel, Level, MetropolisHastings, Proposal};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

const ALPHA: f64 = 1e-4;

type State = ChartState<P2>;
type Integrand<'a> = Box<dyn Fn(&P2) -> f64 + Sync + 'a>;
type Target<'a> = ChartedTarget<'a, P2, Integrand<'a>>;
type JointTarget<'a> = mcmc_charts::Joint<'a, P2, Integrand<'a>>;
type AnyChart = Box<dyn mcmc_charts::Chart<P2>>;

fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(11),
        failure_persistence: None,
        ..Config::default()
    }
}

fn pssmlt_kernel() -> Mixture<'static, Vec<f64>> {
    Mixture::new(
        vec![
            (
                0.6,
                Box::new(
                    CubeWalk::new(SmallStep::Exponential {
                        s1: 1.0 / 64.0,
                        s2: 0.25,
                    })
                    .unwrap(),
                ) as _,
            ),
            (0.4, Box::new(Independence::new(UniformCube)) as _),
        ],
        MixtureRule::PerComponent,
    )
    .unwrap()
}

fn target<'a>(atlas: &'a Atlas<P2>, f: &'a Cells, kind: TargetKind<P2>) -> Target<'a> {
    ChartedTarget::new(atlas, Box::new(move |x: &P2| f.value(x)), kind)
}

/// `x ~ f(x) a(x) / ∫ f a` by rejection, for `0 ≤ a ≤ 1`.
fn draw_point(f: &Cells, a: &dyn Fn(&P2) -> f64, rng: &mut ChainRng) -> P2 {
    loop {
        let x = f.sample(rng);
        if uniform(rng) < a(&x) {
            return x;
        }
    }
}

/// The state of point `x` in chart `k`, coordinates drawn from the chart's exact inverse.
fn in_chart(t: &Target, k: usize, x: P2, rng: &mut ChainRng) -> State {
    let mut s = State::at_point(t.atlas, x);
    let mut y = s.clone();
    t.refresh(&mut s);
    if k == t.atlas.identity() {
        return s;
    }
    let g = t.atlas.reparameterise(&s, k, &mut y, rng);
    assert!(g.is_finite(), "point outside the chart's image");
    y
}

fn weights(t: &Target, x: &P2) -> Vec<f64> {
    let mut s = State::at_point(t.atlas, *x);
    t.refresh(&mut s);
    let tot: f64 = s.ln_p.iter().map(|l| l.exp()).sum();
    s.ln_p.iter().map(|l| l.exp() / tot).collect()
}

/// Features: chart (categorical), the point, and each chart's coordinates (NaN when elsewhere).
fn features(atlas: &Atlas<P2>) -> impl Fn(&State) -> Vec<f64> + '_ {
    move |s: &State| {
        let mut f = vec![s.chart as f64, s.x[0], s.x[1]];
        for k in 0..atlas.charts() {
            for j in 0..atlas.dim(k) {
                f.push(if s.chart == k { s.u[j] } else { f64::NAN });
            }
        }
        f
    }
}

fn mh_step<K: Kernel<State>>(t: &Target, k: &mut K, s: &mut State, rng: &mut ChainRng) {
    let l = t.ln_density(s.chart, s);
    let mut c = Chain::unchecked(std::mem::take(s), l);
    k.step(&mut c, rng, &mut ());
    *s = c.state;
}

fn inv_config(replicates: usize, steps: usize, categorical: bool) -> InvarianceConfig {
    InvarianceConfig {
        replicates,
        steps,
        alpha: ALPHA,
        categorical: if categorical { vec![0] } else { vec![] },
    }
}

proptest! {
    #![proptest_config(config(10))]

    /// PSSMLT in one chart (small + large steps) with the importance-sampled and the weighted
    /// targets: reversible, and the point and coordinates keep their law.
    #[test]
    fn in_chart_moves_keep_both_targets(c1 in any_chart(), c2 in any_chart(), f in cells(), seed in any::<u64>()) {
        let atlas = Atlas::new(vec![c1.boxed(), c2.boxed()]);
        let mut rng = stream(seed, 0);
        for weighted in [false, true] {
            let kind = if weighted { TargetKind::Weighted } else { TargetKind::ImportanceSampled };
            let t = target(&atlas, &f, kind);
            for k in 0..2 {
                let accept = |x: &P2| if weighted { weights(&t, x)[k] } else { (atlas.ln_density(k, x) > f64::NEG_INFINITY) as u8 as f64 };
                let exact = |r: &mut ChainRng| { let x = draw_point(&f, &accept, r); in_chart(&t, k, x, r) };
                let mut mh = MetropolisHastings::new(Level { family: &t, level: k }, InChart::new(pssmlt_kernel()));
                let inv = invariance(&exact, |s: &mut State, r: &mut ChainRng| mh_step(&t, &mut mh, s, r),
                    features(&atlas), &inv_config(3000, 3, false), &mut rng).unwrap();
                prop_assert!(inv.passed, "chart {k} weighted={weighted}: {inv}");
                let pilot: Vec<Vec<f64>> = (0..2000).map(|_| exact(&mut rng).u).collect();
                let grid = QuantileGrid::fit(&pilot, if pilot[0].len() == 2 { 5 } else { 3 });
                let ex = exchangeability(&exact, |s: &mut State, r: &mut ChainRng| mh_step(&t, &mut mh, s, r),
                    |s: &State| grid.cell(&s.u), grid.cells(),
                    &ExchangeabilityConfig { replicates: 15_000, alpha: ALPHA }, &mut rng).unwrap();
                prop_assert!(ex.passed, "chart {k} weighted={weighted}: {ex}");
            }
        }
    }

    /// The auxiliary visibility-only target (paper eq. 18): `π'_i(u) = V(T_i(u))` for a predicate
    /// `V`, sampled in each chart with PSSMLT moves; its exact law is uniform `u` given `V`.
    #[test]
    fn in_chart_moves_keep_the_visibility_target(c1 in any_chart(), threshold in 0.6f64..1.4, seed in any::<u64>()) {
        let atlas = Atlas::new(vec![c1.boxed()]);
        let f = Cells { b: 2, w: vec![1.0; 4] };
        let visible = move |x: &P2| x[0] + x[1] < threshold;
        let t = target(&atlas, &f, TargetKind::Visibility(Box::new(visible)));
        let mut rng = stream(seed, 0);
        let chart = atlas.chart(0).unwrap();
        let dim = chart.dim();
        let exact = |r: &mut ChainRng| loop {
            let u: Vec<f64> = (0..dim).map(|_| uniform(r)).collect();
            let mut s = State::in_chart(0, u);
            if t.ln_density(0, &mut s) == 0.0 {
                return s;
            }
        };
        let mut mh = MetropolisHastings::new(Level { family: &t, level: 0 }, InChart::new(pssmlt_kernel()));
        let inv = invariance(&exact, |s: &mut State, r: &mut ChainRng| mh_step(&t, &mut mh, s, r), |s: &State| s.u.clone(), &inv_config(3000, 3, false), &mut rng).unwrap();
        prop_assert!(inv.passed, "{inv}");
    }

    /// Serial tempering over the charts (+ identity) with random pseudo-priors: chart swaps are
    /// reversible, and whole steps keep the joint law of (chart, point, coordinates).
    #[test]
    fn serial_tempering_chart_swaps_keep_the_joint_law(
        c1 in any_chart(), c2 in any_chart(), f in cells(), ln_c in prop::collection::vec(-0.7f64..0.7, 3),
        with_identity in any::<bool>(), independent in any::<bool>(), seed in any::<u64>()
    ) {
        let mut atlas = Atlas::new(vec![c1.boxed(), c2.boxed()]);
        if with_identity { atlas = atlas.with_identity(); }
        let n = atlas.levels();
        let ln_c = ln_c[..n].to_vec();
        let t = target(&atlas, &f, TargetKind::Weighted);
        let mut rng = stream(seed, 0);
        let cmax = ln_c.iter().copied().fold(f64::NEG_INFINITY, f64::max).exp();
        // Joint law ∝ c_k w_k(x) f(x) q_k(u|x).
        let exact = |r: &mut ChainRng| {
            let x = draw_point(&f, &|x: &P2| weights(&t, x).iter().zip(&ln_c).map(|(w, l)| w * l.exp()).sum::<f64>() / cmax, r);
            let w: Vec<f64> = weights(&t, &x).iter().zip(&ln_c).map(|(w, l)| w * l.exp()).collect();
            let mut v = uniform(r) * w.iter().sum::<f64>();
            let mut k = n - 1;
            for (i, wi) in w.iter().enumerate() { if v < *wi { k = i; break; } v -= wi; }
            in_chart(&t, k, x, r)
        };
        let kernels: Vec<MetropolisHastings<Level<'_, Target>, Box<dyn Proposal<State>>>> = (0..n)
            .map(|k| {
                let p: Box<dyn Proposal<State>> = if k == atlas.identity() {
                    Box::new(TargetSpace::new(GaussianRandomWalk::new(0.15).unwrap()))
                } else {
                    Box::new(InChart::new(pssmlt_kernel()))
                };
                MetropolisHastings::new(Level { family: &t, level: k }, p)
            })
            .collect();
        let lp = if independent { LevelProposal::Independent((0..n).map(|k| 1.0 + k as f64).collect()) } else { LevelProposal::Neighbour };
        let mut st = SerialTempering::new(&t, kernels, exact(&mut rng), 0, Some(ln_c.clone()), lp).unwrap();
        st.level = st.chain.state.chart;
        let load = |st: &mut SerialTempering<State, &Target, _>, s: &State| {
            st.level = s.chart;
            st.chain.state.clone_from(s);
            st.chain.ln_density = t.ln_density(s.chart, &mut st.chain.state);
        };
        let inv = invariance(&exact, |s: &mut State, r: &mut ChainRng| { load(&mut st, s); st.step(r, &mut ()); s.clone_from(&st.chain.state); },
            features(&atlas), &inv_config(4000, 2, true), &mut rng).unwrap();
        prop_assert!(inv.passed, "step: {inv}");
        let pilot: Vec<Vec<f64>> = (0..2000).map(|_| exact(&mut rng).x.to_vec()).collect();
        let grid = QuantileGrid::fit(&pilot, 4);
        let ex = exchangeability(&exact, |s: &mut State, r: &mut ChainRng| { load(&mut st, s); st.level_move(r); s.clone_from(&st.chain.state); },
            |s: &State| grid.cell(&s.x).map(|c| c * n + s.chart), grid.cells() * n,
            &ExchangeabilityConfig { replicates: 15_000, alpha: ALPHA }, &mut rng).unwrap();
        prop_assert!(ex.passed, "level move: {ex}");
    }

    /// Replica exchange between a chain in each chart (weighted targets): sweeps keep the product
    /// law.
    #[test]
    fn replica_exchange_chart_swaps_keep_the_product_law(c1 in any_chart(), c2 in any_chart(), f in cells(), seed in any::<u64>()) {
        let atlas = Atlas::new(vec![c1.boxed(), c2.boxed()]);
        let t = target(&atlas, &f, TargetKind::Weighted);
        let mut rng = stream(seed, 0);
        let exact_k = |k: usize, r: &mut ChainRng| { let x = draw_point(&f, &|x: &P2| weights(&t, x)[k], r); in_chart(&t, k, x, r) };
        let exact = |r: &mut ChainRng| vec![exact_k(0, r), exact_k(1, r)];
        let kernels: Vec<_> = (0..2).map(|k| MetropolisHastings::new(Level { family: &t, level: k }, InChart::new(pssmlt_kernel()))).collect();
        let mut re = ReplicaExchange::new(&t, kernels, exact(&mut rng), SwapSchedule::StochasticEvenOdd).unwrap();
        re.local_steps = 4; // one swap every four steps, as in the paper's Table 1 runs
        let inv = invariance(&exact, |s: &mut Vec<State>, r: &mut ChainRng| {
                for (k, c) in re.chains.iter_mut().enumerate() { c.state.clone_from(&s[k]); c.ln_density = t.ln_density(k, &mut c.state); }
                re.sweep(r, &mut ());
                for (k, c) in re.chains.iter().enumerate() { s[k].clone_from(&c.state); }
            },
            |s: &Vec<State>| s.iter().flat_map(|st| { let mut v = st.x.to_vec(); v.extend(st.u.iter().take(3)); v }).collect(),
            &inv_config(3000, 2, false), &mut rng).unwrap();
        prop_assert!(inv.passed, "{inv}");
    }

    /// A target-space chain alternating inverse primary-space perturbations through each chart.
    #[test]
    fn ipsm_keeps_the_target_space_law(c1 in any_chart(), c2 in any_chart(), f in cells(), seed in any::<u64>()) {
        let atlas = Atlas::new(vec![c1.boxed(), c2.boxed()]).with_identity();
        let t = target(&atlas, &f, TargetKind::ImportanceSampled);
        let id = atlas.identity();
        let mut rng = stream(seed, 0);
        let exact = |r: &mut ChainRng| in_chart(&t, id, f.sample(r), r);
        let mix: Mixture<'_, State> = Mixture::new((0..2).map(|k| (0.5, Box::new(InversePerturbation::new(&t, k, pssmlt_kernel())) as Box<dyn Proposal<State> + Send + Sync>)).collect(), MixtureRule::PerComponent).unwrap();
        let mut mh = MetropolisHastings::new(Level { family: &t, level: id }, mix);
        let inv = invariance(&exact, |s: &mut State, r: &mut ChainRng| mh_step(&t, &mut mh, s, r),
            |s: &State| s.x.to_vec(), &inv_config(3000, 3, false), &mut rng).unwrap();
        prop_assert!(inv.passed, "{inv}");
        let pilot: Vec<Vec<f64>> = (0..2000).map(|_| exact(&mut rng).x.to_vec()).collect();
        let grid = QuantileGrid::fit(&pilot, 5);
        let ex = exchangeability(&exact, |s: &mut State, r: &mut ChainRng| mh_step(&t, &mut mh, s, r),
            |s: &State| grid.cell(&s.x), grid.cells(), &ExchangeabilityConfig { replicates: 15_000, alpha: ALPHA }, &mut rng).unwrap();
        prop_assert!(ex.passed, "{ex}");
    }
}

// ---------------------------------------------------------------------------------------------
// Broken variants.

fn broken_fixture() -> (Atlas<P2>, Cells) {
    let strata = |b| StrataChart {
        weights: vec![0.25, 0.75],
        warps: vec![
            Warp {
                a: 0.6,
                b: 1.4,
                c: 0.3,
            },
            Warp {
                a: 1.8,
                b: 0.7,
                c: -0.3,
            },
        ],
        branching: b,
    };
    let _ = strata;
    (
        Atlas::new(vec![
            Box::new(WarpChart(Warp {
                a: 1.5,
                b: 0.8,
                c: 0.2,
            })),
            Box::new(PartialChart {
                warp: Warp {
                    a: 0.7,
                    b: 1.2,
                    c: -0.2,
                },
                s: 0.8,
            }),
        ]),
        Cells {
            b: 3,
            w: vec![1.0, 3.0, 0.5, 2.0, 4.0, 1.0, 0.3, 2.5, 1.5],
        },
    )
}

fn strata_atlas(b: Branching) -> Atlas<P2> {
    Atlas::new(vec![
        Box::new(WarpChart(Warp {
            a: 1.5,
            b: 0.8,
            c: 0.2,
        })),
        Box::new(StrataChart {
            weights: vec![0.25, 0.75],
            warps: vec![
                Warp {
                    a: 0.6,
                    b: 1.4,
                    c: 0.3,
                },
                Warp {
                    a: 1.8,
                    b: 0.7,
                    c: -0.3,
                },
            ],
            branching: b,
        }),
    ])
}

/// Serial tempering between two charts (weighted targets, equal pseudo-priors): the invariance
/// verdict on (chart, point, coordinates).
fn st_verdict<F: Family<State>>(family: &F, t: &Target, seed: u64) -> bool {
    let atlas = t.atlas;
    let n = atlas.levels();
    let f_cells = Cells {
        b: 3,
        w: vec![1.0, 3.0, 0.5, 2.0, 4.0, 1.0, 0.3, 2.5, 1.5],
    };
    let mut rng = stream(seed, 0);
    let exact = |r: &mut ChainRng| {
        let x = f_cells.sample(r);
        let w = weights(t, &x);
        let k = if uniform(r) < w[0] { 0 } else { 1 };
        // The exact conditional inverse, whatever the chart under test does.
        let mut s = in_chart(t, k, x, r);
        if k == 1 && s.u.len() == 3 {
            s.u = exact_strata_inverse(&x, r);
        }
        s
    };
    let kernels: Vec<_> = (0..n)
        .map(|k| MetropolisHastings::new(Level { family, level: k }, InChart::new(pssmlt_kernel())))
        .collect();
    let mut st = SerialTempering::new(
        family,
        kernels,
        exact(&mut rng),
        0,
        None,
        LevelProposal::Neighbour,
    )
    .unwrap();
    st.level = st.chain.state.chart;
    st.local_steps = 0; // chart swaps only: their effect on the coordinates is not washed out
    invariance(
        &exact,
        |s: &mut State, r: &mut ChainRng| {
            st.level = s.chart;
            st.chain.state.clone_from(s);
            st.chain.ln_density = family.ln_density(s.chart, &mut st.chain.state);
            st.step(r, &mut ());
            s.clone_from(&st.chain.state);
        },
        features(atlas),
        &inv_config(6000, 1, true),
        &mut rng,
    )
    .unwrap()
    .passed
}

fn exact_strata_inverse(x: &P2, r: &mut ChainRng) -> Vec<f64> {
    let c = StrataChart {
        weights: vec![0.25, 0.75],
        warps: vec![
            Warp {
                a: 0.6,
                b: 1.4,
                c: 0.3,
            },
            Warp {
                a: 1.8,
                b: 0.7,
                c: -0.3,
            },
        ],
        branching: Branching::Exact,
    };
    let mut u = vec![0.0; 3];
    assert!(mcmc_charts::Chart::invert(&c, x, &mut u, r));
    u
}

#[test]
fn chart_swaps_with_an_inverse_choosing_wrong_branches_are_caught() {
    let f = broken_fixture().1;
    let verdict = |b| {
        let atlas = strata_atlas(b);
        let t = target(&atlas, &f, TargetKind::Weighted);
        st_verdict(&t, &t, 5)
    };
    assert!(verdict(Branching::Exact), "exact inverse must pass");
    assert!(
        verdict(Branching::UniformReported),
        "a biased inverse that reports its bias must pass"
    );
    assert!(
        !verdict(Branching::UniformSilently),
        "a silently biased inverse must be caught"
    );
}

/// A swap that accepts by the target values alone — with weighted targets `π_i(u) = π_j(u')` at the
/// same point, so it forgets the chart densities `p_j / p_i` and accepts every swap.
struct SwapWithoutDensities<'a>(&'a Target<'a>);

impl Family<State> for SwapWithoutDensities<'_> {
    fn levels(&self) -> usize {
        self.0.levels()
    }
    fn ln_density(&self, level: usize, x: &mut State) -> f64 {
        self.0.ln_density(level, x)
    }
    fn transfer(
        &self,
        from: usize,
        to: usize,
        x: &State,
        y: &mut State,
        rng: &mut ChainRng,
    ) -> f64 {
        let g = self.0.transfer(from, to, x, y, rng);
        if g.is_finite() { 0.0 } else { g }
    }
}

#[test]
fn a_swap_using_f_instead_of_densities_is_caught() {
    let (atlas, f) = broken_fixture();
    let t = target(&atlas, &f, TargetKind::Weighted);
    assert!(st_verdict(&t, &t, 8), "correct swap must pass");
    assert!(
        !st_verdict(&SwapWithoutDensities(&t), &t, 8),
        "swap without densities must be caught"
    );
}

#[test]
fn ipsm_forgetting_the_density_ratio_is_caught() {
    let (atlas, f) = broken_fixture();
    let atlas = atlas.with_identity();
    let t = target(&atlas, &f, TargetKind::ImportanceSampled);
    let id = atlas.identity();
    let verdict = |forget: bool| {
        let mut rng = stream(9, 0);
        let exact = |r: &mut ChainRng| in_chart(&t, id, f.sample(r), r);
        let mut p = InversePerturbation::new(&t, 0, pssmlt_kernel());
        p.forget_density_ratio = forget;
        let mut mh = MetropolisHastings::new(
            Level {
                family: &t,
                level: id,
            },
            p,
        );
        invariance(
            &exact,
            |s: &mut State, r: &mut ChainRng| mh_step(&t, &mut mh, s, r),
            |s: &State| s.x.to_vec(),
            &inv_config(4000, 3, false),
            &mut rng,
        )
        .unwrap()
        .passed
    };
    assert!(verdict(false));
    assert!(!verdict(true));
}

// ---------------------------------------------------------------------------------------------
// The moves as one Metropolis–Hastings kernel on the joint target (how a renderer runs them).

/// Exact draws of the joint law `∝ c_k w_k(x) f(x) κ_k(u|x)` (weighted targets).
fn joint_exact<'a>(
    t: &'a Target<'a>,
    f: &'a Cells,
    ln_c: &'a [f64],
) -> impl Fn(&mut ChainRng) -> State + 'a {
    let n = t.atlas.levels();
    let cmax = ln_c.iter().copied().fold(f64::NEG_INFINITY, f64::max).exp();
    move |r: &mut ChainRng| {
        let cw = |x: &P2| -> Vec<f64> {
            weights(t, x)
                .iter()
                .zip(ln_c)
                .map(|(w, l)| w * l.exp())
                .collect()
        };
        let x = draw_point(f, &|x: &P2| cw(x).iter().sum::<f64>() / cmax, r);
        let w = cw(&x);
        let k = mcmc_core::rng::categorical(&w, uniform(r)).unwrap_or(n - 1);
        in_chart(t, k, x, r)
    }
}

fn joint_step<K: Kernel<State>>(j: &JointTarget<'_>, k: &mut K, s: &mut State, rng: &mut ChainRng) {
    let l = mcmc_core::Target::evaluate(j, s);
    let mut c = Chain::unchecked(std::mem::take(s), l);
    k.step(&mut c, rng, &mut ());
    *s = c.state;
}

proptest! {
    #![proptest_config(config(8))]

    /// In-chart steps, chart swaps as proposals, IPSM through any chart and target-space moves,
    /// the last two with the Gibbs refresh of the chart, mixed into one kernel on the joint target
    /// with random pseudo-priors: whole steps keep the joint law and are reversible.
    #[test]
    fn one_kernel_of_every_move_keeps_the_joint_law(
        c1 in any_chart(), c2 in any_chart(), f in cells(), ln_c in prop::collection::vec(-0.7f64..0.7, 2), seed in any::<u64>()
    ) {
        use mcmc_charts::moves::{ChartSwap, PointMove, Refresh};
        let atlas = Atlas::new(vec![c1.boxed(), c2.boxed()]);
        let t = target(&atlas, &f, TargetKind::Weighted);
        let joint = mcmc_charts::Joint::with_weights(&t, ln_c.clone()).unwrap();
        let gibbs = Refresh::Gibbs { ln_weights: ln_c.clone() };
        let mix: Mixture<'_, State> = Mixture::new(vec![
            (0.3, Box::new(InChart::new(pssmlt_kernel())) as Box<dyn Proposal<State> + Send + Sync>),
            (0.3, Box::new(ChartSwap::new(&t, LevelProposal::Independent(vec![0.3, 0.7])))),
            (0.2, Box::new(InversePerturbation::through_any_chart(&t, pssmlt_kernel()).with_refresh(gibbs.clone()))),
            (0.2, Box::new(PointMove::new(&t, GaussianRandomWalk::new(0.15).unwrap(), gibbs))),
        ], MixtureRule::PerComponent).unwrap();
        let mut mh = MetropolisHastings::new(&joint, mix);
        let exact = joint_exact(&t, &f, &ln_c);
        let mut rng = stream(seed, 0);
        let inv = invariance(&exact, |s: &mut State, r: &mut ChainRng| joint_step(&joint, &mut mh, s, r),
            features(&atlas), &inv_config(4000, 2, true), &mut rng).unwrap();
        prop_assert!(inv.passed, "{inv}");
        let pilot: Vec<Vec<f64>> = (0..2000).map(|_| exact(&mut rng).x.to_vec()).collect();
        let grid = QuantileGrid::fit(&pilot, 4);
        let ex = exchangeability(&exact, |s: &mut State, r: &mut ChainRng| joint_step(&joint, &mut mh, s, r),
            |s: &State| grid.cell(&s.x).map(|c| c * 2 + s.chart), grid.cells() * 2,
            &ExchangeabilityConfig { replicates: 15_000, alpha: ALPHA }, &mut rng).unwrap();
        prop_assert!(ex.passed, "{ex}");
    }

    /// Chains that keep their charts (target-space moves and IPSM with the chart kept) and swap
    /// points by [`mcmc_charts::moves::exchange`]: the product law is kept.
    #[test]
    fn exchanges_and_chart_keeping_moves_keep_the_product_law(c1 in any_chart(), c2 in any_chart(), f in cells(), seed in any::<u64>()) {
        use mcmc_charts::moves::{PointMove, Refresh, exchange};
        let atlas = Atlas::new(vec![c1.boxed(), c2.boxed()]);
        let t = target(&atlas, &f, TargetKind::Weighted);
        let mut rng = stream(seed, 0);
        let exact_k = |k: usize, r: &mut ChainRng| { let x = draw_point(&f, &|x: &P2| weights(&t, x)[k], r); in_chart(&t, k, x, r) };
        let exact = |r: &mut ChainRng| vec![exact_k(0, r), exact_k(1, r)];
        let mix: Mixture<'_, State> = Mixture::new(vec![
            (0.5, Box::new(InChart::new(pssmlt_kernel())) as Box<dyn Proposal<State> + Send + Sync>),
            (0.25, Box::new(InversePerturbation::through_any_chart(&t, pssmlt_kernel()))),
            (0.25, Box::new(PointMove::new(&t, GaussianRandomWalk::new(0.15).unwrap(), Refresh::KeepChart))),
        ], MixtureRule::PerComponent).unwrap();
        let mut mh = [0, 1].map(|k| MetropolisHastings::new(Level { family: &t, level: k }, &mix));
        let inv = invariance(&exact, |s: &mut Vec<State>, r: &mut ChainRng| {
                for (k, st) in s.iter_mut().enumerate() { mh_step(&t, &mut mh[k], st, r); }
                let e = exchange(&t, &s[0], &s[1], r);
                let (a, b) = s.split_at_mut(1);
                e.apply(&mut a[0], &mut b[0]);
            },
            |s: &Vec<State>| s.iter().flat_map(|st| { let mut v = st.x.to_vec(); v.extend(st.u.iter().take(3)); v }).collect(),
            &inv_config(3000, 2, false), &mut rng).unwrap();
        prop_assert!(inv.passed, "{inv}");
    }
}

/// A Gibbs refresh is exact whatever pseudo-priors it draws the chart with (its ratio accounts
/// for the law it draws from). A target-space move that joins a chain in the charts with the
/// point chain's ratio alone — the chart and coordinate draws left out of the acceptance — is
/// caught.
#[test]
fn a_point_move_without_the_chart_terms_is_caught() {
    use mcmc_charts::moves::{PointMove, Refresh};
    struct PointRatioOnly<'a>(PointMove<'a, P2, Integrand<'a>, AnyChart, GaussianRandomWalk>);
    impl Proposal<State> for PointRatioOnly<'_> {
        fn propose(&self, x: &State, y: &mut State, rng: &mut ChainRng) -> mcmc_core::Proposed {
            let p = self.0.propose(x, y, rng);
            // The random walk's own ratio (0), as a chain on points would use it.
            mcmc_core::Proposed::with_ratio(if p.ln_ratio == f64::NEG_INFINITY {
                p.ln_ratio
            } else {
                0.0
            })
        }
    }
    let (atlas, f) = broken_fixture();
    let t = target(&atlas, &f, TargetKind::Weighted);
    let ln_c = vec![0.0, 1.5];
    let joint = mcmc_charts::Joint::with_weights(&t, ln_c.clone()).unwrap();
    let run = |p: &dyn Proposal<State>| {
        let mut mh = MetropolisHastings::new(&joint, p);
        let exact = joint_exact(&t, &f, &ln_c);
        invariance(
            &exact,
            |s: &mut State, r: &mut ChainRng| joint_step(&joint, &mut mh, s, r),
            features(&atlas),
            &inv_config(4000, 2, true),
            &mut stream(12, 0),
        )
        .unwrap()
    };
    let walk = || GaussianRandomWalk::new(0.15).unwrap();
    let gibbs = |w: Vec<f64>| Refresh::Gibbs { ln_weights: w };
    let right = run(&PointMove::new(&t, walk(), gibbs(ln_c.clone())));
    let other = run(&PointMove::new(&t, walk(), gibbs(vec![0.0, 0.0])));
    let broken = run(&PointRatioOnly(PointMove::new(
        &t,
        walk(),
        gibbs(ln_c.clone()),
    )));
    println!(
        "refresh with the joint's weights: {right}\nwith other weights: {other}\npoint ratio only: {broken}"
    );
    assert!(right.passed, "{right}");
    assert!(other.passed, "{other}");
    assert!(!broken.passed, "{broken}");
}

/// A chart swap proposal whose level proposal is skewed but whose ratio leaves it out is caught.
#[test]
fn a_chart_swap_without_its_proposal_ratio_is_caught() {
    use mcmc_charts::moves::ChartSwap;
    struct NoRatio<'a>(ChartSwap<'a, P2, Integrand<'a>, AnyChart>);
    impl Proposal<State> for NoRatio<'_> {
        fn propose(&self, x: &State, y: &mut State, rng: &mut ChainRng) -> mcmc_core::Proposed {
            let p = self.0.propose(x, y, rng);
            let (i, j) = (x.chart as f64, y.chart as f64);
            // Remove ln q(i) − ln q(j) for q = (0.1, 0.9): the ratio keeps only the densities.
            let q = |k: f64| if k == 0.0 { 0.1f64 } else { 0.9 };
            mcmc_core::Proposed::with_ratio(p.ln_ratio - (q(i).ln() - q(j).ln()))
        }
    }
    let (atlas, f) = broken_fixture();
    let t = target(&atlas, &f, TargetKind::Weighted);
    let ln_c = vec![0.0, 0.0];
    let joint = mcmc_charts::Joint::new(&t);
    let swap = || ChartSwap::new(&t, LevelProposal::Independent(vec![0.1, 0.9]));
    let run = |p: &dyn Proposal<State>| {
        let mut mh = MetropolisHastings::new(&joint, p);
        let exact = joint_exact(&t, &f, &ln_c);
        invariance(
            &exact,
            |s: &mut State, r: &mut ChainRng| joint_step(&joint, &mut mh, s, r),
            features(&atlas),
            &inv_config(4000, 1, true),
            &mut stream(13, 0),
        )
        .unwrap()
    };
    let good = run(&swap());
    let bad = run(&NoRatio(swap()));
    println!("with ratio: {good}\nwithout: {bad}");
    assert!(good.passed, "{good}");
    assert!(!bad.passed, "{bad}");
}

/// A toy outside sampler for [`mcmc_charts::moves::ChartIndependence`]: in chart `k` it draws
/// coordinate `k` of the point as `v²` (density `1/(2√x)`) and the other uniformly, and fails
/// with probability 0.3 (a sub-probability proposal, like a density-estimation merge that finds
/// no light vertex). `forget` reports the uniform density instead (deliberately wrong).
struct SquareSampler {
    forget: bool,
}

impl mcmc_charts::moves::PointSampler<P2> for SquareSampler {
    fn draw(&self, chart: usize, y: &mut P2, rng: &mut ChainRng) -> bool {
        if uniform(rng) < 0.3 {
            return false;
        }
        let (v, w) = (uniform(rng), uniform(rng));
        let k = chart.min(1);
        y[k] = v * v;
        y[1 - k] = w;
        true
    }

    fn ln_density(&self, chart: usize, x: &P2) -> f64 {
        if !inside(x) {
            return f64::NEG_INFINITY;
        }
        let c = x[chart.min(1)];
        0.7f64.ln()
            + if self.forget {
                0.0
            } else {
                -(2.0 * c.sqrt()).ln()
            }
    }

    fn name(&self) -> String {
        "square".into()
    }
}

/// Chains kept in their charts (the level targets), moved by in-chart steps and the independence
/// sampler of eqs. 28–29 (an outside sampler mixed with the chart's pushforward): both rules keep
/// each chart's law; an outside sampler that misreports its density is caught.
#[test]
fn independence_samplers_in_a_chart_keep_its_law() {
    use mcmc_charts::moves::{ChartIndependence, IndependenceRule};
    let (atlas, f) = broken_fixture();
    let t = target(&atlas, &f, TargetKind::Weighted);
    let run = |rule: IndependenceRule, forget: bool, seed: u64| {
        let mix: Mixture<'_, State> = Mixture::new(
            vec![
                (
                    0.3,
                    Box::new(InChart::new(pssmlt_kernel()))
                        as Box<dyn Proposal<State> + Send + Sync>,
                ),
                (
                    0.7,
                    Box::new(ChartIndependence::new(
                        &t,
                        SquareSampler { forget },
                        0.6,
                        rule,
                    )),
                ),
            ],
            MixtureRule::PerComponent,
        )
        .unwrap();
        let mut mh = [0, 1].map(|k| {
            MetropolisHastings::new(
                Level {
                    family: &t,
                    level: k,
                },
                &mix,
            )
        });
        let exact_k = |k: usize, r: &mut ChainRng| {
            let x = draw_point(&f, &|x: &P2| weights(&t, x)[k], r);
            in_chart(&t, k, x, r)
        };
        let exact = |r: &mut ChainRng| vec![exact_k(0, r), exact_k(1, r)];
        invariance(
            &exact,
            |s: &mut Vec<State>, r: &mut ChainRng| {
                for (k, st) in s.iter_mut().enumerate() {
                    mh_step(&t, &mut mh[k], st, r);
                }
            },
            |s: &Vec<State>| s.iter().flat_map(|st| st.x.to_vec()).collect(),
            &inv_config(4000, 2, false),
            &mut stream(seed, 0),
        )
        .unwrap()
    };
    let expected = run(IndependenceRule::Expected, false, 21);
    let per_component = run(IndependenceRule::PerComponent, false, 22);
    let forgot = run(IndependenceRule::Expected, true, 23);
    println!("eq. 29: {expected}\neq. 28: {per_component}\nmisreported density: {forgot}");
    assert!(expected.passed, "{expected}");
    assert!(per_component.passed, "{per_component}");
    assert!(!forgot.passed, "{forgot}");
}

/// A point move whose proposal fails leaves the current point in the candidate, whatever partial
/// point the proposal wrote there (a renderer's failed path mutation leaves a fragment of a path;
/// charted MLT reads a candidate's path length when a later large step's map fails too). Fails
/// without the restoring copy in `PointMove::propose`.
#[test]
fn a_failed_point_move_leaves_the_current_point_in_the_candidate() {
    use mcmc_charts::moves::{PointMove, Refresh};
    use mcmc_core::{Failure, Proposed};
    struct WritesAndFails;
    impl Proposal<P2> for WritesAndFails {
        fn propose(&self, _x: &P2, y: &mut P2, _rng: &mut ChainRng) -> Proposed {
            *y = [0.123, 0.456];
            Proposed::failed(0, Failure::Failed)
        }
    }
    let (atlas, f) = broken_fixture();
    let t = target(&atlas, &f, TargetKind::Weighted);
    let mut rng = stream(5, 0);
    for k in [0, 1] {
        let x = in_chart(&t, k, [0.3, 0.6], &mut rng);
        let mut y = in_chart(&t, k, [0.7, 0.2], &mut rng);
        let p =
            PointMove::new(&t, WritesAndFails, Refresh::KeepChart).propose(&x, &mut y, &mut rng);
        assert!(p.failure.is_some());
        assert_eq!(y.x, x.x, "chart {k}");
    }
}
