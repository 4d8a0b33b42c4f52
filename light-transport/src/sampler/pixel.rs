//! The stream of one sample of a pass-based estimator (path tracing, light tracing, BDPT and the
//! other estimators the pass driver runs): fresh independent numbers, or a randomised
//! low-discrepancy sequence per pixel — Owen-scrambled Sobol points (Sobol 1967; direction numbers
//! of Joe & Kuo 2008; nested uniform scrambling, Owen 1995, in the hash-based form of Burley 2020,
//! from the `sobol_burley` crate).
//!
//! # The low-discrepancy stream
//!
//! Pixel `p` of a render with seed `σ` owns one scrambled sequence; its `i`-th pass takes the
//! sequence's `i`-th point. The numbers of a sample are grouped into four-dimensional *sets*,
//! each the first four dimensions of a Sobol sequence scrambled and shuffled by its own seed
//! (Burley's *padding*): sets are randomly associated with each other, and within a set the
//! points of the passes are stratified in every dimension and in the pairs `(0, 1)` and
//! `(2, 3)`, which form `(0, m, 2)`-nets (the first `2^m` passes put exactly one point in each
//! of `2^m` equal rectangles, of any shape; every single dimension is stratified likewise).
//! The sets follow the sample layout ([`crate::sampler`]) so that every pair of numbers that
//! makes one two-dimensional choice takes lanes 0 and 1 of a set:
//!
//! | substream | set | lanes 0, 1 | lane 2 | lane 3 |
//! |---|---|---|---|---|
//! | camera | endpoint | film position | | |
//! | camera | endpoint, second set | lens position | | |
//! | light | endpoint | position on the light | light choice | |
//! | light | endpoint, second set | emitted direction | | |
//! | camera, light | each scattering vertex | direction | lobe choice | Russian roulette |
//! | technique | every three numbers (a next-event choice) | light position | light choice | |
//!
//! Every point of an Owen-scrambled sequence is uniform on the unit cube, so every estimator
//! stays unbiased; the variance falls where the integrand is smooth in the stratified
//! dimensions (measured in the README). The sequence has `2^16` points: passes beyond
//! that read independent numbers. The crate's numbers have 23 bits; the stream fills the
//! remaining 30 of an `f64`'s 53 with random bits, which keeps each number uniform and every
//! stratum as it was.

use super::{
    CAMERA_BLOCK, CAMERA_STREAM, LIGHT_BLOCK, LIGHT_STREAM, STREAMS, SampleStream, VERTEX_BLOCK,
};
use mcmc_core::ChainRng;
use mcmc_core::rng::uniform;
use rand::Rng;

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

/// Passes with a low-discrepancy point: the length of the crate's sequences.
pub const SOBOL_PASSES: u64 = 1 << 16;

/// Scattering vertices of each subpath (and next-event choices) that read Sobol numbers; deeper
/// ones read independent numbers. Measured on `cornell` and `door` (BDPT, 16 spp, MSE between
/// seeds): Sobol at every vertex, or from the endpoints to the third vertex, the second or the
/// first, all gave the same MSE (within 4%, 0.42× and 0.72× that of independent numbers), and
/// every vertex's set costs about 33 ns (BDPT ran 3% slower with Sobol at every vertex).
pub const SOBOL_VERTICES: usize = 2;

/// The numbers of one sample of one pixel in one pass ([`PixelStream::new`]).
#[derive(Clone, Debug)]
pub struct PixelStream {
    /// Independent numbers: the whole stream for [`PixelSampler::Independent`], the low bits of
    /// the Sobol numbers, and the estimator's own random choices (shadow-ray roulette, the
    /// photon mapper's final gather).
    pub rng: ChainRng,
    current: usize,
    pos: [usize; STREAMS],
    sobol: Option<SobolPoint>,
}

/// A pixel's point of the current pass, computed a set at a time.
#[derive(Clone, Debug)]
struct SobolPoint {
    pass: u32,
    pixel_seed: u32,
    /// The last set computed in each substream and its four numbers, as 23-bit integers.
    cache: [(u32, [u32; 4]); STREAMS],
}

/// No set computed yet.
const NO_SET: u32 = u32::MAX;
/// The set of the second pair of an endpoint block (the camera's lens position, the light's
/// emitted direction); vertex sets are numbered from 1.
const ENDPOINT_PAIR_SET: u32 = u32::MAX - 1;
/// Lane of each vertex-block number (lobe, direction, direction, roulette): the direction takes
/// the net-forming pair.
const VERTEX_LANES: [usize; VERTEX_BLOCK] = [2, 0, 1, 3];
/// Numbers of a next-event choice in the technique substream (light choice, light position).
const NEXT_EVENT_BLOCK: usize = 3;

/// The set and lane of position `p` of substream `stream` (module docs); `None` past the
/// first [`SOBOL_VERTICES`] scattering vertices or next-event choices.
fn set_of(stream: usize, p: usize) -> Option<(u32, usize)> {
    let vertex = |q: usize| {
        let b = q / VERTEX_BLOCK;
        (b < SOBOL_VERTICES).then(|| ((1 + b) as u32, VERTEX_LANES[q % VERTEX_BLOCK]))
    };
    match stream {
        // Film position, then lens position.
        CAMERA_STREAM if p < 2 => Some((0, p)),
        CAMERA_STREAM if p < CAMERA_BLOCK => Some((ENDPOINT_PAIR_SET, p - 2)),
        CAMERA_STREAM => vertex(p - CAMERA_BLOCK),
        // Light choice, position on the light, then emitted direction.
        LIGHT_STREAM if p == 0 => Some((0, 2)),
        LIGHT_STREAM if p < 3 => Some((0, p - 1)),
        LIGHT_STREAM if p < LIGHT_BLOCK => Some((ENDPOINT_PAIR_SET, p - 3)),
        LIGHT_STREAM => vertex(p - LIGHT_BLOCK),
        _ => {
            let b = p / NEXT_EVENT_BLOCK;
            (b < SOBOL_VERTICES).then(|| (b as u32, [2, 0, 1][p % NEXT_EVENT_BLOCK]))
        }
    }
}

/// A 32-bit avalanche hash (Wellons' `lowbias32`).
fn mix(mut z: u32) -> u32 {
    z ^= z >> 16;
    z = z.wrapping_mul(0x7feb_352d);
    z ^= z >> 15;
    z = z.wrapping_mul(0x846c_a68b);
    z ^ (z >> 16)
}

/// A 32-bit seed from a 64-bit key (SplitMix64's finaliser, folded).
fn fold(key: u64) -> u32 {
    let mut z = key;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z ^ (z >> 32)) as u32
}

impl SobolPoint {
    /// The four numbers of `set` in substream `stream`, as 23-bit integers.
    fn set(&mut self, stream: usize, set: u32) -> &[u32; 4] {
        let (cached, values) = &mut self.cache[stream];
        if *cached != set {
            let seed = mix(self.pixel_seed ^ mix(set ^ mix(stream as u32 + 1)));
            let v = sobol_burley::sample_4d(self.pass, 0, seed);
            // The crate's floats are exact multiples of 2^-23.
            *values = v.map(|x| (x * (1u32 << 23) as f32) as u32);
            *cached = set;
        }
        values
    }
}

impl PixelStream {
    /// The stream of `pixel`'s sample in pass `pass` of a render with seed `seed`: `rng` (the
    /// pass driver's per-pixel generator) alone for [`PixelSampler::Independent`] and for passes
    /// beyond [`SOBOL_PASSES`], else the pixel's scrambled Sobol point of that pass.
    pub fn new(sampler: PixelSampler, seed: u64, pass: u64, pixel: usize, rng: ChainRng) -> Self {
        let sobol = (sampler == PixelSampler::Sobol && pass < SOBOL_PASSES).then(|| SobolPoint {
            pass: pass as u32,
            pixel_seed: fold(seed ^ (pixel as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)),
            cache: [(NO_SET, [0; 4]); STREAMS],
        });
        Self {
            rng,
            current: 0,
            pos: [0; STREAMS],
            sobol,
        }
    }

    /// Independent numbers from `rng` (for estimators run outside the pass driver).
    pub fn independent(rng: ChainRng) -> Self {
        Self::new(PixelSampler::Independent, 0, 0, 0, rng)
    }
}

impl SampleStream for PixelStream {
    fn start_stream(&mut self, index: usize) {
        self.current = index;
    }
    fn next_1d(&mut self) -> f64 {
        let p = self.pos[self.current];
        self.pos[self.current] += 1;
        let Some(point) = &mut self.sobol else {
            return uniform(&mut self.rng);
        };
        let Some((set, lane)) = set_of(self.current, p) else {
            return uniform(&mut self.rng);
        };
        let high = point.set(self.current, set)[lane] as u64;
        // 23 bits of the point and 30 random ones: exactly representable, below 1.
        let low = self.rng.next_u64() >> 34;
        ((high << 30) | low) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    fn seek(&mut self, index: usize) {
        self.pos[self.current] = index;
    }
    fn position(&self) -> usize {
        self.pos[self.current]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::{TECHNIQUE_STREAM, layout};
    use mcmc_core::rng::stream;

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
                        assert!(p < sobol && lane < 4, "stream {s} position {p}");
                        assert!(seen.insert((set, lane)), "stream {s} position {p}");
                    }
                    None => assert!(p >= sobol, "stream {s} position {p}"),
                }
            }
            assert_eq!(seen.len(), sobol, "stream {s}");
        }
        let at = |s, p| set_of(s, p).unwrap();
        assert_eq!(at(CAMERA_STREAM, layout::FILM), (0, 0));
        assert_eq!(at(CAMERA_STREAM, layout::LENS + 1), (ENDPOINT_PAIR_SET, 1));
        let direction = layout::camera_vertex(1) + layout::DIRECTION;
        assert_eq!(at(CAMERA_STREAM, direction), (1, 0));
        let roulette = layout::light_vertex(2) + layout::ROULETTE;
        assert_eq!(at(LIGHT_STREAM, roulette), (2, 3));
        assert_eq!(at(LIGHT_STREAM, layout::LIGHT_CHOICE), (0, 2));
        assert_eq!(at(LIGHT_STREAM, layout::LIGHT_POSITION), (0, 0));
        assert_eq!(
            at(LIGHT_STREAM, layout::LIGHT_DIRECTION + 1),
            (ENDPOINT_PAIR_SET, 1)
        );
    }

    /// The film positions of a pixel's first 2^m passes form a (0, m, 2)-net: one point in each
    /// of the 2^m rectangles of every shape 2^a × 2^(m−a). Independent numbers fail this (a
    /// test of the test).
    #[test]
    fn a_pixels_passes_stratify_its_film_position() {
        let film = |sampler, pass, pixel| {
            let mut s = PixelStream::new(sampler, 7, pass, pixel, stream(7, pass));
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
                    let mut s = PixelStream::new(PixelSampler::Sobol, 3, i, 11, stream(3, i));
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
                    stream(9, k as u64),
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
                    stream(5, k as u64),
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
            let mut s = PixelStream::new(sampler, 1, pass, 5, stream(1, 2));
            let mut rng = stream(1, 2);
            for _ in 0..10 {
                assert_eq!(s.next_1d(), uniform(&mut rng));
            }
        }
    }
}
