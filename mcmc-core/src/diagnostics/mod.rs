//! Convergence and efficiency diagnostics: integrated autocorrelation time, effective sample size,
//! Monte Carlo standard error, and rank-normalised split R-hat (Vehtari, Gelman, Simpson, Carpenter
//! & Bürkner 2021). Functions return NaN for input that carries no information (constant, or too
//! short: fewer than 4 draws per chain).

mod autocorr;
mod rhat;

pub use autocorr::{autocorrelation, ess, ess_chains, integrated_autocorrelation_time, mcse_mean};
pub use rhat::{ess_bulk, ess_tail, rank_normalize, rhat, split_rhat};

/// Minimum number of draws per chain for any diagnostic.
pub const MIN_DRAWS: usize = 4;

pub(crate) fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

pub(crate) fn variance(x: &[f64]) -> f64 {
    let m = mean(x);
    x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (x.len() as f64 - 1.0)
}
