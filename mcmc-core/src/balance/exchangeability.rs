//! Exchangeability test of reversibility for continuous kernels.
//!
//! Draw `x ~ π` exactly, take one kernel step to `y`, and bin both into cells. If the kernel is
//! π-reversible, `(x, y)` and `(y, x)` have the same law, so for every pair of cells `a ≠ b` the
//! counts `N_ab` (x in a, y in b) and `N_ba` satisfy `N_ab | N_ab + N_ba = m ~ Binomial(m, 1/2)`
//! exactly. Two complementary tests at level `α/2` each (Bonferroni across the two):
//! * Holm-corrected exact binomial tests over all cell pairs (exact level; sensitive to a few
//!   strongly asymmetric pairs);
//! * Bowker's chi-square test of symmetry `Σ (N_ab − N_ba)² / (N_ab + N_ba)` over pairs with
//!   `m ≥ 10` (asymptotic level; sensitive to small asymmetries spread over many pairs).
//!
//! The test sees only what the cells resolve: use cells fine enough to separate where the kernel
//! moves mass (e.g. [`QuantileGrid`] with equal-probability cells), and enough replicates that a
//! typical pair count is in the tens. It detects non-reversibility, not every failure of
//! invariance; pair it with [`super::invariance`].

use super::{CheckReport, binomial_two_sided, chi_square_sf, holm};
use crate::{ChainRng, McmcError};

/// Settings of the exchangeability test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExchangeabilityConfig {
    /// Number of independent `(x, y)` pairs.
    pub replicates: usize,
    /// Family-wise significance level (false-positive rate on a reversible kernel).
    pub alpha: f64,
}

impl Default for ExchangeabilityConfig {
    fn default() -> Self {
        Self {
            replicates: 20_000,
            alpha: 1e-3,
        }
    }
}

/// Equal-probability cells on a product grid, fitted to per-coordinate quantiles of a pilot sample
/// from `π`.
#[derive(Clone, Debug, PartialEq)]
pub struct QuantileGrid {
    edges: Vec<Vec<f64>>,
    bins: usize,
}

impl QuantileGrid {
    /// `bins` cells per coordinate from a pilot sample of states.
    pub fn fit<S: AsRef<[f64]>>(pilot: &[S], bins: usize) -> Self {
        let d = pilot.first().map(|s| s.as_ref().len()).unwrap_or(0);
        let edges = (0..d)
            .map(|c| {
                let mut v: Vec<f64> = pilot.iter().map(|s| s.as_ref()[c]).collect();
                v.sort_by(f64::total_cmp);
                (1..bins)
                    .map(|b| v[(b * v.len() / bins).min(v.len() - 1)])
                    .collect()
            })
            .collect();
        Self { edges, bins }
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.bins.pow(self.edges.len() as u32)
    }

    /// The cell of a state (`None` for non-finite coordinates).
    pub fn cell<S: AsRef<[f64]>>(&self, x: &S) -> Option<usize> {
        let mut idx = 0;
        for (c, e) in self.edges.iter().enumerate() {
            let v = *x.as_ref().get(c)?;
            if !v.is_finite() {
                return None;
            }
            idx = idx * self.bins + e.partition_point(|&t| t <= v);
        }
        Some(idx)
    }
}

/// Run the test: `exact` draws from `π`, `step` advances a state by one kernel step in place,
/// `cell` bins a state into `0..cells` (`None` counts as an extra cell).
pub fn exchangeability<S: Clone>(
    mut exact: impl FnMut(&mut ChainRng) -> S,
    mut step: impl FnMut(&mut S, &mut ChainRng),
    cell: impl Fn(&S) -> Option<usize>,
    cells: usize,
    config: &ExchangeabilityConfig,
    rng: &mut ChainRng,
) -> Result<CheckReport, McmcError> {
    if cells < 2 || config.replicates == 0 || !(config.alpha > 0.0 && config.alpha < 1.0) {
        return Err(McmcError::Check(format!(
            "need at least 2 cells, some replicates and 0 < alpha < 1 (cells {cells}, replicates {}, alpha {})",
            config.replicates, config.alpha
        )));
    }
    let c = cells + 1;
    let mut counts = vec![0u64; c * c];
    let bin = |s: &S| cell(s).filter(|&i| i < cells).unwrap_or(cells);
    for _ in 0..config.replicates {
        let x = exact(rng);
        let mut y = x.clone();
        step(&mut y, rng);
        counts[bin(&x) * c + bin(&y)] += 1;
    }
    let mut pvals = Vec::new();
    let mut pairs = Vec::new();
    let mut bowker = 0.0;
    let mut df = 0usize;
    for a in 0..c {
        for b in a + 1..c {
            let (nab, nba) = (counts[a * c + b], counts[b * c + a]);
            let m = nab + nba;
            if m == 0 {
                continue;
            }
            pvals.push(binomial_two_sided(nab, m));
            pairs.push((a, b, nab, nba));
            if m >= 10 {
                bowker += (nab as f64 - nba as f64).powi(2) / m as f64;
                df += 1;
            }
        }
    }
    let adjusted = holm(&pvals);
    let (worst_i, p_holm) = adjusted
        .iter()
        .copied()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((0, 1.0));
    let p_bowker = chi_square_sf(bowker, df);
    let p = (2.0 * p_holm.min(p_bowker)).min(1.0);
    let detail = match pairs.get(worst_i) {
        Some(&(a, b, nab, nba)) => format!(
            "{} replicates, {} cell pairs; most asymmetric pair ({a},{b}): {nab} vs {nba} (Holm p {p_holm:.2e}); Bowker χ² {bowker:.1} on {df} df (p {p_bowker:.2e})",
            config.replicates,
            pairs.len()
        ),
        None => "no transitions between cells: refine the cells".into(),
    };
    if pairs.is_empty() {
        return Err(McmcError::Check(detail));
    }
    Ok(CheckReport {
        check: "exchangeability",
        passed: p > config.alpha,
        statistic: p,
        threshold: config.alpha,
        detail,
    })
}
