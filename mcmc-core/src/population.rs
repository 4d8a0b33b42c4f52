//! Seeding chains from a population without start-up bias: draw the starting states of `n` chains
//! from a weighted population (e.g. a bootstrap of independent samples weighted by their target
//! value over their sampling density) in proportion to the weights. Systematic resampling (the
//! positions `(i + ξ)/n` of the charted-MLT paper's Algorithm 2) gives every member exactly its
//! expected number of copies up to rounding, `⌊n w_i / W⌋` or one more.

use crate::{ChainRng, McmcError, rng::uniform};

/// Indices of `n` members drawn in proportion to `weights` by systematic resampling, in
/// increasing order. Weights must be finite and non-negative with a positive sum.
///
/// ```
/// use mcmc_core::{population::systematic_resample, rng::stream};
/// let picks = systematic_resample(&[1.0, 0.0, 3.0], 4, &mut stream(0, 0)).unwrap();
/// assert_eq!(picks.iter().filter(|&&i| i == 2).count(), 3);
/// assert!(!picks.contains(&1));
/// ```
pub fn systematic_resample(
    weights: &[f64],
    n: usize,
    rng: &mut ChainRng,
) -> Result<Vec<usize>, McmcError> {
    let mut total = 0.0;
    for &w in weights {
        if !(w.is_finite() && w >= 0.0) {
            return Err(McmcError::InvalidParameter {
                name: "weights",
                reason: format!("resampling weights must be finite and non-negative, got {w}"),
            });
        }
        total += w;
    }
    if total <= 0.0 {
        return Err(McmcError::InvalidParameter {
            name: "weights",
            reason: "every weight is zero: the population found no contribution".into(),
        });
    }
    let xi = uniform(rng);
    let mut out = Vec::with_capacity(n);
    let mut acc = 0.0;
    let mut i = 0;
    for k in 0..n {
        let target = (k as f64 + xi) / n as f64 * total;
        while i + 1 < weights.len() && acc + weights[i] <= target {
            acc += weights[i];
            i += 1;
        }
        // Skip zero-weight members a rounding tie could land on.
        while weights[i] == 0.0 && i + 1 < weights.len() {
            i += 1;
        }
        out.push(i);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;

    /// Every member gets ⌊n w_i/W⌋ or ⌈n w_i/W⌉ copies, and over many draws the mean count is
    /// exactly n w_i / W (checked to 5 standard errors).
    #[test]
    fn counts_are_exact_up_to_rounding_and_unbiased() {
        let w = [0.5, 2.0, 0.0, 1.25, 0.25, 3.0];
        let total: f64 = w.iter().sum();
        let n = 7;
        let mut sum = [0.0f64; 6];
        let reps = 20_000;
        let mut rng = stream(4, 0);
        for _ in 0..reps {
            let picks = systematic_resample(&w, n, &mut rng).unwrap();
            for (i, wi) in w.iter().enumerate() {
                let c = picks.iter().filter(|&&p| p == i).count() as f64;
                let e = n as f64 * wi / total;
                assert!(
                    c >= e.floor() && c <= e.ceil(),
                    "member {i}: {c} copies, expected {e}"
                );
                sum[i] += c;
            }
        }
        for (i, wi) in w.iter().enumerate() {
            let e = n as f64 * wi / total;
            let mean = sum[i] / reps as f64;
            // Counts are within one of each other: variance ≤ 1/4.
            assert!(
                (mean - e).abs() < 5.0 * 0.5 / (reps as f64).sqrt(),
                "member {i}"
            );
        }
    }

    #[test]
    fn bad_weights_are_refused() {
        let mut rng = stream(0, 0);
        assert!(systematic_resample(&[0.0, 0.0], 3, &mut rng).is_err());
        assert!(systematic_resample(&[1.0, f64::NAN], 3, &mut rng).is_err());
        assert!(systematic_resample(&[1.0, -1.0], 3, &mut rng).is_err());
    }
}
