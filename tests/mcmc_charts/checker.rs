//! The chart checker accepts every chart that honours the contract and rejects inverses that pick
//! branches with the wrong probabilities and densities that are off.

use crate::charts::*;
use mcmc_charts::Chart;
use mcmc_charts::checker::{CheckerConfig, DensityReference, check_chart};
use mcmc_core::ChainRng;
use mcmc_core::rng::{stream, uniform};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

fn dist(a: &P2, b: &P2) -> f64 {
    (a[0] - b[0]).abs().max((a[1] - b[1]).abs())
}

fn cell4(x: &P2) -> Option<usize> {
    inside(x).then(|| ((x[0] * 4.0) as usize).min(3) * 4 + ((x[1] * 4.0) as usize).min(3))
}

fn sample_square(rng: &mut ChainRng) -> P2 {
    [uniform(rng), uniform(rng)]
}

pub fn reference() -> DensityReference<'static, P2> {
    DensityReference {
        sample: &sample_square,
        ln_density: &|_| 0.0,
        cell: &cell4,
        cells: 16,
    }
}

pub fn run(chart: &dyn Chart<P2>, seed: u64) -> mcmc_charts::checker::ChartReport {
    let cfg = CheckerConfig {
        samples: 40_000,
        alpha: 1e-4,
        tolerance: 1e-9,
    };
    check_chart(chart, &dist, Some(&reference()), &cfg, &mut stream(seed, 0)).unwrap()
}

proptest! {
    #![proptest_config(Config { cases: 24, rng_seed: RngSeed::Fixed(3), failure_persistence: None, ..Config::default() })]

    /// 24 random charts × 3 tests at α = 1e-4: false-failure probability ≤ 0.8%.
    #[test]
    fn every_kind_of_exact_chart_passes(chart in any_chart(), seed in any::<u64>()) {
        let r = run(chart.boxed().as_ref(), seed);
        prop_assert!(r.passed(), "{chart:?}\n{r}");
    }

    #[test]
    fn branches_chosen_with_wrong_probabilities_are_caught(chart in strata(Branching::UniformSilently), seed in any::<u64>()) {
        // Skip near-degenerate draws where uniform branch choice is almost right everywhere: the
        // branch shares must differ by a clear margin somewhere.
        let r = run(&chart, seed);
        prop_assert!(r.round_trip.passed, "the round trip is still exact: {r}");
        prop_assert!(!r.inverse_uniformity.passed, "{chart:?}\n{r}");
    }
}

/// A chart whose density forgets a factor of 2 on half the square.
struct WrongDensity(WarpChart);

impl Chart<P2> for WrongDensity {
    fn dim(&self) -> usize {
        2
    }
    fn forward(&self, u: &[f64], x: &mut P2) -> bool {
        self.0.forward(u, x)
    }
    fn ln_density(&self, x: &P2) -> f64 {
        self.0.ln_density(x) + if x[0] < 0.5 { 2f64.ln() } else { 0.0 }
    }
    fn invert(&self, x: &P2, u: &mut [f64], rng: &mut ChainRng) -> bool {
        self.0.invert(x, u, rng)
    }
}

#[test]
fn a_wrong_density_is_caught() {
    let c = WrongDensity(WarpChart(Warp {
        a: 1.3,
        b: 0.8,
        c: 0.2,
    }));
    let r = run(&c, 1);
    assert!(r.round_trip.passed && r.inverse_uniformity.passed);
    assert!(!r.density.as_ref().unwrap().passed, "{r}");
}

/// A forward map and inverse that disagree (the inverse of another warp) fail the round trip.
struct MismatchedInverse;

impl Chart<P2> for MismatchedInverse {
    fn dim(&self) -> usize {
        2
    }
    fn forward(&self, u: &[f64], x: &mut P2) -> bool {
        *x = Warp {
            a: 1.3,
            b: 0.8,
            c: 0.2,
        }
        .map(u[0], u[1]);
        true
    }
    fn ln_density(&self, x: &P2) -> f64 {
        Warp {
            a: 1.3,
            b: 0.8,
            c: 0.2,
        }
        .ln_density(x)
    }
    fn invert(&self, x: &P2, u: &mut [f64], _: &mut ChainRng) -> bool {
        u.copy_from_slice(
            &Warp {
                a: 1.3,
                b: 0.8,
                c: 0.25,
            }
            .inv(x),
        );
        true
    }
}

#[test]
fn a_mismatched_inverse_fails_the_round_trip() {
    assert!(!run(&MismatchedInverse, 2).round_trip.passed);
}
