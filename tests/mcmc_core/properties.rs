//! Property tests: random targets × every kind of correct proposal pass the balance checks.
//!
//! Each statistical check runs at α = 1e-4; the properties below run about 300 checks in all, so
//! the probability that some correct kernel fails by chance is at most ≈ 3% (union bound) — and, the
//! seeds being fixed, the outcome is the same on every run.

use crate::zoo::*;
use mcmc_core::balance::exchangeability::{ExchangeabilityConfig, QuantileGrid, exchangeability};
use mcmc_core::balance::invariance::{InvarianceConfig, invariance};
use mcmc_core::balance::pointwise::check_proposal;
use mcmc_core::proposals::GaussianRandomWalk;
use mcmc_core::rng::stream;
use mcmc_core::tempering::{LevelProposal, ReplicaExchange, SerialTempering, SwapSchedule};
use mcmc_core::{ChainRng, FnFamily, Level, MetropolisHastings};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

pub const ALPHA: f64 = 1e-4;

fn config() -> Config {
    Config {
        cases: 6,
        rng_seed: RngSeed::Fixed(20261121),
        failure_persistence: None,
        ..Config::default()
    }
}

prop_compose! {
    pub fn gaussian_mixture()(dim in 1usize..=3, k in 1usize..=3)
        (weights in prop::collection::vec(0.2f64..3.0, k),
         means in prop::collection::vec(prop::collection::vec(-3.0f64..3.0, dim), k),
         sigmas in prop::collection::vec(0.4f64..1.5, k)) -> GaussianMixture {
        GaussianMixture { weights, means, sigmas }
    }
}

pub fn piecewise_constant() -> impl Strategy<Value = PiecewiseConstant> {
    (1usize..=3)
        .prop_flat_map(|dim| (Just(dim), 2usize..=(if dim == 3 { 3 } else { 4 })))
        .prop_flat_map(|(dim, bins)| {
            (
                Just(dim),
                Just(bins),
                prop::collection::vec(
                    prop_oneof![3 => 0.2f64..5.0, 1 => Just(0.0)],
                    bins.pow(dim as u32),
                ),
            )
        })
        .prop_map(|(dim, bins, mut weights)| {
            if weights.iter().all(|&w| w == 0.0) {
                weights[0] = 1.0;
            }
            PiecewiseConstant { dim, bins, weights }
        })
}

pub fn grid_for(pilot: &[Vec<f64>]) -> QuantileGrid {
    let bins = match pilot[0].len() {
        1 => 12,
        2 => 5,
        _ => 3,
    };
    QuantileGrid::fit(pilot, bins)
}

/// Run the exchangeability and invariance checks on one kernel; `Err` with the failing report.
pub fn both_checks(
    exact: &(dyn Fn(&mut ChainRng) -> Vec<f64> + Sync),
    step: &mut dyn FnMut(&mut Vec<f64>, &mut ChainRng),
    grid: &QuantileGrid,
    alpha: f64,
    rng: &mut ChainRng,
) -> Result<(), String> {
    let ex = exchangeability(
        exact,
        &mut *step,
        |x: &Vec<f64>| grid.cell(x),
        grid.cells(),
        &ExchangeabilityConfig {
            replicates: 20_000,
            alpha,
        },
        rng,
    )
    .map_err(|e| e.to_string())?;
    if !ex.passed {
        return Err(ex.to_string());
    }
    let inv = invariance(
        exact,
        &mut *step,
        |x: &Vec<f64>| x.clone(),
        &InvarianceConfig {
            replicates: 4_000,
            steps: 3,
            alpha,
            categorical: vec![],
        },
        rng,
    )
    .map_err(|e| e.to_string())?;
    if !inv.passed {
        return Err(inv.to_string());
    }
    Ok(())
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn proposals_on_real_space_keep_balance(target in gaussian_mixture(), seed in any::<u64>()) {
        let mut rng = stream(seed, 0);
        let pilot: Vec<Vec<f64>> = (0..3000).map(|_| target.sample(&mut rng)).collect();
        let grid = grid_for(&pilot);
        let starts: Vec<Vec<f64>> = pilot[..200].to_vec();
        for (name, proposal) in real_proposals(0.8, target.dim()) {
            if proposal.ln_move_density(&starts[0], &starts[1], 0).is_some() {
                let r = check_proposal(&target, &proposal, &starts, 1e-9, &mut rng).unwrap();
                prop_assert!(r.passed, "{name}: {r}");
            }
            let mut step = stepper(&target, proposal);
            let t = target.clone();
            let res = both_checks(&move |r: &mut ChainRng| t.sample(r), &mut step, &grid, ALPHA, &mut rng);
            prop_assert!(res.is_ok(), "{name} on {target:?}: {}", res.unwrap_err());
        }
    }

    #[test]
    fn proposals_on_the_unit_cube_keep_balance(target in piecewise_constant(), seed in any::<u64>()) {
        let mut rng = stream(seed, 0);
        let pilot: Vec<Vec<f64>> = (0..3000).map(|_| target.sample(&mut rng)).collect();
        let grid = grid_for(&pilot);
        for (name, proposal) in cube_proposals() {
            let mut step = stepper(&target, proposal);
            let t = target.clone();
            let res = both_checks(&move |r: &mut ChainRng| t.sample(r), &mut step, &grid, ALPHA, &mut rng);
            prop_assert!(res.is_ok(), "{name} on {target:?}: {}", res.unwrap_err());
        }
    }

    #[test]
    fn replica_exchange_sweeps_keep_every_level(
        levels in prop::collection::vec(gaussian_mixture().prop_filter("1D", |m| m.dim() == 1), 2..=4),
        deterministic in any::<bool>(),
        seed in any::<u64>(),
    ) {
        let mut rng = stream(seed, 0);
        let family = FnFamily::new(levels.len(), |k: usize, x: &Vec<f64>| levels[k].ln_pdf(x));
        let kernels: Vec<_> = (0..levels.len())
            .map(|k| MetropolisHastings::new(Level { family: &family, level: k }, GaussianRandomWalk::new(0.7).unwrap()))
            .collect();
        let init: Vec<Vec<f64>> = levels.iter().map(|m| m.sample(&mut rng)).collect();
        let schedule = if deterministic { SwapSchedule::DeterministicEvenOdd } else { SwapSchedule::StochasticEvenOdd };
        let mut re = ReplicaExchange::new(&family, kernels, init, schedule).unwrap();
        let exact = |r: &mut ChainRng| levels.iter().map(|m| m.sample(r)).collect::<Vec<Vec<f64>>>();
        let load = |re: &mut ReplicaExchange<Vec<f64>, _, _>, xs: &[Vec<f64>]| {
            for (k, c) in re.chains.iter_mut().enumerate() {
                c.state.clone_from(&xs[k]);
                c.ln_density = levels[k].ln_pdf(&xs[k]);
            }
        };
        // The full sweep (local moves, then swaps) is not reversible but must keep the product law.
        let inv = invariance(
            exact,
            |xs: &mut Vec<Vec<f64>>, r: &mut ChainRng| {
                load(&mut re, xs);
                re.sweep(r, &mut ());
                for (k, c) in re.chains.iter().enumerate() { xs[k].clone_from(&c.state); }
            },
            |xs: &Vec<Vec<f64>>| xs.iter().map(|x| x[0]).collect(),
            &InvarianceConfig { replicates: 4_000, steps: 2, alpha: ALPHA, categorical: vec![] },
            &mut rng,
        ).unwrap();
        prop_assert!(inv.passed, "sweep: {inv}");
        // One stochastic even/odd swap round alone is reversible.
        if !deterministic {
            let pilot: Vec<Vec<f64>> = (0..3000).map(|_| exact(&mut rng).into_iter().flatten().collect()).collect();
            let grid = QuantileGrid::fit(&pilot, if levels.len() == 2 { 5 } else { 3 });
            let ex = exchangeability(
                |r: &mut ChainRng| exact(r).into_iter().flatten().collect::<Vec<f64>>(),
                |flat: &mut Vec<f64>, r: &mut ChainRng| {
                    let xs: Vec<Vec<f64>> = flat.iter().map(|&v| vec![v]).collect();
                    load(&mut re, &xs);
                    re.swap_round(r);
                    for (k, c) in re.chains.iter().enumerate() { flat[k] = c.state[0]; }
                },
                |x: &Vec<f64>| grid.cell(x),
                grid.cells(),
                &ExchangeabilityConfig { replicates: 20_000, alpha: ALPHA },
                &mut rng,
            ).unwrap();
            prop_assert!(ex.passed, "swap round: {ex}");
        }
    }

    #[test]
    fn serial_tempering_steps_keep_the_joint_law(
        levels in prop::collection::vec(gaussian_mixture().prop_filter("1D", |m| m.dim() == 1), 2..=4),
        ln_w in prop::collection::vec(-1.0f64..1.0, 4),
        independent_levels in any::<bool>(),
        seed in any::<u64>(),
    ) {
        let n = levels.len();
        let ln_w = ln_w[..n].to_vec();
        let mut rng = stream(seed, 0);
        let family = FnFamily::new(n, |k: usize, x: &Vec<f64>| levels[k].ln_pdf(x));
        let kernels: Vec<_> = (0..n)
            .map(|k| MetropolisHastings::new(Level { family: &family, level: k }, GaussianRandomWalk::new(0.7).unwrap()))
            .collect();
        let lp = if independent_levels {
            LevelProposal::Independent((0..n).map(|k| 1.0 + k as f64).collect())
        } else {
            LevelProposal::Neighbour
        };
        let mut st = SerialTempering::new(&family, kernels, levels[0].sample(&mut rng), 0, Some(ln_w.clone()), lp).unwrap();
        // Exact joint law: level k with probability ∝ c_k (levels are normalised), then x ~ π_k.
        let c: Vec<f64> = ln_w.iter().map(|l| l.exp()).collect();
        let ctot: f64 = c.iter().sum();
        let exact = |r: &mut ChainRng| {
            let mut u = mcmc_core::rng::uniform(r) * ctot;
            let mut k = n - 1;
            for (i, w) in c.iter().enumerate() { if u < *w { k = i; break; } u -= w; }
            (levels[k].sample(r), k)
        };
        let inv = invariance(
            exact,
            |s: &mut (Vec<f64>, usize), r: &mut ChainRng| {
                st.chain.state.clone_from(&s.0);
                st.level = s.1;
                st.chain.ln_density = levels[s.1].ln_pdf(&s.0);
                st.step(r, &mut ());
                s.0.clone_from(&st.chain.state);
                s.1 = st.level;
            },
            |s: &(Vec<f64>, usize)| {
                let mut f = vec![s.1 as f64];
                f.extend((0..n).map(|k| if k == s.1 { s.0[0] } else { f64::NAN }));
                f
            },
            &InvarianceConfig { replicates: 6_000, steps: 2, alpha: ALPHA, categorical: vec![0] },
            &mut rng,
        ).unwrap();
        prop_assert!(inv.passed, "{inv}");
    }
}
