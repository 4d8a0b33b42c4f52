//! Rank-normalised split R-hat and bulk/tail ESS (Vehtari, Gelman, Simpson, Carpenter & Bürkner,
//! "Rank-normalization, folding, and localization: an improved R-hat", Bayesian Analysis 2021).

use super::{MIN_DRAWS, autocorr::ess_chains, mean, variance};
use statrs::distribution::{ContinuousCDF, Normal};

/// Rank-normalise pooled draws: `z = Φ⁻¹((r − 3/8) / (S + 1/4))` with average ranks for ties.
/// Returns the chains' normalised values in the same shape.
pub fn rank_normalize(chains: &[&[f64]]) -> Vec<Vec<f64>> {
    let mut all: Vec<(f64, usize, usize)> = Vec::new();
    for (c, chain) in chains.iter().enumerate() {
        for (i, &v) in chain.iter().enumerate() {
            all.push((v, c, i));
        }
    }
    let s = all.len() as f64;
    all.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out: Vec<Vec<f64>> = chains.iter().map(|c| vec![0.0; c.len()]).collect();
    let normal = Normal::standard();
    let mut i = 0;
    while i < all.len() {
        let mut j = i;
        while j + 1 < all.len() && all[j + 1].0 == all[i].0 {
            j += 1;
        }
        let rank = (i + j) as f64 / 2.0 + 1.0; // average 1-based rank of the tie group
        let z = normal.inverse_cdf((rank - 0.375) / (s + 0.25));
        for item in &all[i..=j] {
            out[item.1][item.2] = z;
        }
        i = j + 1;
    }
    out
}

/// Classic (non-split) potential scale reduction of `chains`; NaN when a chain is too short or
/// the within-chain variance is zero.
pub fn rhat(chains: &[&[f64]]) -> f64 {
    let m = chains.len();
    let n = chains.iter().map(|c| c.len()).min().unwrap_or(0);
    if m < 2 || n < MIN_DRAWS / 2 || chains.iter().flat_map(|c| c.iter()).any(|v| !v.is_finite()) {
        return f64::NAN;
    }
    let means: Vec<f64> = chains.iter().map(|c| mean(&c[..n])).collect();
    let w = mean(&chains.iter().map(|c| variance(&c[..n])).collect::<Vec<_>>());
    if w.is_nan() || w <= 0.0 {
        return f64::NAN;
    }
    let b_over_n = variance(&means);
    let var_plus = (n as f64 - 1.0) / n as f64 * w + b_over_n;
    (var_plus / w).sqrt()
}

fn split(chains: &[&[f64]]) -> Vec<Vec<f64>> {
    let n = chains.iter().map(|c| c.len()).min().unwrap_or(0);
    let h = n / 2;
    chains
        .iter()
        .flat_map(|c| [c[..h].to_vec(), c[n - h..n].to_vec()])
        .collect()
}

fn as_refs(v: &[Vec<f64>]) -> Vec<&[f64]> {
    v.iter().map(|c| c.as_slice()).collect()
}

fn folded(chains: &[&[f64]]) -> Vec<Vec<f64>> {
    let mut pooled: Vec<f64> = chains.iter().flat_map(|c| c.iter().copied()).collect();
    pooled.sort_by(f64::total_cmp);
    let med = if pooled.is_empty() {
        f64::NAN
    } else if pooled.len() % 2 == 1 {
        pooled[pooled.len() / 2]
    } else {
        0.5 * (pooled[pooled.len() / 2 - 1] + pooled[pooled.len() / 2])
    };
    chains
        .iter()
        .map(|c| c.iter().map(|v| (v - med).abs()).collect())
        .collect()
}

/// Rank-normalised split R-hat: the maximum of the bulk R-hat (rank-normalised split chains) and
/// the tail R-hat (the same on draws folded about the median). Values above 1.01 indicate chains
/// that have not mixed. A single chain is split in two. NaN for constant or too-short input.
pub fn split_rhat(chains: &[&[f64]]) -> f64 {
    let n = chains.iter().map(|c| c.len()).min().unwrap_or(0);
    if chains.is_empty() || n < MIN_DRAWS {
        return f64::NAN;
    }
    let s = split(chains);
    let bulk = rhat(&as_refs(&rank_normalize(&as_refs(&s))));
    let f = folded(&as_refs(&s));
    let tail = rhat(&as_refs(&rank_normalize(&as_refs(&f))));
    if bulk.is_nan() || tail.is_nan() {
        return f64::NAN;
    }
    bulk.max(tail)
}

/// Bulk ESS: multi-chain ESS of the rank-normalised split chains.
pub fn ess_bulk(chains: &[&[f64]]) -> f64 {
    let n = chains.iter().map(|c| c.len()).min().unwrap_or(0);
    if chains.is_empty() || n < MIN_DRAWS || constant(chains) {
        return f64::NAN;
    }
    let s = split(chains);
    ess_chains(&as_refs(&rank_normalize(&as_refs(&s))))
}

/// Tail ESS: the smaller ESS of the 5% and 95% quantile indicators of the split chains.
pub fn ess_tail(chains: &[&[f64]]) -> f64 {
    let n = chains.iter().map(|c| c.len()).min().unwrap_or(0);
    if chains.is_empty() || n < MIN_DRAWS || constant(chains) {
        return f64::NAN;
    }
    let s = split(chains);
    let mut pooled: Vec<f64> = s.iter().flat_map(|c| c.iter().copied()).collect();
    pooled.sort_by(f64::total_cmp);
    let q = |p: f64| pooled[((pooled.len() - 1) as f64 * p).round() as usize];
    let (q05, q95) = (q(0.05), q(0.95));
    let ind = |t: f64, below: bool| -> Vec<Vec<f64>> {
        s.iter()
            .map(|c| {
                c.iter()
                    .map(|&v| ((v <= t) == below) as u8 as f64)
                    .collect()
            })
            .collect()
    };
    let e1 = ess_chains(&as_refs(&ind(q05, true)));
    let e2 = ess_chains(&as_refs(&ind(q95, true)));
    e1.min(e2)
}

fn constant(chains: &[&[f64]]) -> bool {
    let first = chains.iter().find_map(|c| c.first().copied());
    match first {
        None => true,
        Some(f) => chains.iter().all(|c| c.iter().all(|&v| v == f)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;
    use rand::RngExt;
    use rand_distr::StandardNormal;

    fn normals(n: usize, seed: u64, shift: f64, scale: f64) -> Vec<f64> {
        let mut r = stream(seed, 0);
        (0..n)
            .map(|_| shift + scale * r.sample::<f64, _>(StandardNormal))
            .collect()
    }

    #[test]
    fn mixed_chains_have_rhat_near_one() {
        let c: Vec<Vec<f64>> = (0..4).map(|s| normals(2000, s, 0.0, 1.0)).collect();
        let r = split_rhat(&as_refs(&c));
        assert!(r < 1.01, "{r}");
        let e = ess_bulk(&as_refs(&c));
        assert!(e > 6000.0 && e < 10_000.0, "{e}");
        assert!(ess_tail(&as_refs(&c)) > 3000.0);
    }

    #[test]
    fn shifted_chain_is_detected_by_bulk_rhat() {
        let mut c: Vec<Vec<f64>> = (0..3).map(|s| normals(2000, s, 0.0, 1.0)).collect();
        c.push(normals(2000, 9, 1.0, 1.0));
        assert!(split_rhat(&as_refs(&c)) > 1.05);
    }

    #[test]
    fn scale_difference_is_detected_by_tail_rhat() {
        let mut c: Vec<Vec<f64>> = (0..3).map(|s| normals(2000, s, 0.0, 1.0)).collect();
        c.push(normals(2000, 9, 0.0, 3.0));
        assert!(split_rhat(&as_refs(&c)) > 1.05);
    }

    #[test]
    fn trend_within_one_chain_is_detected_by_splitting() {
        let c: Vec<f64> = (0..2000).map(|i| i as f64 / 100.0).collect();
        assert!(split_rhat(&[&c]) > 1.5);
    }

    #[test]
    fn degenerate_input_gives_nan() {
        assert!(split_rhat(&[&[1.0; 100], &[1.0; 100]]).is_nan());
        assert!(split_rhat(&[&[1.0, 2.0]]).is_nan());
        assert!(ess_bulk(&[&[3.0; 10]]).is_nan());
    }

    #[test]
    fn rank_normalisation_is_monotone_and_centred() {
        let c = [vec![3.0, 1.0, 2.0], vec![10.0, -5.0, 2.0]];
        let z = rank_normalize(&as_refs(&c));
        assert!(z[0][1] < z[0][2] && z[0][2] < z[0][0] && z[1][1] < z[0][1]);
        assert_eq!(z[0][2], z[1][2]); // ties share a rank
        let s: f64 = z.iter().flatten().sum();
        assert!(s.abs() < 1e-12);
    }
}
