//! Sample streams: every path is a deterministic function of the numbers it reads from one stream.
//!
//! # Layout
//!
//! A stream has three *substreams*, selected with [`SampleStream::start_stream`]; each is read
//! sequentially from index 0 and path construction reads them in a fixed order:
//!
//! | substream | vertex | numbers |
//! |---|---|---|
//! | [`CAMERA_STREAM`] | camera endpoint | film position (2), lens position (2) |
//! | | each further camera-subpath vertex `i ≥ 1` | [`VERTEX_BLOCK`] = 4: lobe choice (1), direction (2), Russian roulette (1) |
//! | [`LIGHT_STREAM`] | light endpoint | light choice (1), position on the light (2), emitted direction (2) |
//! | | each further light-subpath vertex | [`VERTEX_BLOCK`] = 4, as above |
//! | [`TECHNIQUE_STREAM`] | integrator choices | technique choice (MMLT), light choice for next-event estimation and its position (3) |
//!
//! The Russian-roulette number is read only when roulette is enabled; otherwise it is a free
//! coordinate (inverses fill it uniformly). Numbers are always consumed block by block so that the
//! `i`-th vertex always reads the same positions: this is what lets Kelemen mutations perturb a
//! vertex in place and lets path inversion write a vertex's numbers back. [`layout`] names every
//! position; the walks, the integrators and the chart inverses all use it, and nothing else
//! spells out an offset.
//!
//! Implementations: [`IndependentStream`] (fresh random numbers), [`ReplayStream`] (a given vector
//! per substream — chart forward maps), [`Recorder`] (wraps a stream and keeps what was read), and
//! [`SliceStream`] (a writable stream over given vectors, where inverses [`WritableStream::put`]
//! the numbers of a path back in the layout), [`KeyedStream`] (numbers addressed by position:
//! one sample's walks serve every path length); and for the pass-based estimators, [`PixelStream`]
//! (independent numbers or a per-pixel Owen-scrambled Sobol sequence, [`PixelSampler`]).

mod keyed;
mod pixel;
mod sobol;

pub use keyed::KeyedStream;
pub use pixel::{PixelSampler, PixelStream, SOBOL_PASSES};

use mcmc_core::ChainRng;
use mcmc_core::rng::uniform;

/// Substream of the camera subpath.
pub const CAMERA_STREAM: usize = 0;
/// Substream of the light subpath.
pub const LIGHT_STREAM: usize = 1;
/// Substream of integrator-level choices (technique, next-event light).
pub const TECHNIQUE_STREAM: usize = 2;
/// Number of substreams.
pub const STREAMS: usize = 3;
/// Numbers per scattering vertex.
pub const VERTEX_BLOCK: usize = 4;
/// Numbers of the camera endpoint.
pub const CAMERA_BLOCK: usize = 4;
/// Numbers of the light endpoint.
pub const LIGHT_BLOCK: usize = 5;

/// Where every number lives (see the table above).
pub mod layout {
    use super::{CAMERA_BLOCK, LIGHT_BLOCK, VERTEX_BLOCK};

    /// Camera endpoint block: the film position (2 numbers).
    pub const FILM: usize = 0;
    /// Camera endpoint block: the lens position (2 numbers).
    pub const LENS: usize = 2;
    /// Light endpoint block: the choice of light (1 number).
    pub const LIGHT_CHOICE: usize = 0;
    /// Light endpoint block: the position on the light (2 numbers).
    pub const LIGHT_POSITION: usize = 1;
    /// Light endpoint block: the emitted direction (2 numbers).
    pub const LIGHT_DIRECTION: usize = 3;
    /// Vertex block: the lobe choice (1 number).
    pub const LOBE: usize = 0;
    /// Vertex block: the direction (2 numbers).
    pub const DIRECTION: usize = 1;
    /// Vertex block: Russian roulette (1 number).
    pub const ROULETTE: usize = 3;
    /// Technique substream: the technique (MMLT) or strategy (new paths) choice.
    pub const TECHNIQUE: usize = 0;

    /// Start of the block read when leaving the `b`-th vertex (`b ≥ 1`) of a subpath whose
    /// endpoint block has `endpoint` numbers.
    #[inline]
    pub fn vertex(endpoint: usize, b: usize) -> usize {
        endpoint + (b - 1) * VERTEX_BLOCK
    }

    /// [`vertex`] of a camera subpath.
    #[inline]
    pub fn camera_vertex(b: usize) -> usize {
        vertex(CAMERA_BLOCK, b)
    }

    /// [`vertex`] of a light subpath.
    #[inline]
    pub fn light_vertex(b: usize) -> usize {
        vertex(LIGHT_BLOCK, b)
    }

    /// Numbers a camera subpath of `t` vertices reads (its last vertex scatters nothing).
    pub fn camera_numbers(t: usize) -> usize {
        CAMERA_BLOCK + VERTEX_BLOCK * t.saturating_sub(2)
    }

    /// Numbers a light subpath of `s` vertices reads.
    pub fn light_numbers(s: usize) -> usize {
        if s == 0 {
            0
        } else {
            LIGHT_BLOCK + VERTEX_BLOCK * s.saturating_sub(2)
        }
    }
}

/// A source of numbers in `[0, 1)` organised in substreams.
pub trait SampleStream {
    /// Continue reading substream `index` (each substream remembers its position).
    fn start_stream(&mut self, index: usize);
    /// The next number of the current substream.
    fn next_1d(&mut self) -> f64;
    /// The next two numbers.
    fn next_2d(&mut self) -> [f64; 2] {
        [self.next_1d(), self.next_1d()]
    }
    /// Skip to position `index` of the current substream (used to keep vertex blocks aligned).
    fn seek(&mut self, index: usize);
    /// Position in the current substream.
    fn position(&self) -> usize;
}

impl<S: SampleStream + ?Sized> SampleStream for &mut S {
    fn start_stream(&mut self, index: usize) {
        (**self).start_stream(index)
    }
    fn next_1d(&mut self) -> f64 {
        (**self).next_1d()
    }
    fn next_2d(&mut self) -> [f64; 2] {
        (**self).next_2d()
    }
    fn seek(&mut self, index: usize) {
        (**self).seek(index)
    }
    fn position(&self) -> usize {
        (**self).position()
    }
}

/// Where a stream reads: its current substream and each substream's position, the part every
/// stream of the renderer's layout shares.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Cursor {
    current: usize,
    pos: [usize; STREAMS],
}

impl Cursor {
    /// The current substream.
    #[inline]
    pub fn current(&self) -> usize {
        self.current
    }
    /// Continue reading substream `index` ([`SampleStream::start_stream`]).
    #[inline]
    pub fn start(&mut self, index: usize) {
        self.current = index;
    }
    /// The `(substream, position)` of the next number, moving past it.
    #[inline]
    pub fn advance(&mut self) -> (usize, usize) {
        let i = self.pos[self.current];
        self.pos[self.current] += 1;
        (self.current, i)
    }
    /// Move the current substream to position `index` ([`SampleStream::seek`]).
    #[inline]
    pub fn seek(&mut self, index: usize) {
        self.pos[self.current] = index;
    }
    /// Position in the current substream ([`SampleStream::position`]).
    #[inline]
    pub fn position(&self) -> usize {
        self.pos[self.current]
    }
}

/// Fresh independent numbers from a generator: a [`ChainRng`] by default, or a
/// [`FastRng`](mcmc_core::rng::FastRng) for a stream that lives for one path (a new-path
/// proposal, a bootstrap sample, a pass-based estimator's sample). Positions are tracked
/// (skipped numbers are simply not drawn), so the stream is a valid "replayable" source for
/// statistics but not for replay.
#[derive(Clone, Debug)]
pub struct IndependentStream<R = ChainRng> {
    /// The generator.
    pub rng: R,
    cursor: Cursor,
}

impl<R> IndependentStream<R> {
    /// A stream drawing from `rng`.
    pub fn new(rng: R) -> Self {
        Self {
            rng,
            cursor: Cursor::default(),
        }
    }

    /// The current substream.
    pub fn current(&self) -> usize {
        self.cursor.current()
    }

    /// Reset positions for a new sample (numbers stay fresh).
    pub fn new_sample(&mut self) {
        self.cursor = Cursor::default();
    }
}

impl<R: rand::Rng> SampleStream for IndependentStream<R> {
    fn start_stream(&mut self, index: usize) {
        self.cursor.start(index);
    }
    fn next_1d(&mut self) -> f64 {
        self.cursor.advance();
        uniform(&mut self.rng)
    }
    fn seek(&mut self, index: usize) {
        self.cursor.seek(index);
    }
    fn position(&self) -> usize {
        self.cursor.position()
    }
}

/// Replays given vectors, one per substream. Reading past the end of a vector returns 0.5 and
/// marks the stream as *exhausted* (a fixed-dimension chart forward map must never do that;
/// [`ReplayStream::exhausted`] reports it).
#[derive(Clone, Debug)]
pub struct ReplayStream<'a> {
    data: [&'a [f64]; STREAMS],
    cursor: Cursor,
    exhausted: bool,
}

impl<'a> ReplayStream<'a> {
    /// Replay `camera`, `light` and `technique` numbers.
    pub fn new(camera: &'a [f64], light: &'a [f64], technique: &'a [f64]) -> Self {
        Self {
            data: [camera, light, technique],
            cursor: Cursor::default(),
            exhausted: false,
        }
    }

    /// Whether any read went past the end of its vector (it then read 0.5).
    pub fn exhausted(&self) -> bool {
        self.exhausted
    }
}

impl SampleStream for ReplayStream<'_> {
    fn start_stream(&mut self, index: usize) {
        self.cursor.start(index);
    }
    fn next_1d(&mut self) -> f64 {
        let (stream, i) = self.cursor.advance();
        match self.data[stream].get(i) {
            Some(&v) => v,
            None => {
                self.exhausted = true;
                0.5
            }
        }
    }
    fn seek(&mut self, index: usize) {
        self.cursor.seek(index);
    }
    fn position(&self) -> usize {
        self.cursor.position()
    }
}

/// A stream that can also be written: inverses put the numbers of a path back where the walk
/// would read them.
pub trait WritableStream: SampleStream {
    /// Write `v` at the current position of the current substream and advance.
    fn put(&mut self, v: f64);
    /// Write two numbers.
    fn put_2d(&mut self, v: [f64; 2]) {
        self.put(v[0]);
        self.put(v[1]);
    }
}

/// Readable and writable vectors, one per substream (the technique substream is empty): the
/// primary numbers of a technique chart, camera numbers then light numbers. Writing or reading
/// past the end of a vector marks the stream as overflowed ([`SliceStream::overflowed`]).
#[derive(Debug)]
pub struct SliceStream<'a> {
    data: [&'a mut [f64]; 2],
    cursor: Cursor,
    overflowed: bool,
}

impl<'a> SliceStream<'a> {
    /// Read and write `camera` and `light` numbers.
    pub fn new(camera: &'a mut [f64], light: &'a mut [f64]) -> Self {
        Self {
            data: [camera, light],
            cursor: Cursor::default(),
            overflowed: false,
        }
    }

    /// Whether a read or write fell outside its vector.
    pub fn overflowed(&self) -> bool {
        self.overflowed
    }

    fn slot(&mut self) -> Option<&mut f64> {
        let (stream, i) = self.cursor.advance();
        let slot = self.data.get_mut(stream).and_then(|d| d.get_mut(i));
        if slot.is_none() {
            self.overflowed = true;
        }
        slot
    }
}

impl SampleStream for SliceStream<'_> {
    fn start_stream(&mut self, index: usize) {
        self.cursor.start(index);
    }
    fn next_1d(&mut self) -> f64 {
        self.slot().map_or(0.5, |v| *v)
    }
    fn seek(&mut self, index: usize) {
        self.cursor.seek(index);
    }
    fn position(&self) -> usize {
        self.cursor.position()
    }
}

impl WritableStream for SliceStream<'_> {
    fn put(&mut self, v: f64) {
        if let Some(slot) = self.slot() {
            *slot = v;
        }
    }
}

/// Wraps a stream and records every number read, by substream and position (positions that were
/// skipped hold NaN).
#[derive(Clone, Debug)]
pub struct Recorder<S> {
    /// The wrapped stream.
    pub inner: S,
    /// What was read, per substream.
    pub recorded: [Vec<f64>; STREAMS],
    current: usize,
}

impl<S: SampleStream> Recorder<S> {
    /// Record what `inner` produces.
    pub fn new(inner: S) -> Self {
        Self {
            inner,
            recorded: Default::default(),
            current: 0,
        }
    }
}

impl<S: SampleStream> SampleStream for Recorder<S> {
    fn start_stream(&mut self, index: usize) {
        self.current = index;
        self.inner.start_stream(index);
    }
    fn next_1d(&mut self) -> f64 {
        let i = self.inner.position();
        let v = self.inner.next_1d();
        let r = &mut self.recorded[self.current];
        if r.len() <= i {
            r.resize(i + 1, f64::NAN);
        }
        r[i] = v;
        v
    }
    fn seek(&mut self, index: usize) {
        self.inner.seek(index)
    }
    fn position(&self) -> usize {
        self.inner.position()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mcmc_core::rng::stream;

    #[test]
    fn replaying_a_recording_reproduces_the_numbers() {
        let mut rec = Recorder::new(IndependentStream::new(stream(1, 0)));
        let mut read = Vec::new();
        for s in [CAMERA_STREAM, LIGHT_STREAM, CAMERA_STREAM] {
            rec.start_stream(s);
            read.push(rec.next_1d());
            read.push(rec.next_1d());
        }
        let [c, l, t] = &rec.recorded;
        let mut replay = ReplayStream::new(c, l, t);
        let mut again = Vec::new();
        for s in [CAMERA_STREAM, LIGHT_STREAM, CAMERA_STREAM] {
            replay.start_stream(s);
            again.push(replay.next_1d());
            again.push(replay.next_1d());
        }
        assert_eq!(read, again);
        assert!(!replay.exhausted());
        replay.next_1d();
        assert!(replay.exhausted());
    }

    #[test]
    fn numbers_put_in_the_layout_are_read_back_there() {
        let (mut cam, mut light) = (vec![0.0; layout::camera_numbers(4)], vec![0.0; 5]);
        let mut w = SliceStream::new(&mut cam, &mut light);
        w.start_stream(CAMERA_STREAM);
        w.seek(layout::camera_vertex(2) + layout::DIRECTION);
        w.put_2d([0.25, 0.75]);
        w.start_stream(LIGHT_STREAM);
        w.seek(layout::LIGHT_DIRECTION);
        w.put(0.5);
        assert!(!w.overflowed());
        w.put_2d([0.1, 0.2]);
        assert!(w.overflowed(), "the light block has 5 numbers");
        assert_eq!(cam[CAMERA_BLOCK + VERTEX_BLOCK + 1..][..2], [0.25, 0.75]);
        let mut r = ReplayStream::new(&cam, &light, &[]);
        r.seek(layout::camera_vertex(2));
        assert_eq!(r.next_1d(), 0.0);
        assert_eq!(r.next_2d(), [0.25, 0.75]);
    }

    #[test]
    fn seek_keeps_blocks_aligned() {
        let v: Vec<f64> = (0..12).map(|i| i as f64 / 12.0).collect();
        let mut r = ReplayStream::new(&v, &[], &[]);
        r.next_1d();
        r.seek(VERTEX_BLOCK);
        assert_eq!(r.next_1d(), v[4]);
    }
}
