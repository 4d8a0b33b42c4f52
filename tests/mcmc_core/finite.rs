//! Exact checks on finite state spaces, through the same ratio, acceptance, swap and level-move
//! code the samplers run.

use mcmc_core::balance::finite::{
    TableProposal, TransitionMatrix, level_move_matrix, mh_matrix, product_matrix, swap_matrix,
    tuple_of,
};
use mcmc_core::proposals::{Mixture, MixtureRule, Selection};
use mcmc_core::tempering::{LevelProposal, ReplicaExchange, SerialTempering, SwapSchedule};
use mcmc_core::{FnFamily, Level, MetropolisHastings, Proposal};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

const TOL: f64 = 1e-12;

fn config() -> Config {
    Config {
        cases: 32,
        rng_seed: RngSeed::Fixed(7),
        failure_persistence: None,
        ..Config::default()
    }
}

/// A random proposal matrix on `n` states: random rows supported on random subsets.
fn random_rows(n: usize) -> impl Strategy<Value = Vec<Vec<(usize, f64)>>> {
    prop::collection::vec(
        prop::collection::vec(prop_oneof![1 => Just(0.0), 3 => 0.05f64..1.0], n),
        n,
    )
    .prop_map(move |m| {
        m.into_iter()
            .enumerate()
            .map(|(i, mut row)| {
                // Neighbours on a ring in both directions keep the MH chain irreducible (a move
                // whose reverse has zero probability is always rejected).
                row[(i + 1) % n] += 0.1;
                row[(i + n - 1) % n] += 0.1;
                let s: f64 = row.iter().sum();
                row.iter()
                    .enumerate()
                    .filter(|(_, p)| **p > 0.0)
                    .map(|(j, p)| (j, p / s))
                    .collect()
            })
            .collect()
    })
}

fn ln_pi(pi: &[f64]) -> impl Fn(&usize) -> f64 + Clone + '_ {
    move |x: &usize| pi[*x].ln()
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn mh_with_any_asymmetric_proposal_is_exactly_reversible(
        (pi, rows) in (2usize..=6).prop_flat_map(|n| (prop::collection::vec(0.05f64..1.0, n), random_rows(n)))
    ) {
        let n = pi.len();
        let q = TableProposal::new(rows).unwrap();
        let target = ln_pi(&pi);
        let m = mh_matrix(&target, &q, n).unwrap();
        let r = m.check(&pi, TOL, true);
        prop_assert!(r.passed, "{r}");
        // The same proposal reporting a zero ratio breaks balance unless it happens to be symmetric.
        let broken = mh_matrix(&target, &q.clone().treated_as_symmetric(), n).unwrap();
        let symmetric = (0..n).all(|x| (0..n).all(|y| {
            let (a, b) = (q.ln_transition_density(&x, &y).unwrap(), q.ln_transition_density(&y, &x).unwrap());
            a == b || (a.exp() - b.exp()).abs() < 1e-15
        }));
        prop_assert_eq!(broken.check(&pi, TOL, true).passed, symmetric);
    }

    #[test]
    fn mixtures_under_both_rules_are_exactly_reversible(
        (pi, r1, r2, w) in (2usize..=5).prop_flat_map(|n| (prop::collection::vec(0.05f64..1.0, n), random_rows(n), random_rows(n), 0.05f64..0.95))
    ) {
        let n = pi.len();
        let target = ln_pi(&pi);
        for rule in [MixtureRule::PerComponent, MixtureRule::Combined] {
            let mix: Mixture<'_, usize> = Mixture::new(vec![
                (w, Box::new(TableProposal::new(r1.clone()).unwrap()) as _),
                (1.0 - w, Box::new(TableProposal::new(r2.clone()).unwrap()) as _),
            ], rule).unwrap();
            let r = mh_matrix(&target, &mix, n).unwrap().check(&pi, TOL, true);
            prop_assert!(r.passed, "{rule:?}: {r}");
        }
    }
}

/// Up and down moves on a ring, each reporting a zero ratio (only the pair is symmetric, and only
/// with equal weights): the combined rule is exact for any weights, the per-component rule is not.
#[test]
fn directional_moves_need_the_combined_rule() {
    let n = 5;
    let pi: Vec<f64> = (1..=n).map(|i| i as f64).collect();
    let up = TableProposal::new((0..n).map(|i| vec![((i + 1) % n, 1.0)]).collect())
        .unwrap()
        .treated_as_symmetric();
    let down = TableProposal::new((0..n).map(|i| vec![((i + n - 1) % n, 1.0)]).collect())
        .unwrap()
        .treated_as_symmetric();
    let target = ln_pi(&pi);
    let mk = |rule| -> Mixture<'_, usize> {
        Mixture::new(
            vec![
                (0.7, Box::new(up.clone()) as _),
                (0.3, Box::new(down.clone()) as _),
            ],
            rule,
        )
        .unwrap()
    };
    let good = mh_matrix(&target, &mk(MixtureRule::Combined), n)
        .unwrap()
        .check(&pi, TOL, true);
    let bad = mh_matrix(&target, &mk(MixtureRule::PerComponent), n)
        .unwrap()
        .check(&pi, TOL, true);
    assert!(good.passed, "{good}");
    assert!(!bad.passed, "{bad}");
    println!("combined: {good}\nper-component: {bad}");
}

#[test]
fn a_kernel_that_cannot_leave_a_state_is_reducible() {
    let pi = [0.2, 0.3, 0.5];
    let stuck = TableProposal::new(vec![vec![(0, 1.0)], vec![(2, 1.0)], vec![(1, 1.0)]]).unwrap();
    let r = mh_matrix(&ln_pi(&pi), &stuck, 3)
        .unwrap()
        .check(&pi, TOL, true);
    assert!(!r.passed && r.detail.contains("irreducible false"), "{r}");
}

fn family_of(pis: &[Vec<f64>]) -> FnFamily<impl Fn(usize, &usize) -> f64 + '_> {
    FnFamily::new(pis.len(), move |k: usize, x: &usize| pis[k][*x].ln())
}

fn ring_walk(n: usize) -> TableProposal {
    TableProposal::new(
        (0..n)
            .map(|i| vec![((i + 1) % n, 0.5), ((i + n - 1) % n, 0.5)])
            .collect(),
    )
    .unwrap()
}

/// Replica exchange on 3 levels over 3 states: each swap and the stochastic even/odd round are
/// reversible for the product law; the deterministic even/odd schedule (even round then odd round)
/// keeps the product law but is not reversible; a full sweep keeps it.
#[test]
fn replica_exchange_exact() {
    let n = 3;
    let pis = vec![
        vec![0.7, 0.2, 0.1],
        vec![0.3, 0.3, 0.4],
        vec![0.1, 0.1, 0.8],
    ];
    let fam = family_of(&pis);
    let q = ring_walk(n);
    let kernels: Vec<_> = (0..3)
        .map(|k| {
            MetropolisHastings::new(
                Level {
                    family: &fam,
                    level: k,
                },
                q.clone(),
            )
        })
        .collect();
    let mut re = ReplicaExchange::new(
        &fam,
        kernels,
        vec![0, 0, 0],
        SwapSchedule::DeterministicEvenOdd,
    )
    .unwrap();
    let joint: Vec<f64> = (0..n * n * n)
        .map(|i| {
            tuple_of(i, n, 3)
                .iter()
                .enumerate()
                .map(|(k, &x)| pis[k][x])
                .product()
        })
        .collect();
    let even = swap_matrix(&mut re, n, 0);
    let odd = swap_matrix(&mut re, n, 1);
    for (name, m) in [("swap (0,1)", &even), ("swap (1,2)", &odd)] {
        let r = m.check(&joint, TOL, true);
        // A lone swap cannot reach every tuple: check balance and stationarity only.
        assert!(r.statistic <= TOL, "{name}: {r}");
    }
    let stochastic = even.mix(0.5, &odd);
    assert!(stochastic.detailed_balance_error(&joint) <= TOL);
    let deo = even.then(&odd);
    assert!(deo.stationarity_error(&joint) <= TOL);
    assert!(
        deo.detailed_balance_error(&joint) > 1e-3,
        "DEO is expected to be non-reversible"
    );
    let local: Vec<TransitionMatrix> = (0..3)
        .map(|k| mh_matrix(&|x: &usize| pis[k][*x].ln(), &q, n).unwrap())
        .collect();
    let sweep = product_matrix(&local).then(&deo);
    let r = sweep.check(&joint, TOL, false);
    assert!(r.passed, "{r}");
}

/// Serial tempering over (x, level): the level move is exactly reversible for `c_k π_k(x)`, and so
/// is the local move; dropping the pseudo-prior breaks it.
#[test]
fn serial_tempering_exact() {
    let n = 3;
    let pis = vec![
        vec![0.7, 0.2, 0.1],
        vec![0.3, 0.3, 0.4],
        vec![0.1, 0.1, 0.8],
    ];
    let ln_w = vec![0.0, 1.0, -0.5];
    let fam = family_of(&pis);
    let q = ring_walk(n);
    let kernels: Vec<_> = (0..3)
        .map(|k| {
            MetropolisHastings::new(
                Level {
                    family: &fam,
                    level: k,
                },
                q.clone(),
            )
        })
        .collect();
    let mut st = SerialTempering::new(
        &fam,
        kernels,
        0,
        0,
        Some(ln_w.clone()),
        LevelProposal::Neighbour,
    )
    .unwrap();
    let joint: Vec<f64> = (0..n * 3)
        .map(|i| ln_w[i % 3].exp() * pis[i % 3][i / 3])
        .collect();
    let levels = level_move_matrix(&mut st, n);
    let r = levels.check(&joint, TOL, true);
    assert!(r.statistic <= TOL, "{r}");
    let local = TransitionMatrix::from_rows(n * 3, |i| {
        let (x, k) = (i / 3, i % 3);
        let m = mh_matrix(&|y: &usize| pis[k][*y].ln(), &q, n).unwrap();
        (0..n).map(|y| (y * 3 + k, m.get(x, y))).collect()
    });
    let r = local.then(&levels).check(&joint, TOL, false);
    assert!(r.passed, "{r}");
    st.ln_weights = vec![0.0; 3];
    assert!(
        level_move_matrix(&mut st, n)
            .check(&joint, TOL, true)
            .statistic
            > 1e-3
    );
}

/// A table proposal that only applies where `suits[x] > 0` (its suitability).
#[derive(Clone, Debug)]
struct Suited {
    table: TableProposal,
    suits: Vec<f64>,
}

impl Proposal<usize> for Suited {
    fn propose(
        &self,
        x: &usize,
        y: &mut usize,
        rng: &mut mcmc_core::ChainRng,
    ) -> mcmc_core::Proposed {
        self.table.propose(x, y, rng)
    }
    fn ln_transition_density(&self, from: &usize, to: &usize) -> Option<f64> {
        self.table.ln_transition_density(from, to)
    }
    fn outcomes(&self, x: &usize) -> Option<Vec<mcmc_core::Outcome<usize>>> {
        self.table.outcomes(x)
    }
    fn suitability(&self, x: &usize) -> f64 {
        self.suits[*x]
    }
}

/// Chooses components by suitability but reports only the chosen component's own ratio,
/// forgetting that the selection probabilities depend on the state (deliberately broken).
struct SelectionRatioForgotten(Vec<(f64, Suited)>);

impl Proposal<usize> for SelectionRatioForgotten {
    fn propose(
        &self,
        _: &usize,
        _: &mut usize,
        _: &mut mcmc_core::ChainRng,
    ) -> mcmc_core::Proposed {
        unreachable!("only enumerated")
    }
    fn outcomes(&self, x: &usize) -> Option<Vec<mcmc_core::Outcome<usize>>> {
        let total: f64 = self.0.iter().map(|(w, c)| w * c.suitability(x)).sum();
        let mut out = Vec::new();
        for (w, c) in &self.0 {
            let p = w * c.suitability(x) / total;
            if p > 0.0 {
                for mut o in c.outcomes(x)? {
                    o.probability *= p;
                    out.push(o);
                }
            }
        }
        Some(out)
    }
}

fn suitabilities(n: usize) -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(prop_oneof![1 => Just(0.0), 3 => 0.1f64..2.0], n)
}

proptest! {
    #![proptest_config(config())]

    /// Mixtures choosing components in proportion to their suitability for the current state are
    /// exactly reversible under both rules (the state-dependent selection probabilities are in the
    /// ratio); the same selection without them in the ratio is not.
    #[test]
    fn suitability_weighted_mixtures_are_exactly_reversible(
        (pi, r1, r2, s1, w) in (3usize..=6).prop_flat_map(|n| (
            prop::collection::vec(0.05f64..1.0, n), random_rows(n), random_rows(n), suitabilities(n), 0.05f64..0.95))
    ) {
        let n = pi.len();
        let target = ln_pi(&pi);
        // The second component suits every state, so some move is always possible.
        let a = Suited { table: TableProposal::new(r1).unwrap(), suits: s1.clone() };
        let b = Suited { table: TableProposal::new(r2).unwrap(), suits: (0..n).map(|i| 0.5 + i as f64).collect() };
        for rule in [MixtureRule::PerComponent, MixtureRule::Combined] {
            let mix: Mixture<'_, usize> = Mixture::new(vec![
                (w, Box::new(a.clone()) as _),
                (1.0 - w, Box::new(b.clone()) as _),
            ], rule).unwrap().with_selection(Selection::Suitability);
            let r = mh_matrix(&target, &mix, n).unwrap().check(&pi, TOL, true);
            prop_assert!(r.passed, "{rule:?}: {r}");
        }
        if s1.iter().all(|&s| s == 0.0) {
            return Ok(());
        }
        let broken = SelectionRatioForgotten(vec![(w, a), (1.0 - w, b)]);
        let r = mh_matrix(&target, &broken, n).unwrap().check(&pi, TOL, true);
        // Balance holds by accident only if the selection probability of every used move is
        // the same at both ends; with distinct suitabilities per state it never is.
        prop_assert!(!r.passed, "the forgotten selection ratio was not caught: {r}");
    }
}

/// A mixture whose components all refuse a state counts a not-applicable proposal and stays.
#[test]
fn a_mixture_with_no_suitable_component_stays_and_counts_it() {
    let table = TableProposal::new(vec![vec![(1, 1.0)], vec![(0, 1.0)]]).unwrap();
    let never = Suited {
        table,
        suits: vec![0.0, 0.0],
    };
    let mix: Mixture<'_, usize> =
        Mixture::new(vec![(1.0, Box::new(never) as _)], MixtureRule::PerComponent)
            .unwrap()
            .with_selection(Selection::Suitability);
    let target = |x: &usize| -(*x as f64);
    let mut mh = MetropolisHastings::new(target, mix);
    let mut chain = mcmc_core::Chain::start(&target, 0usize).unwrap();
    mcmc_core::Kernel::run(&mut mh, &mut chain, 10, &mut mcmc_core::rng::stream(1, 0));
    assert_eq!(chain.state, 0);
    let t = chain.stats.total();
    assert_eq!((t.proposed, t.not_applicable, t.accepted), (10, 10, 0));
}
