//! Owen-scrambled two-dimensional Sobol points: the first two dimensions of Sobol's sequence
//! (Sobol 1967), the van der Corput sequence and its partner of the Pascal matrix, which
//! together form a `(0, 2)`-sequence in base 2: the first `2^m` points put exactly one point in
//! each of `2^m` equal rectangles of any shape, and each coordinate alone is stratified likewise.
//! Each seed shuffles the points and Owen-scrambles both coordinates by hashing (Burley 2020,
//! with the hash of the `sobol_burley` crate), so every point is uniform on the unit square and
//! the nets survive.
//!
//! The crate computes the second coordinate by a loop over the index's bits. Its generator
//! matrix has a closed form: by Lucas' theorem bit `j` of the (bit-reversed) coordinate is the
//! parity of the index bits `k` whose binary digits include `j`'s, a transform of five shifts.
//! A point costs about half the crate's `sample_4d` (151 instructions for both coordinates,
//! against 287 for four); a test checks that it equals the crate's `sample` in both
//! coordinates for every index.

use sobol_burley::parts::{hash, owen_scramble_rev};

/// Points of the sequence (the crate's limit).
pub const POINTS: u64 = 1 << 16;

/// Bit `j` of the result: the parity of the bits `k ⊇ j` of `i` (Pascal's triangle mod 2): the
/// second Sobol coordinate of index `i`, bit-reversed.
#[inline]
fn pascal(i: u32) -> u32 {
    let mut v = i;
    v ^= (v >> 1) & 0x5555_5555;
    v ^= (v >> 2) & 0x3333_3333;
    v ^= (v >> 4) & 0x0f0f_0f0f;
    v ^= (v >> 8) & 0x00ff_00ff;
    v ^= (v >> 16) & 0x0000_ffff;
    v
}

/// Point `index` of a sequence, its coordinates computed on demand ([`Point::coordinate`]).
#[derive(Clone, Copy, Debug)]
pub struct Point {
    /// The shuffled index.
    i: u32,
    seed: u32,
}

impl Point {
    /// Point `index` (below [`POINTS`]) of the sequence scrambled by `seed`, from the index with
    /// its bits reversed (`index.reverse_bits()`: a pixel's sets share it).
    #[inline]
    pub fn new(index_reversed: u32, seed: u32) -> Self {
        debug_assert!(u64::from(index_reversed.reverse_bits()) < POINTS);
        let shuffled = owen_scramble_rev(index_reversed, hash(seed ^ 0x79c6_8e4a));
        Self {
            i: (shuffled & 0xffff_0000).reverse_bits(),
            seed,
        }
    }

    /// Coordinate `d` (0 or 1) as a 32-bit fixed-point fraction: the crate's
    /// `sample(index, d, seed)`, to its 23 bits.
    #[inline]
    pub fn coordinate(&self, d: usize) -> u32 {
        let scramble = hash(self.seed.wrapping_mul(0x9c8f_2d3b) ^ [0x912f_69ba, 0x174f_18ab][d]);
        let sobol = if d == 0 { self.i } else { pascal(self.i) };
        owen_scramble_rev(sobol, scramble).reverse_bits()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed form is the crate's sequence: every index of several seeds, both coordinates.
    /// (Wrong masks or shift directions in `pascal`, or another scramble, fail at once.)
    #[test]
    fn points_are_the_crates_first_two_dimensions() {
        let to_f32 = |v: u32| sobol_burley::parts::u32_to_f32_norm(v);
        for seed in [0u32, 1, 7, 0x9e37_79b9, u32::MAX] {
            for index in 0..POINTS as u32 {
                let p = Point::new(index.reverse_bits(), seed);
                let (x, y) = (p.coordinate(0), p.coordinate(1));
                assert_eq!(
                    to_f32(x),
                    sobol_burley::sample(index, 0, seed),
                    "{seed} {index}"
                );
                assert_eq!(
                    to_f32(y),
                    sobol_burley::sample(index, 1, seed),
                    "{seed} {index}"
                );
            }
        }
    }
}
