//! A stream whose every number is a function of its key and its position alone (a counter-based
//! generator, [`mcmc_core::rng::counter_uniform`]), not of the order in which numbers are read.
//!
//! This is what lets one independent sample serve every path length at once: with the layout of
//! [`crate::sampler`], a subpath of `t` vertices reads the first numbers of its substream that a
//! longer subpath reads, so the walks of the longest path length, traced once, are the walks of
//! every shorter one, number for number. A sequential generator (a lazy primary sample's, an
//! [`super::IndependentStream`]'s) gives a number the next value in draw order instead, which
//! depends on what was read before it.

use super::{Cursor, SampleStream};
use mcmc_core::rng::counter_uniform;

/// Numbers addressed by `(key, substream, position)`.
#[derive(Clone, Debug)]
pub struct KeyedStream {
    key: u64,
    cursor: Cursor,
}

impl KeyedStream {
    /// The stream of `key`, every substream at its start.
    pub fn new(key: u64) -> Self {
        Self {
            key,
            cursor: Cursor::default(),
        }
    }

    /// Number `index` of substream `stream`.
    #[inline]
    pub fn number(&self, stream: usize, index: usize) -> f64 {
        // Substreams are 2^32 apart in the key's sequence: far beyond any path's numbers.
        counter_uniform(self.key, ((stream as u64) << 32) | index as u64)
    }

    /// The first `len` numbers of substream `stream` (e.g. to fill a primary sample with the
    /// numbers a walk on this stream reads).
    pub fn numbers(&self, stream: usize, len: usize) -> Vec<f64> {
        (0..len).map(|i| self.number(stream, i)).collect()
    }
}

impl SampleStream for KeyedStream {
    fn start_stream(&mut self, index: usize) {
        self.cursor.start(index);
    }
    #[inline]
    fn next_1d(&mut self) -> f64 {
        let (stream, i) = self.cursor.advance();
        self.number(stream, i)
    }
    fn seek(&mut self, index: usize) {
        self.cursor.seek(index);
    }
    fn position(&self) -> usize {
        self.cursor.position()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A number depends on its position only: reading a substream forwards, backwards, or
    /// interleaved with another gives the same numbers; substreams and keys differ.
    #[test]
    fn numbers_depend_on_position_not_on_reading_order() {
        let mut forwards = KeyedStream::new(5);
        let ahead: Vec<f64> = (0..20).map(|_| forwards.next_1d()).collect();
        let mut backwards = KeyedStream::new(5);
        backwards.start_stream(2);
        let _ = backwards.next_2d();
        backwards.start_stream(0);
        for i in (0..20).rev() {
            backwards.seek(i);
            assert_eq!(backwards.next_1d(), ahead[i]);
        }
        assert_eq!(KeyedStream::new(5).numbers(0, 20), ahead);
        assert_ne!(KeyedStream::new(5).numbers(1, 20), ahead);
        assert_ne!(KeyedStream::new(6).numbers(0, 20), ahead);
    }
}
