//! Ensembles give the same chains whatever the number of threads.

use mcmc_core::proposals::GaussianRandomWalk;
use mcmc_core::{Chain, Ensemble, Kernel, MetropolisHastings};

fn run_in_pool(threads: usize) -> Vec<Vec<f64>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        Ensemble::new(16, 99).run(|i, rng| {
            let target = |x: &Vec<f64>| -0.5 * (x[0] * x[0] + x[1] * x[1]);
            let mut mh = MetropolisHastings::new(target, GaussianRandomWalk::new(1.0).unwrap());
            let mut c = Chain::start(&target, vec![i as f64, 0.0]).unwrap();
            (0..500)
                .map(|_| {
                    mh.step(&mut c, rng, &mut ());
                    c.state[0]
                })
                .collect()
        })
    })
}

#[test]
fn one_and_two_threads_give_identical_chains() {
    let a = run_in_pool(1);
    let b = run_in_pool(2);
    assert_eq!(a, b);
    // and chains are distinct streams
    assert_ne!(a[0][100..], a[1][100..]);
}
