//! Invariance test from independent replicates.
//!
//! Draw `2N` states from `π` exactly; advance the first `N` by `m` kernel steps each; compare them
//! with the other `N` (untouched, hence independent of the first) feature by feature: a two-sample
//! Kolmogorov–Smirnov test for continuous features and a chi-square test of homogeneity for
//! categorical ones, Bonferroni-corrected across features. Each replicate is independent, so
//! autocorrelation plays no role, and non-reversible kernels (deterministic sweeps, non-reversible
//! tempering schedules) are tested as well as reversible ones. Comparing against fresh draws rather
//! than the replicates' own starting points keeps the two samples independent, as the KS test
//! requires. A feature may be NaN to mean "absent" (e.g. the state of a level the chain is not at);
//! absent values are dropped from both samples.

use super::{CheckReport, chi_square_sf};
use crate::{ChainRng, McmcError};
use statrs::stats_tests::NaNPolicy;
use statrs::stats_tests::ks_test::{KSTwoSampleAlternativeMethod, ks_twosample};
use std::collections::BTreeMap;

/// Settings of the invariance test.
#[derive(Clone, Debug, PartialEq)]
pub struct InvarianceConfig {
    /// Number of stepped replicates `N` (and of fresh comparison draws).
    pub replicates: usize,
    /// Kernel steps per replicate `m`.
    pub steps: usize,
    /// Family-wise significance level.
    pub alpha: f64,
    /// Indices of features that are categorical (compared with a chi-square test).
    pub categorical: Vec<usize>,
}

impl Default for InvarianceConfig {
    fn default() -> Self {
        Self {
            replicates: 5_000,
            steps: 1,
            alpha: 1e-3,
            categorical: vec![],
        }
    }
}

/// Run the test: `exact` draws from `π`, `step` advances a state in place, `features` maps a state
/// to the numbers compared.
pub fn invariance<S>(
    mut exact: impl FnMut(&mut ChainRng) -> S,
    mut step: impl FnMut(&mut S, &mut ChainRng),
    features: impl Fn(&S) -> Vec<f64>,
    config: &InvarianceConfig,
    rng: &mut ChainRng,
) -> Result<CheckReport, McmcError> {
    if config.replicates < 20 || !(config.alpha > 0.0 && config.alpha < 1.0) {
        return Err(McmcError::Check(
            "need at least 20 replicates and 0 < alpha < 1".into(),
        ));
    }
    let mut after: Vec<Vec<f64>> = Vec::with_capacity(config.replicates);
    let mut fresh: Vec<Vec<f64>> = Vec::with_capacity(config.replicates);
    for _ in 0..config.replicates {
        let mut x = exact(rng);
        for _ in 0..config.steps {
            step(&mut x, rng);
        }
        after.push(features(&x));
        fresh.push(features(&exact(rng)));
    }
    let nf = after.first().map(Vec::len).unwrap_or(0);
    if nf == 0 {
        return Err(McmcError::Check("no features to compare".into()));
    }
    let mut worst = (1.0f64, 0usize, 0.0f64);
    let mut tested = 0;
    for f in 0..nf {
        let a: Vec<f64> = after.iter().map(|v| v[f]).filter(|v| !v.is_nan()).collect();
        let b: Vec<f64> = fresh.iter().map(|v| v[f]).filter(|v| !v.is_nan()).collect();
        if a.len() < 10 || b.len() < 10 {
            continue;
        }
        tested += 1;
        let (stat, p) = if config.categorical.contains(&f) {
            homogeneity(&a, &b)
        } else {
            ks_twosample(
                a,
                b,
                KSTwoSampleAlternativeMethod::TwoSidedAsymptotic,
                NaNPolicy::Error,
            )
            .map_err(|e| McmcError::Check(format!("KS test failed: {e}")))?
        };
        if p < worst.0 {
            worst = (p, f, stat);
        }
    }
    if tested == 0 {
        return Err(McmcError::Check(
            "every feature had fewer than 10 present values".into(),
        ));
    }
    let p = (worst.0 * tested as f64).min(1.0);
    Ok(CheckReport {
        check: "invariance",
        passed: p > config.alpha,
        statistic: p,
        threshold: config.alpha,
        detail: format!(
            "{} replicates × {} steps, {tested} features; worst feature {} (statistic {:.4}, raw p {:.2e})",
            config.replicates, config.steps, worst.1, worst.2, worst.0
        ),
    })
}

/// Chi-square test that two samples of categories come from one law.
fn homogeneity(a: &[f64], b: &[f64]) -> (f64, f64) {
    let mut table: BTreeMap<i64, (f64, f64)> = BTreeMap::new();
    for &v in a {
        table.entry(v.round() as i64).or_default().0 += 1.0;
    }
    for &v in b {
        table.entry(v.round() as i64).or_default().1 += 1.0;
    }
    let (na, nb) = (a.len() as f64, b.len() as f64);
    let n = na + nb;
    let mut stat = 0.0;
    for &(ca, cb) in table.values() {
        let tot = ca + cb;
        let (ea, eb) = (tot * na / n, tot * nb / n);
        stat += (ca - ea).powi(2) / ea + (cb - eb).powi(2) / eb;
    }
    let df = table.len().saturating_sub(1);
    (stat, chi_square_sf(stat, df))
}
