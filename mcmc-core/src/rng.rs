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
    Substreams::new(master_seed, purpose).get(index)
}

/// The key of a purpose's generators: the purpose mixed into the master seed by SplitMix64's
/// finaliser (streams stay selected by index).
fn purpose_key(master_seed: u64, purpose: u64) -> u64 {
    mix64(master_seed ^ purpose.wrapping_mul(GOLDEN_GAMMA))
}

/// SplitMix64's increment: 2^64 divided by the golden ratio, odd.
const GOLDEN_GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// SplitMix64's output function (Steele, Lea and Flood 2014; the variant of Stafford's
/// `Mix13`): a bijection of 64-bit words in which every input bit affects every output bit. The
/// one mixer of this workspace's keys.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Number `counter` of the uniform sequence keyed by `key`: the `counter`-th output (from 0) of
/// SplitMix64 started at state `key`, as a 53-bit number in `[0, 1)` like [`uniform`]'s. A
/// counter-based generator: any number is computed directly from its position, so readers that
/// visit positions in different orders, or some positions only, agree on every number they share.
///
/// ```
/// use mcmc_core::rng::{counter_uniform, uniform};
/// use rand::SeedableRng;
/// let mut sequential = rand_xoshiro::SplitMix64::seed_from_u64(99);
/// for i in 0..16 {
///     assert_eq!(counter_uniform(99, i), uniform(&mut sequential));
/// }
/// ```
#[inline]
pub fn counter_uniform(key: u64, counter: u64) -> f64 {
    let z = mix64(key.wrapping_add(counter.wrapping_add(1).wrapping_mul(GOLDEN_GAMMA)));
    (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// The sub-streams of one purpose of a master seed, for a caller that makes many of them:
/// [`Substreams::get`] gives [`substream`]'s generators bit for bit, but keys the generator once
/// and copies it, rather than expanding the seed through PCG32 and setting ChaCha up per stream.
/// (The pass driver's per-pixel generators used it; they are now [`FastSubstreams`].)
///
/// ```
/// use mcmc_core::rng::{Substreams, substream};
/// use rand::Rng;
/// let pixels = Substreams::new(7, 42);
/// assert_eq!(pixels.get(3).next_u64(), substream(7, 42, 3).next_u64());
/// ```
#[derive(Clone, Debug)]
pub struct Substreams {
    /// The generator keyed for the purpose, on stream 0, nothing drawn yet.
    keyed: ChainRng,
}

impl Substreams {
    /// The sub-streams of `purpose` of `master_seed`.
    pub fn new(master_seed: u64, purpose: u64) -> Self {
        Self {
            keyed: ChainRng::seed_from_u64(purpose_key(master_seed, purpose)),
        }
    }

    /// Sub-stream `index`: a copy of the keyed generator, which has drawn nothing, so selecting
    /// the stream costs no block of output.
    #[inline]
    pub fn get(&self, index: u64) -> ChainRng {
        let mut rng = self.keyed.clone();
        rng.set_stream(index);
        rng
    }
}

/// The generator for short-lived draws that need no streams of their own: xoshiro256++
/// (Blackman and Vigna 2021), its state filled by SplitMix64 from one 64-bit seed. A proposal or
/// an independent sample that reads a few dozen numbers and is then dropped costs less with it
/// than with a [`ChainRng`], whose keying and first four-block refill cost more than the numbers
/// themselves. Not for chains, replicas or workers: those keep their ChaCha8 streams.
pub type FastRng = rand_xoshiro::Xoshiro256PlusPlus;

/// The [`FastRng`] for stream `index` of `master_seed`: seed and index mixed by SplitMix64's
/// finaliser (as [`substream`] mixes a purpose), then expanded by SplitMix64 into the state, so
/// neighbouring seeds or indices give unrelated generators.
///
/// ```
/// use mcmc_core::rng::fast_stream;
/// use rand::Rng;
/// assert_eq!(fast_stream(7, 3).next_u64(), fast_stream(7, 3).next_u64());
/// assert_ne!(fast_stream(7, 3).next_u64(), fast_stream(7, 4).next_u64());
/// assert_ne!(fast_stream(7, 3).next_u64(), fast_stream(8, 3).next_u64());
/// ```
#[inline]
pub fn fast_stream(master_seed: u64, index: u64) -> FastRng {
    FastRng::seed_from_u64(purpose_key(master_seed, index))
}

/// The [`FastRng`] sub-streams of one purpose of a master seed, for a caller that makes a
/// generator per item (a pass's pixels): [`FastSubstreams::get`]`(i)` is
/// [`fast_stream`]`(k, i)` with `k` the purpose mixed into the master seed once, as
/// [`Substreams`] mixes it. A generator then costs one SplitMix64 expansion of 32 bytes, where a
/// [`ChainRng`] copies about 300 bytes and refills four blocks before its first number.
///
/// ```
/// use mcmc_core::rng::FastSubstreams;
/// use rand::Rng;
/// let pixels = FastSubstreams::new(7, 42);
/// assert_eq!(pixels.get(3).next_u64(), FastSubstreams::new(7, 42).get(3).next_u64());
/// assert_ne!(pixels.get(3).next_u64(), pixels.get(4).next_u64());
/// assert_ne!(pixels.get(3).next_u64(), FastSubstreams::new(7, 43).get(3).next_u64());
/// ```
#[derive(Clone, Copy, Debug)]
pub struct FastSubstreams {
    key: u64,
}

impl FastSubstreams {
    /// The sub-streams of `purpose` of `master_seed`.
    pub fn new(master_seed: u64, purpose: u64) -> Self {
        Self {
            key: purpose_key(master_seed, purpose),
        }
    }

    /// Sub-stream `index`.
    #[inline]
    pub fn get(&self, index: u64) -> FastRng {
        fast_stream(self.key, index)
    }
}

/// A uniform draw in `[0, 1)` with 53 random bits (from a [`ChainRng`] or any other generator).
#[inline]
pub fn uniform<R: rand::Rng + ?Sized>(rng: &mut R) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A uniform index in `0 .. n` from a uniform number `u` in `[0, 1)` (`n ≥ 1`; rounding at the
/// top end falls to `n − 1`).
///
/// ```
/// use mcmc_core::rng::uniform_index;
/// assert_eq!(uniform_index(0.0, 3), 0);
/// assert_eq!(uniform_index(0.5, 3), 1);
/// assert_eq!(uniform_index(0.999_999_999_999_999_9, 3), 2);
/// ```
#[inline]
pub fn uniform_index(u: f64, n: usize) -> usize {
    ((u * n as f64) as usize).min(n.saturating_sub(1))
}

/// The index drawn with probability proportional to `weights` by the uniform number `u` in
/// `[0, 1)` (inverse of the cumulative sum; non-positive and NaN weights are never chosen, and
/// rounding at the top end falls to the last positive weight). `None` when no weight is positive.
pub fn categorical(weights: &[f64], u: f64) -> Option<usize> {
    let total: f64 = weights.iter().filter(|w| **w > 0.0).sum();
    let mut v = u * total;
    let mut last = None;
    for (i, &w) in weights.iter().enumerate() {
        if w > 0.0 {
            if v < w {
                return Some(i);
            }
            v -= w;
            last = Some(i);
        }
    }
    last
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn categorical_follows_the_weights() {
        let w = [0.0, 1.0, f64::NAN, 3.0, -2.0];
        assert_eq!(categorical(&w, 0.0), Some(1));
        assert_eq!(categorical(&w, 0.2499), Some(1));
        assert_eq!(categorical(&w, 0.25), Some(3));
        assert_eq!(categorical(&w, 0.999_999_999), Some(3));
        assert_eq!(categorical(&[0.0, -1.0], 0.5), None);
        let mut rng = stream(3, 0);
        let n = 40_000;
        let hits = (0..n)
            .filter(|_| categorical(&w, uniform(&mut rng)) == Some(3))
            .count();
        // Binomial(40 000, 3/4): sd 86.6; 6 sd.
        assert!((hits as f64 - 0.75 * n as f64).abs() < 520.0, "{hits}");
    }

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u64> = (0..4).map(|_| stream(1, 0).next_u64()).collect();
        assert!(a.windows(2).all(|w| w[0] == w[1]));
        assert_ne!(stream(1, 0).next_u64(), stream(2, 0).next_u64());
        assert_ne!(substream(1, 1, 0).next_u64(), substream(1, 2, 0).next_u64());
    }

    /// A sub-stream made from the shared keyed generator is the one made from scratch, for the
    /// first numbers (within the first block and past it) of several streams and purposes.
    #[test]
    fn substreams_are_the_streams_keyed_from_scratch() {
        for (seed, purpose) in [(0, 0), (7, 0x5eed_0001), (u64::MAX, 3)] {
            let shared = Substreams::new(seed, purpose);
            for index in [0, 1, 2, 1000, u64::MAX] {
                let keyed = stream(purpose_key(seed, purpose), index);
                let (mut a, mut b) = (shared.get(index), keyed);
                for _ in 0..100 {
                    assert_eq!(a.next_u64(), b.next_u64(), "{seed} {purpose} {index}");
                }
            }
        }
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
