//! The lazy primary-sample state and Kelemen's small/large steps keep a black box's target, even
//! when which coordinates are read depends on the state (so coordinates go stale, are caught up by
//! missed small steps, or are replaced by missed large steps); and an asymmetric variant is caught.

use crate::properties::ALPHA;
use mcmc_core::balance::exchangeability::{ExchangeabilityConfig, QuantileGrid, exchangeability};
use mcmc_core::balance::invariance::{InvarianceConfig, invariance};
use mcmc_core::primary_sample::{Kelemen, PrimarySample};
use mcmc_core::proposals::SmallStep;
use mcmc_core::proposals::wrap;
use mcmc_core::rng::{stream, uniform};
use mcmc_core::{Chain, ChainRng, Kernel, MetropolisHastings, Proposal, Proposed, Target};

/// `Ψ(ξ)`: reads ξ0 and then ξ1 (if ξ0 > 0.4) or ξ2 and ξ3 (otherwise).
#[derive(Clone, Copy)]
struct BlackBox;

impl BlackBox {
    fn value(x0: f64, x1: f64, x2: f64, x3: f64) -> f64 {
        if x0 > 0.4 {
            (1.0 + 3.0 * x0) * (0.2 + (6.0 * x1).sin().powi(2))
        } else {
            (0.5 + x0) * (0.1 + x2 * x3 * 4.0)
        }
    }
}

impl Target<PrimarySample> for BlackBox {
    fn ln_density(&self, _x: &PrimarySample) -> f64 {
        unreachable!("the kernel evaluates through `evaluate`")
    }
    fn evaluate(&self, x: &mut PrimarySample) -> f64 {
        let x0 = x.get(0, 0);
        let v = if x0 > 0.4 {
            BlackBox::value(x0, x.get(0, 1), 0.0, 0.0)
        } else {
            BlackBox::value(x0, 0.0, x.get(1, 0), x.get(1, 1))
        };
        v.ln()
    }
}

const BOUND: f64 = 4.0 * 1.2;

/// Exact draw of all four coordinates (the unread ones are uniform) by rejection.
fn exact(rng: &mut ChainRng) -> PrimarySample {
    loop {
        let v: Vec<f64> = (0..4).map(|_| uniform(rng)).collect();
        if uniform(rng) * BOUND < BlackBox::value(v[0], v[1], v[2], v[3]) {
            return PrimarySample::from_values(
                vec![vec![v[0], v[1]], vec![v[2], v[3]]],
                SmallStep::Exponential {
                    s1: 1.0 / 64.0,
                    s2: 0.2,
                },
                rand::Rng::next_u64(rng),
            )
            .unwrap();
        }
    }
}

fn coords(x: &mut PrimarySample) -> Vec<f64> {
    x.materialise();
    vec![x.raw(0)[0], x.raw(0)[1], x.raw(1)[0], x.raw(1)[1]]
}

/// Kelemen's proposal with an extra drift on the first coordinate: asymmetric, reported symmetric.
struct Drifting(Kelemen);

impl Proposal<PrimarySample> for Drifting {
    fn propose(&self, x: &PrimarySample, y: &mut PrimarySample, rng: &mut ChainRng) -> Proposed {
        let p = self.0.propose(x, y, rng);
        let v = y.get(0, 0);
        let values = vec![
            vec![wrap(v + 0.03), y.get(0, 1)],
            vec![y.get(1, 0), y.get(1, 1)],
        ];
        *y = PrimarySample::from_values(values, SmallStep::default(), rand::Rng::next_u64(rng))
            .unwrap();
        p
    }
}

fn verdicts<P: Proposal<PrimarySample>>(proposal: P, seed: u64) -> (bool, bool) {
    let mut rng = stream(seed, 0);
    let mut mh = MetropolisHastings::new(BlackBox, proposal);
    let mut step = |x: &mut PrimarySample, r: &mut ChainRng| {
        let l = BlackBox.evaluate(x);
        let mut c = Chain::unchecked(x.clone(), l);
        // Several steps so coordinates go stale and are caught up.
        for _ in 0..4 {
            mh.step(&mut c, r, &mut ());
        }
        *x = c.state;
    };
    let inv = invariance(
        exact,
        &mut step,
        |x: &PrimarySample| coords(&mut x.clone()),
        &InvarianceConfig {
            replicates: 4000,
            steps: 1,
            alpha: ALPHA,
            categorical: vec![],
        },
        &mut rng,
    )
    .unwrap();
    let pilot: Vec<Vec<f64>> = (0..2000)
        .map(|_| coords(&mut exact(&mut rng))[..2].to_vec())
        .collect();
    let grid = QuantileGrid::fit(&pilot, 5);
    let mut one = |x: &mut PrimarySample, r: &mut ChainRng| {
        let l = BlackBox.evaluate(x);
        let mut c = Chain::unchecked(x.clone(), l);
        mh.step(&mut c, r, &mut ());
        *x = c.state;
    };
    let ex = exchangeability(
        exact,
        &mut one,
        |x: &PrimarySample| grid.cell(&coords(&mut x.clone())[..2].to_vec()),
        grid.cells(),
        &ExchangeabilityConfig {
            replicates: 20_000,
            alpha: ALPHA,
        },
        &mut rng,
    )
    .unwrap();
    (inv.passed, ex.passed)
}

#[test]
fn kelemen_steps_on_lazy_coordinates_keep_the_target() {
    for (seed, large) in [(1, 0.3), (2, 0.0), (3, 0.9)] {
        let k = Kelemen::new(
            large,
            SmallStep::Exponential {
                s1: 1.0 / 64.0,
                s2: 0.2,
            },
        )
        .unwrap();
        let (inv, ex) = verdicts(k, seed);
        assert!(
            inv && ex,
            "large step probability {large}: invariance {inv}, exchangeability {ex}"
        );
        let g = Kelemen::new(large, SmallStep::Gaussian { sigma: 0.08 }).unwrap();
        let (inv, ex) = verdicts(g, seed + 10);
        assert!(
            inv && ex,
            "gaussian small steps, large {large}: invariance {inv}, exchangeability {ex}"
        );
    }
}

#[test]
fn a_drifting_kelemen_step_is_caught() {
    let (inv, ex) = verdicts(
        Drifting(
            Kelemen::new(
                0.3,
                SmallStep::Exponential {
                    s1: 1.0 / 64.0,
                    s2: 0.2,
                },
            )
            .unwrap(),
        ),
        7,
    );
    assert!(!inv || !ex, "the drifting proposal passed both checks");
}
