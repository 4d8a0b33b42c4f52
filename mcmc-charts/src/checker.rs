//! A checker any user can run on their own chart: does it honour the contract of [`crate::chart`]?
//!
//! 1. **Round trip**: `T(R(x)) = x` for points `x = T(U)`, and `R` succeeds wherever `p(x) > 0`.
//! 2. **Exact conditional inverse**: for `U` uniform, `x = T(U)`, `U' = R(x)`, the pair `(U, U')`
//!    must be exchangeable and `U'` uniform on the region where `T` succeeds. The checker compares
//!    the law of `U'` with the law of an independent uniform `U` (restricted to that region) on 1D
//!    marginals (32 bins) and on every pair of coordinates (8×8 bins) with chi-square tests of
//!    homogeneity, Bonferroni-corrected. An inverse that picks branches with the wrong probabilities
//!    skews the branch-selecting coordinate and fails here.
//! 3. **Density**: `P(T(U) ∈ c)` for cells `c` of the target space against `∫_c p dμ`, estimated by
//!    importance sampling from a reference sampler with known density `q`
//!    (`E_q[p/q · 1_c]`); a z-test per cell with Holm's correction. A uniform reference on a domain
//!    of measure `M` has `q = 1/M`; where `p` is concentrated, give a reference that puts samples
//!    there, or the estimate of `∫_c p` is too noisy to test against.
//!
//! All three are seeded; the statistical ones have family-wise false-positive rate `α`.

use crate::Chart;
use mcmc_core::balance::{CheckReport, chi_square_sf, holm, normal_two_sided};
use mcmc_core::rng::uniform;
use mcmc_core::{ChainRng, McmcError};

/// Settings of the chart checker.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CheckerConfig {
    /// Samples for each test.
    pub samples: usize,
    /// Family-wise significance level of each statistical test.
    pub alpha: f64,
    /// Tolerance of the round trip, in the user's distance.
    pub tolerance: f64,
}

impl Default for CheckerConfig {
    fn default() -> Self {
        Self {
            samples: 100_000,
            alpha: 1e-4,
            tolerance: 1e-9,
        }
    }
}

/// Results of [`check_chart`].
#[derive(Clone, Debug)]
pub struct ChartReport {
    /// Name of the chart.
    pub chart: String,
    /// `T(R(x)) = x`.
    pub round_trip: CheckReport,
    /// `U' = R(T(U))` uniform (the exact-conditional contract).
    pub inverse_uniformity: CheckReport,
    /// `p(x)` against a histogram of `T(U)` (when a reference domain was given).
    pub density: Option<CheckReport>,
    /// Fraction of uniform `U` for which `T` succeeded.
    pub success_rate: f64,
}

impl ChartReport {
    /// Whether every check passed.
    pub fn passed(&self) -> bool {
        self.round_trip.passed
            && self.inverse_uniformity.passed
            && self.density.as_ref().is_none_or(|d| d.passed)
    }
}

impl std::fmt::Display for ChartReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "chart {} ({:.1}% of U maps to a point): {}",
            self.chart,
            100.0 * self.success_rate,
            if self.passed() { "passed" } else { "FAILED" }
        )?;
        writeln!(f, "  {}", self.round_trip)?;
        writeln!(f, "  {}", self.inverse_uniformity)?;
        if let Some(d) = &self.density {
            writeln!(f, "  {d}")?;
        }
        Ok(())
    }
}

/// A reference for the density test: `sample` draws points with density `exp(ln_density(x))`
/// with respect to the target space's reference measure (positive wherever the chart's density is,
/// inside the cells), and `cell` bins points into `0..cells`.
pub struct DensityReference<'a, X> {
    /// Sampler of the reference law.
    pub sample: &'a dyn Fn(&mut ChainRng) -> X,
    /// Its log density with respect to the reference measure (`-ln M` for uniform on measure `M`).
    pub ln_density: &'a dyn Fn(&X) -> f64,
    /// Cell of a point (`None`: outside every cell).
    pub cell: &'a dyn Fn(&X) -> Option<usize>,
    /// Number of cells.
    pub cells: usize,
}

fn random_u(dim: usize, rng: &mut ChainRng) -> Vec<f64> {
    (0..dim).map(|_| uniform(rng)).collect()
}

/// Run every check on `chart`. `distance` measures how far apart two points are (for the round
/// trip); `density` is optional.
pub fn check_chart<X: Default + Clone, C: Chart<X> + ?Sized>(
    chart: &C,
    distance: &dyn Fn(&X, &X) -> f64,
    density: Option<&DensityReference<'_, X>>,
    config: &CheckerConfig,
    rng: &mut ChainRng,
) -> Result<ChartReport, McmcError> {
    let d = chart.dim();
    let n = config.samples;
    let mut x = X::default();
    let mut x2 = X::default();
    let mut u2 = vec![0.0; d];
    let mut worst = 0.0f64;
    let mut worst_detail = String::from("every point recovered");
    let mut inverted: Vec<Vec<f64>> = Vec::with_capacity(n);
    let mut successes = 0usize;
    for _ in 0..n {
        let u = random_u(d, rng);
        if !chart.forward(&u, &mut x) {
            continue;
        }
        successes += 1;
        let lp = chart.ln_density(&x);
        if !lp.is_finite() {
            worst = f64::INFINITY;
            worst_detail = format!("p(T(u)) = exp({lp}) at u = {u:?}");
            continue;
        }
        if !chart.invert(&x, &mut u2, rng) {
            worst = f64::INFINITY;
            worst_detail = format!("R failed at T(u) for u = {u:?}");
            continue;
        }
        if !chart.forward(&u2, &mut x2) {
            worst = f64::INFINITY;
            worst_detail = format!("T failed at R(T(u)) = {u2:?} for u = {u:?}");
            continue;
        }
        let e = distance(&x, &x2);
        if e.is_nan() || e > worst {
            worst = if e.is_nan() { f64::INFINITY } else { e };
            worst_detail = format!("|T(R(T(u))) − T(u)| = {e:.3e} at u = {u:?}");
        }
        inverted.push(u2.clone());
    }
    if successes < 100 {
        return Err(McmcError::Check(format!(
            "the forward map succeeded for only {successes} of {n} uniform samples"
        )));
    }
    let round_trip = CheckReport {
        check: "round trip T(R(x)) = x",
        passed: worst <= config.tolerance,
        statistic: worst,
        threshold: config.tolerance,
        detail: worst_detail,
    };
    // Reference: an independent uniform sample restricted to where T succeeds.
    let mut reference: Vec<Vec<f64>> = Vec::with_capacity(inverted.len());
    while reference.len() < inverted.len() {
        let u = random_u(d, rng);
        if chart.forward(&u, &mut x) {
            reference.push(u);
        }
    }
    let inverse_uniformity = uniformity(&inverted, &reference, d, config.alpha);
    let density = density
        .map(|r| density_check(chart, r, config, rng))
        .transpose()?;
    Ok(ChartReport {
        chart: chart.name(),
        round_trip,
        inverse_uniformity,
        density,
        success_rate: successes as f64 / n as f64,
    })
}

/// Chi-square homogeneity of two samples of cell indices.
fn homogeneity(a: &[usize], b: &[usize], cells: usize) -> (f64, usize) {
    let mut ca = vec![0f64; cells];
    let mut cb = vec![0f64; cells];
    for &i in a {
        ca[i] += 1.0;
    }
    for &i in b {
        cb[i] += 1.0;
    }
    let (na, nb) = (a.len() as f64, b.len() as f64);
    let mut stat = 0.0;
    let mut df = 0usize;
    for c in 0..cells {
        let t = ca[c] + cb[c];
        if t == 0.0 {
            continue;
        }
        df += 1;
        let (ea, eb) = (t * na / (na + nb), t * nb / (na + nb));
        stat += (ca[c] - ea).powi(2) / ea + (cb[c] - eb).powi(2) / eb;
    }
    (stat, df.saturating_sub(1))
}

fn uniformity(inverted: &[Vec<f64>], reference: &[Vec<f64>], d: usize, alpha: f64) -> CheckReport {
    let bin = |v: f64, b: usize| mcmc_core::rng::uniform_index(v, b);
    let mut tests: Vec<(String, f64)> = Vec::new();
    for i in 0..d {
        let a: Vec<usize> = inverted.iter().map(|u| bin(u[i], 32)).collect();
        let b: Vec<usize> = reference.iter().map(|u| bin(u[i], 32)).collect();
        let (s, df) = homogeneity(&a, &b, 32);
        tests.push((format!("u[{i}]"), chi_square_sf(s, df)));
    }
    for i in 0..d {
        for j in i + 1..d {
            let a: Vec<usize> = inverted
                .iter()
                .map(|u| bin(u[i], 8) * 8 + bin(u[j], 8))
                .collect();
            let b: Vec<usize> = reference
                .iter()
                .map(|u| bin(u[i], 8) * 8 + bin(u[j], 8))
                .collect();
            let (s, df) = homogeneity(&a, &b, 64);
            tests.push((format!("(u[{i}], u[{j}])"), chi_square_sf(s, df)));
        }
    }
    let (name, p) = tests
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .cloned()
        .unwrap_or(("none".into(), 1.0));
    let corrected = (p * tests.len() as f64).min(1.0);
    CheckReport {
        check: "exact conditional inverse (U' = R(T(U)) uniform)",
        passed: corrected > alpha,
        statistic: corrected,
        threshold: alpha,
        detail: format!(
            "{} samples, {} marginal tests; least uniform {name} (raw p {p:.2e})",
            inverted.len(),
            tests.len()
        ),
    }
}

fn density_check<X: Default + Clone, C: Chart<X> + ?Sized>(
    chart: &C,
    r: &DensityReference<'_, X>,
    config: &CheckerConfig,
    rng: &mut ChainRng,
) -> Result<CheckReport, McmcError> {
    let n = config.samples;
    let d = chart.dim();
    let mut x = X::default();
    let mut counts = vec![0f64; r.cells];
    for _ in 0..n {
        let u = random_u(d, rng);
        if chart.forward(&u, &mut x)
            && let Some(c) = (r.cell)(&x).filter(|&c| c < r.cells)
        {
            counts[c] += 1.0;
        }
    }
    let mut sum = vec![0f64; r.cells];
    let mut sum2 = vec![0f64; r.cells];
    for _ in 0..n {
        let y = (r.sample)(rng);
        if let Some(c) = (r.cell)(&y).filter(|&c| c < r.cells) {
            let p = (chart.ln_density(&y) - (r.ln_density)(&y)).exp();
            if !p.is_finite() {
                return Err(McmcError::Check("the chart's density is not finite".into()));
            }
            sum[c] += p;
            sum2[c] += p * p;
        }
    }
    let nf = n as f64;
    let mut pvals = Vec::with_capacity(r.cells);
    let mut worst = (1.0, 0usize, 0.0, 0.0);
    for c in 0..r.cells {
        let ph = counts[c] / nf;
        let eh = sum[c] / nf;
        // Binomial variance of the count under the null (probability eh), plus the variance of the
        // importance-sampling estimate of eh.
        let pn = eh.clamp(0.0, 1.0);
        let var = pn * (1.0 - pn) / nf + (sum2[c] / nf - eh * eh).max(0.0) / nf;
        let p = if var <= 0.0 {
            if (ph - eh).abs() < 1e-12 { 1.0 } else { 0.0 }
        } else {
            normal_two_sided((ph - eh).abs() / var.sqrt())
        };
        if p < worst.0 {
            worst = (p, c, ph, eh);
        }
        pvals.push(p);
    }
    let adj = holm(&pvals);
    let min_adj = adj.iter().copied().fold(1.0, f64::min);
    Ok(CheckReport {
        check: "density p(x) against a histogram of T(U)",
        passed: min_adj > config.alpha,
        statistic: min_adj,
        threshold: config.alpha,
        detail: format!(
            "{} cells; worst cell {}: P(T(U) in cell) = {:.5}, ∫p = {:.5}",
            r.cells, worst.1, worst.2, worst.3
        ),
    })
}
