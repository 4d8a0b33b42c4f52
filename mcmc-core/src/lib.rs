//! # mcmc-core
//!
//! A small, domain-agnostic Markov chain Monte Carlo toolkit: targets, proposals,
//! Metropolis–Hastings kernels, mixtures, parallel ensembles, replica exchange, serial tempering,
//! diagnostics — and **public balance checks** that prove a kernel leaves its target invariant and
//! catch the ones that do not.
//!
//! ```
//! use mcmc_core::{Chain, Kernel, MetropolisHastings, rng::stream};
//! use mcmc_core::proposals::{GaussianRandomWalk, Mixture, MixtureRule, Independence, UniformCube};
//! use mcmc_core::diagnostics::{ess, split_rhat};
//!
//! // An unnormalised density on R²: a banana (log density; -inf where zero is allowed).
//! let banana = |x: &Vec<f64>| -0.5 * (x[0] * x[0] + 4.0 * (x[1] - x[0] * x[0]).powi(2));
//!
//! // A random walk mixed with an occasional bolder move, accepted per component.
//! let proposal = Mixture::new(
//!     vec![
//!         (0.9, Box::new(GaussianRandomWalk::new(0.5).unwrap()) as _),
//!         (0.1, Box::new(GaussianRandomWalk::new(2.0).unwrap()) as _),
//!     ],
//!     MixtureRule::PerComponent,
//! ).unwrap();
//! let names = mcmc_core::Proposal::kinds(&proposal);
//! let mut kernel = MetropolisHastings::new(banana, proposal);
//! let mut chain = Chain::start(&banana, vec![0.0, 0.0]).unwrap();
//! let mut rng = stream(42, 0);
//! let mut trace = Vec::new();
//! for _ in 0..20_000 {
//!     kernel.step(&mut chain, &mut rng, &mut ());
//!     trace.push(chain.state[0]);
//! }
//! println!("{}", chain.stats.table(&names));
//! // The curved tails make this a slowly mixing target: about one effective draw per 250 steps.
//! println!("ESS {:.0}, split R-hat {:.3}", ess(&trace), split_rhat(&[&trace]));
//! assert!(ess(&trace) > 20.0);
//! ```
//!
//! ## Concepts
//! * [`Target`]: an unnormalised log density (any `Fn(&S) -> f64` is one).
//! * [`Proposal`]: draws a candidate and reports `ln q(x|y) − ln q(y|x)` and a move kind;
//!   [`proposals`] has Gaussian random walks, Kelemen's primary-sample-space small steps on the
//!   unit cube, independence samplers and mixtures with both transition rules.
//! * [`Kernel`], [`MetropolisHastings`], [`Chain`]: the guarded accept/reject step, with an
//!   [`Observer`] that sees every proposal and its acceptance probability (expected-value
//!   recording).
//! * [`Ensemble`]: many chains in parallel, reproducible whatever the thread count.
//! * [`tempering`]: replica exchange and serial tempering over any [`Family`] of targets.
//! * [`diagnostics`]: autocorrelation time, ESS, MCSE, rank-normalised split R-hat.
//! * [`balance`]: pointwise, finite-space exact, exchangeability and invariance checks.
//!
//! All randomness comes from [`ChainRng`] streams keyed by a master seed and an index
//! ([`rng::stream`]).

#![warn(missing_docs)]

pub mod balance;
pub mod diagnostics;
mod ensemble;
mod error;
pub mod kernel;
pub mod population;
pub mod primary_sample;
mod proposal;
pub mod proposals;
pub mod rng;
mod stats;
mod target;
pub mod tempering;

pub use ensemble::Ensemble;
pub use error::McmcError;
pub use kernel::{Chain, FnObserver, Kernel, MetropolisHastings, Observer};
pub use proposal::{Density, Outcome, Proposal, Proposed};
pub use rng::ChainRng;
pub use stats::{Failure, KindStats, Stats};
pub use target::{Family, FnFamily, Level, Target, Tempered};
