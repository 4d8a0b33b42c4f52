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
            ks_two_sample(a, b)
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

/// Two-sample Kolmogorov–Smirnov test: the statistic `D = sup |F_a − F_b|` and its asymptotic
/// p-value `Q_KS((√n_e + 0.12 + 0.11/√n_e) D)` with `n_e = n_a n_b / (n_a + n_b)` (Stephens' small-sample
/// correction). Ties make the test conservative.
pub fn ks_two_sample(mut a: Vec<f64>, mut b: Vec<f64>) -> (f64, f64) {
    a.sort_by(f64::total_cmp);
    b.sort_by(f64::total_cmp);
    let (na, nb) = (a.len() as f64, b.len() as f64);
    let (mut i, mut j) = (0, 0);
    let mut d = 0.0f64;
    while i < a.len() && j < b.len() {
        let v = a[i].min(b[j]);
        while i < a.len() && a[i] <= v {
            i += 1;
        }
        while j < b.len() && b[j] <= v {
            j += 1;
        }
        d = d.max((i as f64 / na - j as f64 / nb).abs());
    }
    let ne = na * nb / (na + nb);
    let lambda = (ne.sqrt() + 0.12 + 0.11 / ne.sqrt()) * d;
    (d, kolmogorov_q(lambda))
}

/// `Q_KS(λ) = 2 Σ_{j≥1} (−1)^{j−1} exp(−2 j² λ²)`, the Kolmogorov distribution's upper tail.
fn kolmogorov_q(lambda: f64) -> f64 {
    if lambda < 0.2 {
        return 1.0; // the series equals 1 to double precision here and converges slowly
    }
    let mut sum = 0.0;
    let mut sign = 1.0;
    for j in 1..=200 {
        let term = (-2.0 * (j as f64 * lambda).powi(2)).exp();
        sum += sign * term;
        if term < 1e-16 * sum.abs() {
            break;
        }
        sign = -sign;
    }
    (2.0 * sum).clamp(0.0, 1.0)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ks_agrees_with_known_values() {
        // Identical samples: D = 0, p = 1 (and no slow series).
        let a: Vec<f64> = (0..1000).map(|i| i as f64).collect();
        assert_eq!(ks_two_sample(a.clone(), a.clone()), (0.0, 1.0));
        // Disjoint samples: D = 1, p ≈ 0.
        let b: Vec<f64> = (0..1000).map(|i| 5000.0 + i as f64).collect();
        let (d, p) = ks_two_sample(a.clone(), b);
        assert_eq!(d, 1.0);
        assert!(p < 1e-100);
        // Q_KS(1.36) ≈ 0.049 and Q_KS(1.63) ≈ 0.0098 (the classic 5% and 1% critical values).
        assert!((kolmogorov_q(1.358) - 0.05).abs() < 1e-3);
        assert!((kolmogorov_q(1.628) - 0.01).abs() < 3e-4);
        // Constant feature in both samples.
        assert_eq!(ks_two_sample(vec![0.0; 50], vec![0.0; 70]).1, 1.0);
    }
}
