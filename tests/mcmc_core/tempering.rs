//! Tempering ladders: exact round trips, swap acceptance at stationarity, weight adaptation.

use mcmc_core::balance::tempering::{deo_round_trips_all_accepted, expected_swap_acceptance};
use mcmc_core::proposals::GaussianRandomWalk;
use mcmc_core::rng::stream;
use mcmc_core::tempering::{
    Adaptation, LevelProposal, ReplicaExchange, SerialTempering, SwapSchedule,
};
use mcmc_core::{ChainRng, FnFamily, Level, MetropolisHastings};
use rand::RngExt;
use rand_distr::StandardNormal;

/// With identical targets at every level every swap is accepted; the non-reversible schedule then
/// moves replicas ballistically and the round-trip count is known exactly.
#[test]
fn round_trips_are_exact_when_every_swap_is_accepted() {
    for levels in [2usize, 3, 5, 8] {
        let fam = FnFamily::new(levels, |_k: usize, x: &Vec<f64>| -0.5 * x[0] * x[0]);
        let kernels: Vec<_> = (0..levels)
            .map(|k| {
                MetropolisHastings::new(
                    Level {
                        family: &fam,
                        level: k,
                    },
                    GaussianRandomWalk::new(1.0).unwrap(),
                )
            })
            .collect();
        let mut re = ReplicaExchange::new(
            &fam,
            kernels,
            vec![vec![0.3]; levels],
            SwapSchedule::DeterministicEvenOdd,
        )
        .unwrap();
        let mut rng = stream(1, 0);
        let rounds = 1000;
        for _ in 0..rounds {
            re.sweep(&mut rng, &mut ());
        }
        assert!(re.swaps.iter().all(|s| s.accepted == s.attempted));
        assert_eq!(
            re.round_trips.total(),
            deo_round_trips_all_accepted(levels, rounds),
            "levels {levels}"
        );
    }
}

/// The observed acceptance of each pair, from replicas drawn exactly from the product law and
/// swapped once, agrees with an independent Monte Carlo estimate of E[min(1, r)]. Both are means of
/// 20 000 independent terms; |difference| < 5 combined standard errors (false-failure rate < 1e-6
/// per pair).
#[test]
fn swap_acceptance_matches_its_stationary_expectation() {
    let sig = [0.5f64, 1.0, 2.0, 4.0];
    let fam = FnFamily::new(4, |k: usize, x: &Vec<f64>| -0.5 * (x[0] / sig[k]).powi(2));
    let exact = |k: usize, r: &mut ChainRng| vec![sig[k] * r.sample::<f64, _>(StandardNormal)];
    let kernels: Vec<_> = (0..4)
        .map(|k| {
            MetropolisHastings::new(
                Level {
                    family: &fam,
                    level: k,
                },
                GaussianRandomWalk::new(1.0).unwrap(),
            )
        })
        .collect();
    let mut re = ReplicaExchange::new(
        &fam,
        kernels,
        vec![vec![0.0]; 4],
        SwapSchedule::DeterministicEvenOdd,
    )
    .unwrap();
    let mut rng = stream(5, 0);
    let draws = 20_000;
    for _ in 0..draws {
        for k in 0..3 {
            for l in [k, k + 1] {
                re.chains[l].state = exact(l, &mut rng);
                re.chains[l].ln_density = -0.5 * (re.chains[l].state[0] / sig[l]).powi(2);
            }
            re.try_swap(k, &mut rng);
        }
    }
    for k in 0..3 {
        let (e, se) = expected_swap_acceptance(&fam, k, exact, draws, &mut stream(6, k as u64));
        let s = re.swaps[k];
        let obs = s.mean_acceptance();
        let se_obs = (obs * (1.0 - obs) / s.attempted as f64).sqrt();
        println!(
            "pair ({k},{}): observed {obs:.4}, expected {e:.4} ± {se:.4}",
            k + 1
        );
        assert!((obs - e).abs() < 5.0 * (se * se + se_obs * se_obs).sqrt());
    }
}

/// Weight adaptation finds `c_k ∝ 1/Z_k` for unnormalised levels whose masses differ by e^6, and
/// the chain then spends about equal time per level. Tolerances are generous multiples of the
/// run-to-run spread measured over seeds (weights within 0.35 nats, time fractions within 0.1).
#[test]
fn serial_tempering_adapts_weights_to_equal_time() {
    // Level k: Z_k = e^{2k} · sqrt(2π) σ_k.
    let sig = [0.5f64, 1.0, 2.0, 4.0];
    let fam = FnFamily::new(4, |k: usize, x: &Vec<f64>| {
        2.0 * k as f64 - 0.5 * (x[0] / sig[k]).powi(2)
    });
    let kernels: Vec<_> = (0..4)
        .map(|k| {
            MetropolisHastings::new(
                Level {
                    family: &fam,
                    level: k,
                },
                GaussianRandomWalk::new(sig[k]).unwrap(),
            )
        })
        .collect();
    let mut st =
        SerialTempering::new(&fam, kernels, vec![0.0], 0, None, LevelProposal::Neighbour).unwrap();
    st.adaptation = Some(Adaptation {
        gamma0: 1.0,
        t0: 1000.0,
        warmup: 200_000,
    });
    let mut rng = stream(11, 0);
    for _ in 0..400_000 {
        st.step(&mut rng, &mut ());
    }
    let ln_z: Vec<f64> = (0..4).map(|k| 2.0 * k as f64 + sig[k].ln()).collect();
    let offset = st.ln_weights[0] + ln_z[0];
    for (k, (w, z)) in st.ln_weights.iter().zip(&ln_z).enumerate() {
        let err = w + z - offset;
        assert!(
            err.abs() < 0.35,
            "level {k}: ln c + ln Z off by {err:.3}; weights {:?}",
            st.ln_weights
        );
    }
    for (k, t) in st.time_per_level().iter().enumerate() {
        assert!((t - 0.25).abs() < 0.1, "level {k}: time fraction {t:.3}");
    }
    assert!(st.round_trips.total() > 100);
}

/// A level whose density is NaN in part of the space: swaps into it are rejected and counted as
/// invalid, never accepted, and the counters stay finite.
#[test]
fn invalid_swaps_are_counted_and_rejected() {
    let fam = FnFamily::new(2, |k: usize, x: &Vec<f64>| {
        if k == 1 && x[0] > 1.0 {
            f64::NAN
        } else {
            -0.5 * x[0] * x[0]
        }
    });
    let kernels: Vec<_> = (0..2)
        .map(|k| {
            MetropolisHastings::new(
                Level {
                    family: &fam,
                    level: k,
                },
                GaussianRandomWalk::new(1.0).unwrap(),
            )
        })
        .collect();
    let mut re = ReplicaExchange::new(
        &fam,
        kernels,
        vec![vec![0.0]; 2],
        SwapSchedule::StochasticEvenOdd,
    )
    .unwrap();
    let mut rng = stream(2, 0);
    for _ in 0..5000 {
        re.sweep(&mut rng, &mut ());
        assert!(re.chains[1].state[0] <= 1.0);
    }
    let s = re.swaps[0];
    assert!(s.invalid > 50, "{s:?}");
    assert!(s.acceptance_sum.is_finite() && s.accepted > 0);
}
