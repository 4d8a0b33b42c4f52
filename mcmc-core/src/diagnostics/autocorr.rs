//! Autocorrelation by FFT, integrated autocorrelation time by Geyer's initial monotone sequence
//! (Geyer 1992, as in Stan), and effective sample sizes.

use super::{MIN_DRAWS, mean, variance};
use rustfft::{FftPlanner, num_complex::Complex};

/// Normalised autocorrelation `ρ_0 … ρ_{n-1}` of a series (biased estimator, `ρ_0 = 1`); empty
/// for a constant series.
pub fn autocorrelation(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    if n < 2 {
        return vec![];
    }
    let m = mean(x);
    let size = (2 * n).next_power_of_two();
    let mut buf: Vec<Complex<f64>> = x
        .iter()
        .map(|&v| Complex::new(v - m, 0.0))
        .chain(std::iter::repeat(Complex::new(0.0, 0.0)))
        .take(size)
        .collect();
    let mut planner = FftPlanner::new();
    planner.plan_fft_forward(size).process(&mut buf);
    for c in &mut buf {
        *c = Complex::new(c.norm_sqr(), 0.0);
    }
    planner.plan_fft_inverse(size).process(&mut buf);
    let c0 = buf[0].re;
    if c0 <= 0.0 || !c0.is_finite() {
        return vec![];
    }
    buf[..n].iter().map(|c| c.re / c0).collect()
}

/// Geyer's initial monotone sequence estimate from autocorrelations `ρ_t`:
/// `τ = −1 + 2 Σ_m P_m` with `P_m = ρ_{2m} + ρ_{2m+1}` summed while positive and made monotone.
fn geyer_tau(rho: &[f64]) -> f64 {
    let mut sum = 0.0;
    let mut prev = f64::INFINITY;
    let mut m = 0;
    while 2 * m + 1 < rho.len() {
        let mut p = rho[2 * m] + rho[2 * m + 1];
        if p <= 0.0 {
            break;
        }
        if p > prev {
            p = prev;
        }
        sum += p;
        prev = p;
        m += 1;
    }
    -1.0 + 2.0 * sum
}

/// Integrated autocorrelation time `τ = 1 + 2 Σ_{t≥1} ρ_t` (so that `ESS = n / τ`). For an AR(1)
/// series `x_t = a x_{t-1} + ε_t`, `τ = (1+a)/(1−a)`. NaN for constant or too-short input.
pub fn integrated_autocorrelation_time(x: &[f64]) -> f64 {
    if x.len() < MIN_DRAWS || x.iter().any(|v| !v.is_finite()) {
        return f64::NAN;
    }
    let rho = autocorrelation(x);
    if rho.is_empty() {
        return f64::NAN;
    }
    // Never report fewer than one draw's worth of correlation below 1/log10(n) (antithetic chains
    // can be super-efficient; Stan caps ESS at n·log10(n)).
    geyer_tau(&rho).max(1.0 / (x.len() as f64).log10())
}

/// Effective sample size of one chain, `n / τ`.
pub fn ess(x: &[f64]) -> f64 {
    x.len() as f64 / integrated_autocorrelation_time(x)
}

/// Multi-chain effective sample size (Stan's estimator, Vehtari et al. 2021 eq. 10–11): the
/// autocorrelations of the chains are combined with the between-chain variance so that chains
/// stuck in different modes lower the ESS. Chains are truncated to the shortest.
pub fn ess_chains(chains: &[&[f64]]) -> f64 {
    let m = chains.len();
    let n = chains.iter().map(|c| c.len()).min().unwrap_or(0);
    if m == 0 || n < MIN_DRAWS || chains.iter().any(|c| c[..n].iter().any(|v| !v.is_finite())) {
        return f64::NAN;
    }
    let means: Vec<f64> = chains.iter().map(|c| mean(&c[..n])).collect();
    let vars: Vec<f64> = chains.iter().map(|c| variance(&c[..n])).collect();
    let w = mean(&vars);
    let b_over_n = if m > 1 { variance(&means) } else { 0.0 };
    let var_plus = (n as f64 - 1.0) / n as f64 * w + b_over_n;
    if var_plus.is_nan() || var_plus <= 0.0 {
        return f64::NAN;
    }
    let acfs: Vec<Vec<f64>> = chains.iter().map(|c| autocorrelation(&c[..n])).collect();
    if acfs.iter().any(|a| a.is_empty()) {
        return f64::NAN;
    }
    let rho: Vec<f64> = (0..n)
        .map(|t| {
            // autocovariance of chain j at lag t: ρ_t,j · s²_j (n−1)/n
            let avg_cov: f64 = (0..m)
                .map(|j| acfs[j][t] * vars[j] * (n as f64 - 1.0) / n as f64)
                .sum::<f64>()
                / m as f64;
            if t == 0 {
                1.0
            } else {
                1.0 - (w - avg_cov) / var_plus
            }
        })
        .collect();
    let tau = geyer_tau(&rho).max(1.0 / ((m * n) as f64).log10());
    (m * n) as f64 / tau
}

/// Monte Carlo standard error of the mean of one chain, `sd / sqrt(ESS)`.
pub fn mcse_mean(x: &[f64]) -> f64 {
    if x.len() < MIN_DRAWS {
        return f64::NAN;
    }
    (variance(x) / ess(x)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;
    use rand::RngExt;
    use rand_distr::StandardNormal;

    fn ar1(a: f64, n: usize, seed: u64) -> Vec<f64> {
        let mut rng = stream(seed, 0);
        let mut x = 0.0;
        let s = (1.0 - a * a).sqrt();
        let e0: f64 = rng.sample(StandardNormal);
        x += e0;
        (0..n)
            .map(|_| {
                let e: f64 = rng.sample(StandardNormal);
                x = a * x + s * e;
                x
            })
            .collect()
    }

    /// AR(1) has τ = (1+a)/(1−a). With n = 200 000 the estimator's relative standard error is a few
    /// percent for these a; the 10% band is > 3 standard errors (false-failure rate < 0.3% per a,
    /// seeded so the outcome is fixed).
    #[test]
    fn ar1_tau_matches_theory() {
        for (i, a) in [0.0, 0.5, 0.9].into_iter().enumerate() {
            let x = ar1(a, 200_000, 10 + i as u64);
            let tau = integrated_autocorrelation_time(&x);
            let want = (1.0 + a) / (1.0 - a);
            assert!(
                (tau / want - 1.0).abs() < 0.1,
                "a = {a}: tau {tau}, want {want}"
            );
            let e = ess(&x);
            assert!((e / (200_000.0 / want) - 1.0).abs() < 0.1);
        }
    }

    #[test]
    fn multi_chain_ess_agrees_with_single_chain_theory() {
        let a = 0.8;
        let chains: Vec<Vec<f64>> = (0..4).map(|s| ar1(a, 50_000, 100 + s)).collect();
        let refs: Vec<&[f64]> = chains.iter().map(|c| c.as_slice()).collect();
        let e = ess_chains(&refs);
        let want = 200_000.0 * (1.0 - a) / (1.0 + a);
        assert!((e / want - 1.0).abs() < 0.12, "ess {e} want {want}");
    }

    #[test]
    fn chains_in_different_places_have_low_ess() {
        let c1 = ar1(0.5, 10_000, 1);
        let c2: Vec<f64> = ar1(0.5, 10_000, 2).iter().map(|v| v + 10.0).collect();
        let e = ess_chains(&[&c1, &c2]);
        assert!(e < 100.0, "ess {e}");
    }

    #[test]
    fn degenerate_input_gives_nan() {
        assert!(integrated_autocorrelation_time(&[1.0; 100]).is_nan());
        assert!(integrated_autocorrelation_time(&[1.0, 2.0, 3.0]).is_nan());
        assert!(ess(&[]).is_nan());
        assert!(ess_chains(&[&[2.0; 50], &[2.0; 50]]).is_nan());
        assert!(mcse_mean(&[1.0]).is_nan());
        assert!(integrated_autocorrelation_time(&[1.0, f64::NAN, 2.0, 3.0, 4.0]).is_nan());
    }

    #[test]
    fn mcse_of_iid_draws_is_sd_over_sqrt_n() {
        let x = ar1(0.0, 40_000, 7);
        let m = mcse_mean(&x);
        assert!((m / (1.0 / 200.0) - 1.0).abs() < 0.1, "{m}");
    }
}
