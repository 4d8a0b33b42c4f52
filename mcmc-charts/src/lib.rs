//! # mcmc-charts
//!
//! Charted Metropolis–Hastings (Pantaleoni 2017): sampling charts with stochastic right inverses,
//! and the moves that jump between them — chart swaps by serial tempering and by replica exchange,
//! inverse primary-space perturbations — built on the kernels of `mcmc-core`. Nothing here knows
//! about light: a renderer plugs its path-sampling techniques in as [`Chart`]s.
//!
//! * [`Chart`]: forward map, density, and the stochastic right inverse sampling the **exact
//!   conditional law** of the primary coordinates given the point (the contract that makes every
//!   acceptance rule exact and simple; [`chart`] explains it).
//! * [`Atlas`]: the charts of one target space, optionally with the identity chart.
//! * [`ChartedTarget`]: importance-sampled, weighted or visibility targets per chart, as an
//!   `mcmc_core::Family` whose transfer is the chart swap — so `mcmc_core`'s `SerialTempering` and
//!   `ReplicaExchange` run charted chains unchanged.
//! * [`moves`]: in-chart moves and inverse primary-space perturbations, with the derivation of every
//!   acceptance rule from Metropolis–Hastings–Green.
//! * [`checker`]: verify a chart's round trip, the exactness of its inverse, and its density.
//!
//! ## A user-defined chart
//!
//! A non-injective chart of `[0,1)`: the first coordinate picks one of two strata (probability 0.3
//! and 0.7), which map the second coordinate onto the whole interval by `x = v` and `x = v²`. Its
//! density is `p(x) = 0.3 + 0.7 / (2√x)`; the inverse picks the stratum in proportion to its share of
//! `p(x)` and fills the free position inside the stratum's interval uniformly.
//!
//! ```
//! use mcmc_charts::{Chart, checker::{check_chart, CheckerConfig}};
//! use mcmc_core::{ChainRng, rng::{stream, uniform}};
//!
//! struct TwoStrata;
//! impl Chart<f64> for TwoStrata {
//!     fn dim(&self) -> usize { 2 }
//!     fn forward(&self, u: &[f64], x: &mut f64) -> bool {
//!         *x = if u[0] < 0.3 { u[1] } else { u[1] * u[1] };
//!         true
//!     }
//!     fn ln_density(&self, x: &f64) -> f64 {
//!         if (0.0..1.0).contains(x) && *x > 0.0 { (0.3 + 0.7 / (2.0 * x.sqrt())).ln() } else { f64::NEG_INFINITY }
//!     }
//!     fn invert(&self, x: &f64, u: &mut [f64], rng: &mut ChainRng) -> bool {
//!         let (a, b) = (0.3, 0.7 / (2.0 * x.sqrt()));      // each stratum's share of p(x)
//!         if uniform(rng) * (a + b) < a {
//!             u[0] = 0.3 * uniform(rng);                    // free coordinate, uniform in the stratum
//!             u[1] = *x;
//!         } else {
//!             u[0] = 0.3 + 0.7 * uniform(rng);
//!             u[1] = x.sqrt();
//!         }
//!         true
//!     }
//! }
//!
//! let report = check_chart(&TwoStrata, &|a: &f64, b: &f64| (a - b).abs(), None,
//!                          &CheckerConfig { samples: 50_000, ..Default::default() }, &mut stream(1, 0)).unwrap();
//! assert!(report.passed(), "{report}");
//! ```

#![warn(missing_docs)]

mod atlas;
pub mod chart;
pub mod checker;
pub mod moves;
mod target;

pub use atlas::{Atlas, ChartState};
pub use chart::Chart;
pub use target::{ChartedTarget, Integrand, Joint, TargetKind};
