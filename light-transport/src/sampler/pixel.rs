//! The stream of one sample of a pass-based estimator (path tracing, light tracing, BDPT and the
//! other estimators the pass driver runs): fresh independent numbers, or a randomised
//! low-discrepancy sequence per pixel: Owen-scrambled Sobol points (Sobol 1967; nested uniform
//! scrambling, Owen 1995, in the hash-based form of Burley 2020).
//!
//! # The low-discrepancy stream
//!
//! Pixel `p` of a render with seed `σ` owns one scrambled sequence of each *set* of numbers; its
//! `i`-th pass takes the sequences' `i`-th points. A set is two numbers: the first two dimensions
//! of Sobol's sequence, shuffled and Owen-scrambled by the set's own seed ([`super::sobol`];
//! Burley's *padding*), so that sets are randomly associated with each other while within a set
//! the passes' points form `(0, m, 2)`-nets (the first `2^m` passes put exactly one point in each
//! of `2^m` equal rectangles of any shape; each number alone is stratified likewise). The sets
//! follow the sample layout ([`crate::sampler`]), every two-dimensional choice a set of its own:
//!
//! | substream | sets |
//! |---|---|
//! | camera | film position; lens position; per scattering vertex: direction, (lobe choice, roulette) |
//! | light | position on the light; emitted direction; light choice; per scattering vertex: direction, (lobe choice, roulette) |
//! | technique | per next-event choice (three numbers): light position, light choice |
//!
//! Only the endpoints and the first [`SOBOL_VERTICES`] scattering vertices of each subpath (and
//! next-event choices) read Sobol numbers; deeper vertices read independent ones, which changed
//! nothing measurable (below).
//!
//! Every point of an Owen-scrambled sequence is uniform, so every estimator stays unbiased; the
//! variance falls where the integrand is smooth in the stratified dimensions (measured in the
//! README). The sequences have `2^16` points: passes beyond that read independent numbers. A
//! number takes the scrambled point's 32 bits and 21 random ones, which keeps it uniform and
//! every stratum as it was.

use super::sobol::Point;
use super::{
    CAMERA_BLOCK, CAMERA_STREAM, IndependentStream, LIGHT_BLOCK, LIGHT_STREAM, STREAMS,
    SampleStream, VERTEX_BLOCK,
};
use mcmc_core::ChainRng;
use mcmc_core::rng::{FastRng, uniform};
use rand::{Rng, SeedableRng};

/// How the pass-based estimators draw the numbers of a sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PixelSampler {
    /// Fresh independent numbers for every sample.
    Independent,
    /// An Owen-scrambled Sobol sequence per pixel, one point per pass (module docs).
    #[default]
    Sobol,
}

impl std::fmt::Display for PixelSampler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            PixelSampler::Independent => "independent",
            PixelSampler::Sobol => "sobol",
        })
    }
}

/// Passes with a low-discrepancy point: the length of the sequences.
pub const SOBOL_PASSES: u64 = super::sobol::POINTS;

/// Scattering vertices of each subpath (and next-event choices) that read Sobol numbers; deeper
/// ones read independent numbers. Measured on `cornell` and `door` (BDPT, 16 spp, MSE between
/// seeds): Sobol numbers at every vertex, or from the endpoints to the third vertex, the second
/// or the first, all gave the same MSE (within 4%; 0.42× and 0.72× that of independent numbers),
/// while each set costs about 10 ns, which path tracing on the cheap built-ins notices.
pub const SOBOL_VERTICES: usize = 1;

/// The numbers of one sample of one pixel in one pass ([`PixelStream::new`]).
#[derive(Clone, Debug)]
pub struct PixelStream {
    /// Independent numbers and the positions of the substreams: the whole stream for
    /// [`PixelSampler::Independent`], the low bits of the Sobol numbers, and the estimator's own
    /// random choices ([`PixelStream::rng`]).
    independent: IndependentStream<FastRng>,
    sobol: Option<SobolPoint>,
}

/// A pixel's points of the current pass, computed a set at a time.
#[derive(Clone, Debug)]
struct SobolPoint {
    /// The pass, its bits reversed.
    pass_reversed: u32,
    pixel_seed: u32,
    /// Each substream's sets, computed when first read.
    sets: [[Option<Point>; MAX_SETS]; STREAMS],
}

/// Sets of each substream (those [`set_of`] places).
#[cfg(test)]
const SETS: [usize; STREAMS] = [
    2 + 2 * SOBOL_VERTICES,
    3 + 2 * SOBOL_VERTICES,
    2 * SOBOL_VERTICES,
];
/// The most sets of any substream.
const MAX_SETS: usize = 3 + 2 * SOBOL_VERTICES;

/// Positions of each substream that read Sobol numbers (camera, light, technique): those
/// [`set_of`] places.
const SOBOL_POSITIONS: [usize; STREAMS] = [
    CAMERA_BLOCK + VERTEX_BLOCK * SOBOL_VERTICES,
    LIGHT_BLOCK + VERTEX_BLOCK * SOBOL_VERTICES,
    NEXT_EVENT_BLOCK * SOBOL_VERTICES,
];

/// Numbers of a next-event choice in the technique substream (light choice, light position).
const NEXT_EVENT_BLOCK: usize = 3;

/// The set and lane of position `p` of substream `stream` (module docs); `None` past the first
/// [`SOBOL_VERTICES`] scattering vertices or next-event choices.
fn set_of(stream: usize, p: usize) -> Option<(u32, usize)> {
    // The sets of a vertex block (lobe, direction, direction, roulette), the first being `first`.
    let vertex = |first: usize, q: usize| {
        let b = q / VERTEX_BLOCK;
        let (set, lane) = [(1, 0), (0, 0), (0, 1), (1, 1)][q % VERTEX_BLOCK];
        (b < SOBOL_VERTICES).then_some(((first + 2 * b + set) as u32, lane))
    };
    match stream {
        // Film position, lens position.
        CAMERA_STREAM if p < CAMERA_BLOCK => Some(((p / 2) as u32, p % 2)),
        CAMERA_STREAM => vertex(2, p - CAMERA_BLOCK),
        // Light choice, position on the light, emitted direction.
        LIGHT_STREAM if p == 0 => Some((2, 0)),
        LIGHT_STREAM if p < LIGHT_BLOCK => Some((((p - 1) / 2) as u32, (p - 1) % 2)),
        LIGHT_STREAM => vertex(3, p - LIGHT_BLOCK),
        // Light choice, light position.
        _ => {
            let b = p / NEXT_EVENT_BLOCK;
            let (set, lane) = [(1, 0), (0, 0), (0, 1)][p % NEXT_EVENT_BLOCK];
            (b < SOBOL_VERTICES).then_some(((2 * b + set) as u32, lane))
        }
    }
}

/// A 32-bit seed from a 64-bit key (SplitMix64's finaliser, folded).
fn fold(key: u64) -> u32 {
    let z = mcmc_core::rng::mix64(key);
    (z ^ (z >> 32)) as u32
}

impl SobolPoint {
    /// Number `lane` of `set` in substream `stream`, as a 32-bit fixed-point fraction. A set's
    /// seed is the pixel's plus a multiple of the golden ratio per set; the sequence hashes its
    /// seed before use, so these are as good as independent seeds (the crate's documentation,
    /// and the independence test below).
    fn number(&mut self, stream: usize, set: u32, lane: usize) -> u32 {
        let key = (stream as u32 * 256 + set + 1).wrapping_mul(0x9E37_79B9);
        let (pass, seed) = (self.pass_reversed, self.pixel_seed.wrapping_add(key));
        self.sets[stream][set as usize]
            .get_or_insert_with(|| Point::new(pass, seed))
            .coordinate(lane)
    }
}

impl PixelStream {
    /// The stream of `pixel`'s sample in pass `pass` of a render with seed `seed`: `rng` (the
    /// pass driver's per-pixel generator) alone for [`PixelSampler::Independent`] and for passes
    /// beyond [`SOBOL_PASSES`], else the pixel's scrambled Sobol point of that pass.
    pub fn new(sampler: PixelSampler, seed: u64, pass: u64, pixel: usize, rng: FastRng) -> Self {
        let sobol = (sampler == PixelSampler::Sobol && pass < SOBOL_PASSES).then(|| SobolPoint {
            pass_reversed: (pass as u32).reverse_bits(),
            pixel_seed: fold(seed ^ (pixel as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)),
            sets: [[None; MAX_SETS]; STREAMS],
        });
        Self {
            independent: IndependentStream::new(rng),
            sobol,
        }
    }

    /// The generator of the independent numbers, for the estimator's own random choices
    /// (shadow-ray roulette, the photon mapper's final gather).
    pub fn rng(&mut self) -> &mut FastRng {
        &mut self.independent.rng
    }

    /// A [`ChainRng`] keyed from this sample's generator, for an estimator that runs Metropolis
    /// chains from its sample (ERPT): the kernels draw from a `ChainRng`.
    pub fn chain_rng(&mut self) -> ChainRng {
        ChainRng::from_rng(&mut self.independent.rng)
    }

    /// The Sobol number at position `p` of the current substream (below its
    /// [`SOBOL_POSITIONS`]).
    #[inline(never)]
    fn sobol_number(&mut self, p: usize) -> f64 {
        let current = self.independent.current();
        let rng = &mut self.independent.rng;
        let (Some(point), Some((set, lane))) = (&mut self.sobol, set_of(current, p)) else {
            return uniform(rng);
        };
        let high = u64::from(point.number(current, set, lane));
        // 32 bits of the point and 21 random ones: exactly representable, below 1.
        let low = rng.next_u64() >> 43;
        ((high << 21) | low) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Independent numbers from `rng` (for estimators run outside the pass driver).
    pub fn independent(rng: FastRng) -> Self {
        Self::new(PixelSampler::Independent, 0, 0, 0, rng)
    }
}

impl SampleStream for PixelStream {
    fn start_stream(&mut self, index: usize) {
        self.independent.start_stream(index);
    }
    #[inline]
    fn next_1d(&mut self) -> f64 {
        let p = self.independent.position();
        // Most numbers lie past the Sobol positions: one comparison sends them to the generator.
        if self.sobol.is_some() && p < SOBOL_POSITIONS[self.independent.current()] {
            self.independent.seek(p + 1);
            self.sobol_number(p)
        } else {
            self.independent.next_1d()
        }
    }
    fn seek(&mut self, index: usize) {
        self.independent.seek(index);
    }
    fn position(&self) -> usize {
        self.independent.position()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::{TECHNIQUE_STREAM, layout};
    use mcmc_core::rng::fast_stream;

    /// Every position of the layout up to the Sobol depth has its own set and lane (no two
    /// numbers of a sample share one); the positions after it have none.
    #[test]
    fn positions_map_to_distinct_lanes() {
        for (s, sobol) in [
            (CAMERA_STREAM, layout::camera_vertex(SOBOL_VERTICES + 1)),
            (LIGHT_STREAM, layout::light_vertex(SOBOL_VERTICES + 1)),
            (TECHNIQUE_STREAM, NEXT_EVENT_BLOCK * SOBOL_VERTICES),
        ] {
            let mut seen = std::collections::HashSet::new();
            for p in 0..200 {
                match set_of(s, p) {
                    Some((set, lane)) => {
                        assert!(p < sobol && lane < 2, "stream {s} position {p}");
                        assert!(seen.insert((set, lane)), "stream {s} position {p}");
                    }
                    None => assert!(p >= sobol, "stream {s} position {p}"),
                }
            }
            assert_eq!(seen.len(), sobol, "stream {s}");
            assert_eq!(SOBOL_POSITIONS[s], sobol, "stream {s}");
            let sets: std::collections::HashSet<u32> = seen.iter().map(|&(set, _)| set).collect();
            assert_eq!(sets, (0..SETS[s] as u32).collect(), "stream {s}");
        }
        let at = |s, p| set_of(s, p).unwrap();
        assert_eq!(at(CAMERA_STREAM, layout::FILM), (0, 0));
        assert_eq!(at(CAMERA_STREAM, layout::LENS + 1), (1, 1));
        let vertex = |b, offset| layout::camera_vertex(b) + offset;
        assert_eq!(at(CAMERA_STREAM, vertex(1, layout::DIRECTION)), (2, 0));
        assert_eq!(at(CAMERA_STREAM, vertex(1, layout::LOBE)), (3, 0));
        assert_eq!(at(CAMERA_STREAM, vertex(1, layout::ROULETTE)), (3, 1));
        assert_eq!(at(LIGHT_STREAM, layout::LIGHT_CHOICE), (2, 0));
        assert_eq!(at(LIGHT_STREAM, layout::LIGHT_POSITION), (0, 0));
        assert_eq!(at(LIGHT_STREAM, layout::LIGHT_DIRECTION + 1), (1, 1));
        let vertex = |b, offset| layout::light_vertex(b) + offset;
        assert_eq!(at(LIGHT_STREAM, vertex(1, layout::DIRECTION + 1)), (3, 1));
        assert_eq!(at(LIGHT_STREAM, vertex(1, layout::ROULETTE)), (4, 1));
        assert_eq!(at(TECHNIQUE_STREAM, 1), (0, 0));
        assert_eq!(at(TECHNIQUE_STREAM, 0), (1, 0));
    }

    /// The film positions of a pixel's first 2^m passes form a (0, m, 2)-net: one point in each
    /// of the 2^m rectangles of every shape 2^a × 2^(m−a). Independent numbers fail this (a
    /// test of the test).
    #[test]
    fn a_pixels_passes_stratify_its_film_position() {
        let film = |sampler, pass, pixel| {
            let mut s = PixelStream::new(sampler, 7, pass, pixel, fast_stream(7, pass));
            s.start_stream(CAMERA_STREAM);
            s.next_2d()
        };
        let is_net = |points: &[[f64; 2]], m: u32| {
            (0..=m).all(|a| {
                let (nx, ny) = (1usize << a, 1usize << (m - a));
                let mut cells = vec![0; nx * ny];
                for p in points {
                    cells[(p[0] * nx as f64) as usize * ny + (p[1] * ny as f64) as usize] += 1;
                }
                cells.iter().all(|&c| c == 1)
            })
        };
        for pixel in [0, 1, 4097] {
            for m in [2, 4, 6, 8] {
                let points: Vec<_> = (0..1u64 << m)
                    .map(|i| film(PixelSampler::Sobol, i, pixel))
                    .collect();
                assert!(is_net(&points, m), "pixel {pixel}, 2^{m} passes");
                let random: Vec<_> = (0..1u64 << m)
                    .map(|i| film(PixelSampler::Independent, i, pixel))
                    .collect();
                assert!(!is_net(&random, m), "independent numbers are not a net");
            }
        }
        // The direction of a light vertex and the lens position, as well.
        let pairs = |stream_index, at| -> Vec<[f64; 2]> {
            (0..64)
                .map(|i| {
                    let mut s = PixelStream::new(PixelSampler::Sobol, 3, i, 11, fast_stream(3, i));
                    s.start_stream(stream_index);
                    s.seek(at);
                    s.next_2d()
                })
                .collect()
        };
        assert!(is_net(&pairs(CAMERA_STREAM, layout::LENS), 6));
        assert!(is_net(&pairs(LIGHT_STREAM, layout::LIGHT_POSITION), 6));
        assert!(is_net(&pairs(LIGHT_STREAM, layout::LIGHT_DIRECTION), 6));
        let light_direction = layout::light_vertex(SOBOL_VERTICES) + layout::DIRECTION;
        assert!(is_net(&pairs(LIGHT_STREAM, light_direction), 6));
        let next_event_position = NEXT_EVENT_BLOCK * (SOBOL_VERTICES - 1) + 1;
        assert!(is_net(&pairs(TECHNIQUE_STREAM, next_event_position), 6));
        // Single numbers: one in each of 64 intervals.
        let single = |stream_index, at| {
            let mut cells = [0; 64];
            for i in 0..64 {
                let mut s = PixelStream::new(PixelSampler::Sobol, 3, i, 11, fast_stream(3, i));
                s.start_stream(stream_index);
                s.seek(at);
                cells[(s.next_1d() * 64.0) as usize] += 1;
            }
            cells.iter().all(|&c| c == 1)
        };
        assert!(single(
            CAMERA_STREAM,
            layout::camera_vertex(1) + layout::LOBE
        ));
        assert!(single(
            LIGHT_STREAM,
            layout::light_vertex(1) + layout::ROULETTE
        ));
        assert!(single(LIGHT_STREAM, layout::LIGHT_CHOICE));
        assert!(single(TECHNIQUE_STREAM, 0));
    }

    /// Across pixels and seeds, every number is uniform on [0, 1): a chi-square test on 64 bins
    /// per position (α = 1e-6 each, 24 positions), and no number reaches 1.
    #[test]
    fn numbers_are_uniform_across_pixels() {
        let n = 20_000usize;
        for (s, p) in [(CAMERA_STREAM, 0), (CAMERA_STREAM, 6), (LIGHT_STREAM, 0)]
            .into_iter()
            .chain((1..8).map(|p| (LIGHT_STREAM, p)))
            .chain((0..14).map(|p| (TECHNIQUE_STREAM, p)))
        {
            let mut bins = [0usize; 64];
            for k in 0..n {
                let pass = (k % 5) as u64;
                let mut st = PixelStream::new(
                    PixelSampler::Sobol,
                    1 + (k % 3) as u64,
                    pass,
                    k,
                    fast_stream(9, k as u64),
                );
                st.start_stream(s);
                st.seek(p);
                let v = st.next_1d();
                assert!((0.0..1.0).contains(&v));
                bins[(v * 64.0) as usize] += 1;
            }
            let e = n as f64 / 64.0;
            let chi2: f64 = bins.iter().map(|&b| (b as f64 - e).powi(2) / e).sum();
            // The 1 − 1e-6 quantile of chi-square with 63 degrees of freedom is about 130.
            assert!(chi2 < 130.0, "stream {s} position {p}: chi2 {chi2}");
        }
    }

    /// A Sobol number is uniform below the point's 32 bits too: where it falls inside its cell of
    /// width 2^−32 (its random low bits) is uniform over 20 000 pixels, for both lanes of a set,
    /// by a chi-square test on 64 bins (α = 1e-6 per position, 4 positions). Low bits left at a
    /// constant fail it (a test of the test).
    #[test]
    fn the_bits_below_the_point_are_uniform() {
        let n = 20_000usize;
        // The 1 − 1e-6 quantile of chi-square with 63 degrees of freedom is about 130.
        let uniform_in_cells = |inside: &[f64]| {
            let mut bins = [0usize; 64];
            for &f in inside {
                bins[((f * 64.0) as usize).min(63)] += 1;
            }
            let e = inside.len() as f64 / 64.0;
            bins.iter()
                .map(|&b| (b as f64 - e).powi(2) / e)
                .sum::<f64>()
                < 130.0
        };
        for (s, p) in [
            (CAMERA_STREAM, layout::FILM),
            (CAMERA_STREAM, layout::FILM + 1),
            (LIGHT_STREAM, layout::LIGHT_CHOICE),
            (TECHNIQUE_STREAM, 2),
        ] {
            let inside: Vec<f64> = (0..n)
                .map(|k| {
                    let mut st = PixelStream::new(
                        PixelSampler::Sobol,
                        3,
                        (k % 9) as u64,
                        k,
                        fast_stream(3, k as u64),
                    );
                    st.start_stream(s);
                    st.seek(p);
                    (st.next_1d() * 2f64.powi(32)).fract()
                })
                .collect();
            assert!(uniform_in_cells(&inside), "stream {s} position {p}");
        }
        assert!(!uniform_in_cells(&vec![0.0; n]));
    }

    /// Numbers that share a set number and lane in different substreams (the film position and
    /// the position on the light; the first directions of the camera and light subpaths; the
    /// first next-event choice) are independent: their correlation over 20 000 pixels is within
    /// 4.5 standard errors of 0 (0.032). Sets seeded without their substream make them equal.
    #[test]
    fn substreams_are_independent() {
        let n = 20_000;
        let read = |s: &mut PixelStream, stream_index, p| {
            s.start_stream(stream_index);
            s.seek(p);
            s.next_1d()
        };
        let pairs = [
            (
                (CAMERA_STREAM, layout::FILM),
                (LIGHT_STREAM, layout::LIGHT_POSITION),
            ),
            ((CAMERA_STREAM, layout::FILM), (TECHNIQUE_STREAM, 1)),
            (
                (CAMERA_STREAM, layout::camera_vertex(1) + layout::DIRECTION),
                (LIGHT_STREAM, layout::light_vertex(1) + layout::DIRECTION),
            ),
        ];
        for ((sa, pa), (sb, pb)) in pairs {
            let (mut sab, mut sa2, mut sb2, mut ma, mut mb) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for k in 0..n {
                let mut s = PixelStream::new(
                    PixelSampler::Sobol,
                    5,
                    (k % 7) as u64,
                    k,
                    fast_stream(5, k as u64),
                );
                let (a, b) = (read(&mut s, sa, pa), read(&mut s, sb, pb));
                assert_ne!(a, b);
                (ma, mb) = (ma + a, mb + b);
                (sab, sa2, sb2) = (sab + a * b, sa2 + a * a, sb2 + b * b);
            }
            let nf = n as f64;
            let (ma, mb) = (ma / nf, mb / nf);
            let cov = sab / nf - ma * mb;
            let r = cov / ((sa2 / nf - ma * ma) * (sb2 / nf - mb * mb)).sqrt();
            assert!(
                r.abs() < 4.5 / nf.sqrt(),
                "({sa}, {pa}) and ({sb}, {pb}): correlation {r}"
            );
        }
    }

    /// Passes beyond the sequence's length read independent numbers; the independent sampler
    /// reads exactly its generator's numbers.
    #[test]
    fn passes_beyond_the_sequence_and_independent_streams_read_the_generator() {
        for (sampler, pass) in [
            (PixelSampler::Sobol, SOBOL_PASSES),
            (PixelSampler::Independent, 3),
        ] {
            let mut s = PixelStream::new(sampler, 1, pass, 5, fast_stream(1, 2));
            let mut rng = fast_stream(1, 2);
            for _ in 0..10 {
                assert_eq!(s.next_1d(), uniform(&mut rng));
            }
        }
    }
}
