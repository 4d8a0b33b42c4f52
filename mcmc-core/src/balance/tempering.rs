//! Checks specific to tempering ladders.
//!
//! Per-level marginals are tested with [`super::invariance`] on the product state of a replica
//! exchange (one feature per level) or on `(x, level)` of serial tempering (the level as a
//! categorical feature, and `x` per level with NaN where absent). This module adds the exact
//! round-trip count of the non-reversible schedule when every swap is accepted, and the expected
//! swap acceptance at stationarity against which a sampler's observed rate can be compared.

use crate::tempering::RoundTrips;
use crate::{ChainRng, Family};

/// Round trips completed after `rounds` swap rounds of the deterministic even/odd schedule on
/// `levels` levels when every swap is accepted.
///
/// With every swap accepted, the replica at level `p` heads up when `p` is even and down when odd,
/// and every replica then zig-zags with period `2K`: `K−1` rounds up, one round waiting at the top,
/// `K−1` rounds down, one round waiting at the bottom. This function evaluates those trajectories
/// in closed form (`level(t) = a((t + φ_p) mod 2K)` with `a` the zig-zag) and counts trips with the
/// sampler's definition (bottom → top → bottom, observed after each round).
pub fn deo_round_trips_all_accepted(levels: usize, rounds: u64) -> u64 {
    if levels < 2 {
        return 0;
    }
    let k = levels as u64;
    let zigzag = |t: u64| -> usize {
        let t = t % (2 * k);
        (if t < k { t } else { 2 * k - 1 - t }) as usize
    };
    let mut trips = RoundTrips::new(levels);
    trips.visit(0, 0, levels);
    for p in 0..levels as u64 {
        let phase = if p % 2 == 0 { p } else { 2 * k - 1 - p };
        for t in 1..=rounds {
            let l = zigzag(t + phase);
            if l == 0 || l == levels - 1 {
                trips.visit(p as usize, l, levels);
            }
        }
    }
    trips.total()
}

/// Monte Carlo estimate (with its standard error) of the expected acceptance probability of a
/// plain swap between levels `k` and `k+1` at stationarity, from independent exact draws of the
/// two levels.
pub fn expected_swap_acceptance<S: Clone, F: Family<S>>(
    family: &F,
    k: usize,
    mut exact: impl FnMut(usize, &mut ChainRng) -> S,
    draws: usize,
    rng: &mut ChainRng,
) -> (f64, f64) {
    let mut sum = 0.0;
    let mut sum2 = 0.0;
    for _ in 0..draws {
        let mut x = exact(k, rng);
        let mut z = exact(k + 1, rng);
        let (lxk, lzk1) = (
            family.ln_density(k, &mut x),
            family.ln_density(k + 1, &mut z),
        );
        let (lzk, lxk1) = (
            family.ln_density(k, &mut z),
            family.ln_density(k + 1, &mut x),
        );
        let a = crate::kernel::acceptance(lxk + lzk1, lzk + lxk1, 0.0).0;
        sum += a;
        sum2 += a * a;
    }
    let n = draws as f64;
    let mean = sum / n;
    (mean, ((sum2 / n - mean * mean).max(0.0) / n).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_levels_by_hand() {
        // Replica 0 reaches the top after round 1 and is back after round 3, then every 2 rounds
        // one of the two replicas completes a trip.
        assert_eq!(deo_round_trips_all_accepted(2, 2), 0);
        assert_eq!(deo_round_trips_all_accepted(2, 3), 1);
        assert_eq!(deo_round_trips_all_accepted(2, 5), 2);
        assert_eq!(deo_round_trips_all_accepted(2, 7), 3);
    }

    #[test]
    fn trips_grow_by_one_per_replica_per_period() {
        for k in 2..7u64 {
            let a = deo_round_trips_all_accepted(k as usize, 1000 * 2 * k);
            let b = deo_round_trips_all_accepted(k as usize, 1001 * 2 * k);
            assert_eq!(b - a, k);
        }
    }
}
