//! Cost of one Metropolis–Hastings step through the framework (`MetropolisHastings` + `Chain` +
//! `Kernel::step` with the `()` observer) against a hand-written loop doing the same arithmetic with
//! the same generator (`ChainRng`, ChaCha8), normal sampler (`StandardNormal`) and uniform
//! (`mcmc_core::rng::uniform`). Target: a 2D standard normal, random walk σ = 1.
//!
//! Both are measured with a `[f64; 2]` state (the hand-written loop keeps it in registers) and with
//! a `Vec<f64>` state (the hand-written loop then uses a state and a candidate buffer it swaps, as
//! the framework does).
//!
//! Run with `cargo bench --bench mh_step`; criterion reports steps/s (`Throughput::Elements`).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mcmc_core::proposals::GaussianRandomWalk;
use mcmc_core::rng::{stream, uniform};
use mcmc_core::{Chain, Kernel, MetropolisHastings};
use rand::RngExt;
use rand_distr::StandardNormal;

/// Steps per benchmark iteration.
const STEPS: u64 = 10_000;

fn ln_normal(x: &[f64; 2]) -> f64 {
    -0.5 * (x[0] * x[0] + x[1] * x[1])
}

fn mh_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("mh_step");
    group.throughput(Throughput::Elements(STEPS));

    group.bench_function("framework_array", |b| {
        let walk = GaussianRandomWalk::new(1.0).expect("positive scale");
        let mut mh = MetropolisHastings::new(ln_normal, walk);
        let mut chain = Chain::start(&ln_normal, [0.0; 2]).expect("finite start");
        let mut rng = stream(1, 0);
        b.iter(|| {
            for _ in 0..STEPS {
                mh.step(&mut chain, &mut rng, &mut ());
            }
            black_box(&chain.state);
        })
    });

    group.bench_function("framework_vec", |b| {
        let ln_normal_vec = |x: &Vec<f64>| -0.5 * (x[0] * x[0] + x[1] * x[1]);
        let walk = GaussianRandomWalk::new(1.0).expect("positive scale");
        let mut mh = MetropolisHastings::new(ln_normal_vec, walk);
        let mut chain = Chain::start(&ln_normal_vec, vec![0.0; 2]).expect("finite start");
        let mut rng = stream(1, 0);
        b.iter(|| {
            for _ in 0..STEPS {
                mh.step(&mut chain, &mut rng, &mut ());
            }
            black_box(&chain.state);
        })
    });

    group.bench_function("hand_written", |b| {
        let mut x = [0.0; 2];
        let mut lx = ln_normal(&x);
        let mut accepted = 0u64;
        let mut rng = stream(1, 0);
        b.iter(|| {
            for _ in 0..STEPS {
                let e0: f64 = rng.sample(StandardNormal);
                let e1: f64 = rng.sample(StandardNormal);
                let y = [x[0] + e0, x[1] + e1];
                let ly = ln_normal(&y);
                let l = ly - lx;
                if l >= 0.0 || uniform(&mut rng) < l.exp() {
                    x = y;
                    lx = ly;
                    accepted += 1;
                }
            }
            black_box((&x, accepted));
        })
    });

    // The same loop on heap-allocated state and candidate buffers, as the framework's Vec variant.
    group.bench_function("hand_written_vec", |b| {
        let ln_normal_vec = |x: &Vec<f64>| -0.5 * (x[0] * x[0] + x[1] * x[1]);
        let (mut x, mut y) = (vec![0.0; 2], vec![0.0; 2]);
        let mut lx = ln_normal_vec(&x);
        let mut accepted = 0u64;
        let mut rng = stream(1, 0);
        b.iter(|| {
            for _ in 0..STEPS {
                for (yi, xi) in y.iter_mut().zip(&x) {
                    let e: f64 = rng.sample(StandardNormal);
                    *yi = xi + e;
                }
                let ly = ln_normal_vec(&y);
                let l = ly - lx;
                if l >= 0.0 || uniform(&mut rng) < l.exp() {
                    std::mem::swap(&mut x, &mut y);
                    lx = ly;
                    accepted += 1;
                }
            }
            black_box((&x, accepted));
        })
    });

    group.finish();
}

criterion_group!(benches, mh_step);
criterion_main!(benches);
