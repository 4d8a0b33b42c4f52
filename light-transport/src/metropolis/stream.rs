//! A [`SampleStream`] over a lazy primary-sample state: path construction reads the state's
//! coordinates, which are created or brought up to date on demand.

use crate::sampler::{STREAMS, SampleStream};
use mcmc_core::primary_sample::PrimarySample;

/// Reads a [`PrimarySample`] in the renderer's stream layout.
pub struct PrimaryStream<'a> {
    sample: &'a mut PrimarySample,
    current: usize,
    pos: [usize; STREAMS],
}

impl<'a> PrimaryStream<'a> {
    /// Read `sample` from the start of every substream.
    pub fn new(sample: &'a mut PrimarySample) -> Self {
        Self {
            sample,
            current: 0,
            pos: [0; STREAMS],
        }
    }
}

impl SampleStream for PrimaryStream<'_> {
    fn start_stream(&mut self, index: usize) {
        self.current = index;
    }
    #[inline]
    fn next_1d(&mut self) -> f64 {
        let i = self.pos[self.current];
        self.pos[self.current] += 1;
        self.sample.get(self.current, i)
    }
    fn seek(&mut self, index: usize) {
        self.pos[self.current] = index;
    }
    fn position(&self) -> usize {
        self.pos[self.current]
    }
}
