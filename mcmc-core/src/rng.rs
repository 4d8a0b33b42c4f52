//! Portable, seedable random streams for chains.
//!
//! Every chain, replica or worker draws from its own [`ChainRng`]: a ChaCha8 generator keyed by a
//! master seed and selecting one of 2^64 independent streams by index (`set_stream`). Stream `i` of
//! master seed `s` is the same on every machine and independent of how many threads run, so results
//! are reproducible and do not depend on scheduling. Never derive streams as `seed + i`: neighbouring
//! seeds of many generators are correlated, while ChaCha streams are independent by construction.

use rand::SeedableRng;

/// The random number generator used by every kernel of this crate (ChaCha8 from `rand_chacha`:
/// portable, seedable, and cloneable so a chain's stream can be snapshot and resumed).
pub type ChainRng = rand_chacha::ChaCha8Rng;

/// The generator for stream `index` of `master_seed`.
///
/// ```
/// use mcmc_core::rng::stream;
/// use rand::Rng;
/// let mut a = stream(7, 3);
/// let mut b = stream(7, 3);
/// assert_eq!(a.next_u64(), b.next_u64());
/// assert_ne!(stream(7, 3).next_u64(), stream(7, 4).next_u64());
/// ```
pub fn stream(master_seed: u64, index: u64) -> ChainRng {
    let mut rng = ChainRng::seed_from_u64(master_seed);
    rng.set_stream(index);
    rng
}

/// The generator for sub-stream `index` of a named purpose (e.g. "bootstrap", "chains") of
/// `master_seed`, so that different phases of one run never share numbers.
pub fn substream(master_seed: u64, purpose: u64, index: u64) -> ChainRng {
    // Mix the purpose into the key with SplitMix64 finalisation; streams stay selected by index.
    let mut z = master_seed ^ purpose.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    stream(z, index)
}

/// A uniform draw in `[0, 1)` with 53 random bits.
#[inline]
pub fn uniform(rng: &mut ChainRng) -> f64 {
    use rand::Rng;
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u64> = (0..4).map(|_| stream(1, 0).next_u64()).collect();
        assert!(a.windows(2).all(|w| w[0] == w[1]));
        assert_ne!(stream(1, 0).next_u64(), stream(2, 0).next_u64());
        assert_ne!(substream(1, 1, 0).next_u64(), substream(1, 2, 0).next_u64());
    }

    #[test]
    fn a_cloned_stream_continues_identically() {
        let mut a = stream(5, 9);
        a.next_u64();
        let mut b = a.clone();
        assert_eq!(a.next_u64(), b.next_u64());
    }

    #[test]
    fn uniform_is_in_unit_interval() {
        let mut r = stream(0, 0);
        for _ in 0..10_000 {
            let u = uniform(&mut r);
            assert!((0.0..1.0).contains(&u));
        }
    }
}
