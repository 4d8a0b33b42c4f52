//! Public checks that a kernel leaves its target invariant — use them on your own kernels.
//!
//! | check | what it proves | cost |
//! |---|---|---|
//! | [`pointwise`] | `π(x) q(y|x) α(x→y) = π(y) q(x|y) α(y→x)` at given pairs, and that the reported ratio equals the ratio of transition densities | exact, needs `q` evaluable |
//! | [`finite`] | exact detailed balance, stationarity `πP = π` and irreducibility of the enumerated transition matrix | exact, finite spaces |
//! | [`exchangeability`] | `(x, y)` and `(y, x)` have the same law for `x ~ π`, `y ~ K(x, ·)` (reversibility) | statistical |
//! | [`invariance`] | `y ~ K^m(x, ·)` has law `π` when `x ~ π` (stationarity; also for non-reversible kernels) | statistical |
//! | [`tempering`] | ladders: exact round-trip counts, expected swap acceptance | exact / statistical |
//!
//! Statistical checks are seeded and report a p-value; with significance level `α` their
//! false-positive rate on a correct kernel is at most `α` (exact binomial tests with Holm's
//! correction) or approximately `α` (asymptotic chi-square and Kolmogorov–Smirnov tests, all
//! corrected with Bonferroni across statistics). The repository's `tests/balance_rates.rs` measures
//! both the false-positive rate on correct kernels and the detection rate on broken ones.
//!
//! ```
//! use mcmc_core::{Chain, Kernel, MetropolisHastings, proposals::GaussianRandomWalk, rng::stream};
//! use mcmc_core::balance::exchangeability::{exchangeability, ExchangeabilityConfig, QuantileGrid};
//! use rand::RngExt;
//! use rand_distr::StandardNormal;
//!
//! let target = |x: &Vec<f64>| -0.5 * x[0] * x[0];
//! let mut mh = MetropolisHastings::new(target, GaussianRandomWalk::new(1.0).unwrap());
//! let exact = |rng: &mut mcmc_core::ChainRng| vec![rng.sample::<f64, _>(StandardNormal)];
//! let mut rng = stream(1, 0);
//! let pilot: Vec<Vec<f64>> = (0..2000).map(|_| exact(&mut rng)).collect();
//! let grid = QuantileGrid::fit(&pilot, 6);
//! let report = exchangeability(
//!     exact,
//!     |x: &mut Vec<f64>, rng: &mut mcmc_core::ChainRng| {
//!         let mut c = Chain::start(&target, x.clone()).unwrap();
//!         mh.step(&mut c, rng, &mut ());
//!         *x = c.state;
//!     },
//!     |x: &Vec<f64>| grid.cell(x),
//!     grid.cells(),
//!     &ExchangeabilityConfig { replicates: 20_000, alpha: 1e-3 },
//!     &mut rng,
//! )
//! .unwrap();
//! assert!(report.passed, "{report}");
//! ```

pub mod exchangeability;
pub mod finite;
pub mod invariance;
pub mod pointwise;
pub mod tempering;

use statrs::distribution::{Binomial, ChiSquared, ContinuousCDF, DiscreteCDF};
use std::fmt;

/// The outcome of a check.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckReport {
    /// Which check.
    pub check: &'static str,
    /// Whether the kernel passed.
    pub passed: bool,
    /// For statistical checks the (corrected) p-value; for exact checks the largest violation.
    pub statistic: f64,
    /// Significance level, or tolerance for exact checks.
    pub threshold: f64,
    /// Human-readable details (worst cell, worst coordinate, …).
    pub detail: String,
}

impl fmt::Display for CheckReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {}: statistic {:.3e} (threshold {:.1e}); {}",
            self.check,
            if self.passed { "passed" } else { "FAILED" },
            self.statistic,
            self.threshold,
            self.detail
        )
    }
}

/// Two-sided exact p-value of `k` successes in `m` fair Bernoulli trials.
pub fn binomial_two_sided(k: u64, m: u64) -> f64 {
    if m == 0 {
        return 1.0;
    }
    let lo = k.min(m - k);
    let b = Binomial::new(0.5, m).expect("valid binomial");
    (2.0 * b.cdf(lo)).min(1.0)
}

/// Holm–Bonferroni adjusted p-values (same order as the input); controls the family-wise error
/// rate under any dependence between the tests.
pub fn holm(p: &[f64]) -> Vec<f64> {
    let m = p.len();
    let mut idx: Vec<usize> = (0..m).collect();
    idx.sort_by(|&a, &b| p[a].total_cmp(&p[b]));
    let mut adj = vec![0.0; m];
    let mut running: f64 = 0.0;
    for (rank, &i) in idx.iter().enumerate() {
        running = running.max(((m - rank) as f64 * p[i]).min(1.0));
        adj[i] = running;
    }
    adj
}

/// Two-sided normal tail `P(|Z| ≥ z)`.
pub fn normal_two_sided(z: f64) -> f64 {
    statrs::function::erf::erfc(z.abs() / std::f64::consts::SQRT_2)
}

/// Upper tail `P(χ²_df ≥ stat)`.
pub fn chi_square_sf(stat: f64, df: usize) -> f64 {
    if df == 0 {
        return 1.0;
    }
    ChiSquared::new(df as f64)
        .map(|c| c.sf(stat))
        .unwrap_or(f64::NAN)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn binomial_p_values() {
        assert_eq!(binomial_two_sided(5, 10), 1.0);
        // P(X <= 0) = 2^-10, two-sided = 2^-9
        assert!((binomial_two_sided(0, 10) - 2f64.powi(-9)).abs() < 1e-15);
        assert!((binomial_two_sided(10, 10) - 2f64.powi(-9)).abs() < 1e-15);
    }

    #[test]
    fn holm_adjustment() {
        let a = holm(&[0.01, 0.04, 0.03]);
        assert!((a[0] - 0.03).abs() < 1e-15);
        assert!((a[2] - 0.06).abs() < 1e-15);
        assert!((a[1] - 0.06).abs() < 1e-15);
    }
}
