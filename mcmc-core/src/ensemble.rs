//! Many independent chains in parallel (rayon). Chain `i` draws from stream `i` of the master seed
//! ([`crate::rng::stream`]), so every chain — and therefore every result — is identical whatever
//! the number of threads.

use crate::ChainRng;
use crate::rng::stream;
use rayon::prelude::*;

/// `chains` independent chains keyed by one master seed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Ensemble {
    /// Number of chains.
    pub chains: usize,
    /// Master seed.
    pub master_seed: u64,
}

impl Ensemble {
    /// An ensemble of `chains` chains.
    pub fn new(chains: usize, master_seed: u64) -> Self {
        Self {
            chains,
            master_seed,
        }
    }

    /// Run `f(chain_index, rng)` for every chain in parallel and collect the results in chain order.
    ///
    /// ```
    /// use mcmc_core::{Ensemble, Chain, Kernel, MetropolisHastings, proposals::GaussianRandomWalk};
    /// let target = |x: &Vec<f64>| -0.5 * x[0] * x[0];
    /// let means = Ensemble::new(4, 42).run(|_, rng| {
    ///     let mut mh = MetropolisHastings::new(target, GaussianRandomWalk::new(1.0).unwrap());
    ///     let mut chain = Chain::start(&target, vec![0.0]).unwrap();
    ///     let mut sum = 0.0;
    ///     for _ in 0..1000 { mh.step(&mut chain, rng, &mut ()); sum += chain.state[0]; }
    ///     sum / 1000.0
    /// });
    /// assert_eq!(means.len(), 4);
    /// ```
    pub fn run<R, F>(&self, f: F) -> Vec<R>
    where
        R: Send,
        F: Fn(usize, &mut ChainRng) -> R + Sync,
    {
        (0..self.chains)
            .into_par_iter()
            .map(|i| {
                let mut rng = stream(self.master_seed, i as u64);
                f(i, &mut rng)
            })
            .collect()
    }

    /// Like [`Ensemble::run`] but sequential (for callers already inside a parallel region).
    pub fn run_sequential<R, F>(&self, f: F) -> Vec<R>
    where
        F: Fn(usize, &mut ChainRng) -> R,
    {
        (0..self.chains)
            .map(|i| {
                let mut rng = stream(self.master_seed, i as u64);
                f(i, &mut rng)
            })
            .collect()
    }
}
