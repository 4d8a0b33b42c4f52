//! A [`SampleStream`] over a lazy primary-sample state: path construction reads the state's
//! coordinates, which are created or brought up to date on demand.

use crate::sampler::{Cursor, SampleStream};
use mcmc_core::primary_sample::PrimarySample;

/// Reads a [`PrimarySample`] in the renderer's stream layout.
pub struct PrimaryStream<'a> {
    sample: &'a mut PrimarySample,
    cursor: Cursor,
}

impl<'a> PrimaryStream<'a> {
    /// Read `sample` from the start of every substream.
    pub fn new(sample: &'a mut PrimarySample) -> Self {
        Self {
            sample,
            cursor: Cursor::default(),
        }
    }
}

impl SampleStream for PrimaryStream<'_> {
    fn start_stream(&mut self, index: usize) {
        self.cursor.start(index);
    }
    #[inline]
    fn next_1d(&mut self) -> f64 {
        let (stream, i) = self.cursor.advance();
        self.sample.get(stream, i)
    }
    fn seek(&mut self, index: usize) {
        self.cursor.seek(index);
    }
    fn position(&self) -> usize {
        self.cursor.position()
    }
}
