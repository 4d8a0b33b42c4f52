//! Unbiased integrators — path tracing, light tracing, bidirectional path tracing — and the
//! deterministic pass-based driver they share.
//!
//! A render is a sequence of *passes*; each pass takes one sample per pixel (for light tracing: one
//! light path per pixel). The pixels of a pass are split into fixed chunks processed in parallel;
//! every sample draws from its own stream (`seed`, pass, pixel), and chunk results are merged in
//! chunk order, so images are bit-identical whatever the number of threads.

mod bdpt;
mod lt;
mod pt;

pub use bdpt::Bdpt;
pub use lt::LightTracer;
pub use pt::PathTracer;

use crate::film::Film;
use crate::sampler::IndependentStream;
use crate::scene::Scene;
use crate::spectrum::Rgb;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// A splat: raster position and value.
pub type Splat = ([f64; 2], Rgb);

/// One sample of an unbiased estimator.
pub trait Estimator: Sync {
    /// Estimate for the sample of `pixel` (its own pixel's value), splatting light-side
    /// contributions into `splats`.
    fn sample(
        &self,
        scene: &Scene,
        pixel: usize,
        stream: &mut IndependentStream,
        splats: &mut Vec<Splat>,
    ) -> Rgb;
    /// Whether `sample`'s return value is a pixel estimate (false for light tracing, which only
    /// splats).
    fn has_pixel_estimate(&self) -> bool {
        true
    }
    /// Whether splats are made (they are normalised by the number of passes).
    fn splats(&self) -> bool;
}

/// How long to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// A number of samples per pixel.
    SamplesPerPixel(u64),
    /// Wall-clock time (whole passes; at least one).
    Time(Duration),
}

/// Progress after each pass.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    /// Passes done.
    pub passes: u64,
    /// Passes planned (None for time budgets).
    pub planned: Option<u64>,
    /// Elapsed time.
    pub elapsed: Duration,
    /// Rays traced so far.
    pub rays: u64,
}

/// Statistics of a finished render.
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderStats {
    /// Passes (= samples per pixel).
    pub passes: u64,
    /// Samples taken.
    pub samples: u64,
    /// Rays traced.
    pub rays: u64,
    /// Wall-clock time.
    pub elapsed: Duration,
    /// Samples discarded as non-finite.
    pub discarded: u64,
}

const CHUNKS: usize = 64;

/// What a chunk of a pass produces: pixel estimates, splats, rays traced.
type ChunkResult = (Vec<(usize, Rgb)>, Vec<Splat>, u64);
const PASS_PURPOSE: u64 = 0x5eed_0001;

/// Render `estimator` into a film within `budget`; `progress` is called after every pass and may
/// stop the render early by returning `false`.
pub fn render<E: Estimator>(
    scene: &Scene,
    estimator: &E,
    budget: Budget,
    seed: u64,
    mut progress: impl FnMut(&Film, Progress) -> bool,
) -> (Film, RenderStats) {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let npix = w * h;
    let mut film = Film::new(w, h);
    let start = Instant::now();
    let mut stats = RenderStats::default();
    let planned = match budget {
        Budget::SamplesPerPixel(n) => Some(n.max(1)),
        Budget::Time(_) => None,
    };
    let chunk = npix.div_ceil(CHUNKS);
    loop {
        let pass = stats.passes;
        let results: Vec<ChunkResult> = (0..CHUNKS)
            .into_par_iter()
            .map(|c| {
                crate::accel::take_ray_count();
                let lo = (c * chunk).min(npix);
                let hi = ((c + 1) * chunk).min(npix);
                let mut samples = Vec::with_capacity(hi - lo);
                let mut splats = Vec::new();
                for pixel in lo..hi {
                    let mut stream = IndependentStream::new(mcmc_core::rng::substream(
                        seed ^ pass.wrapping_mul(0x9E37_79B9_7F4A_7C15),
                        PASS_PURPOSE,
                        pixel as u64,
                    ));
                    let v = estimator.sample(scene, pixel, &mut stream, &mut splats);
                    samples.push((pixel, v));
                }
                (samples, splats, crate::accel::take_ray_count())
            })
            .collect();
        for (samples, splats, rays) in results {
            if estimator.has_pixel_estimate() {
                for (p, v) in samples {
                    film.add_sample(p, v);
                }
            }
            for (r, v) in splats {
                film.add_splat(r, v);
            }
            stats.rays += rays;
        }
        if estimator.splats() {
            film.splat_scale += 1.0;
        }
        stats.passes += 1;
        stats.samples += npix as u64;
        let elapsed = start.elapsed();
        let go_on = progress(
            &film,
            Progress {
                passes: stats.passes,
                planned,
                elapsed,
                rays: stats.rays,
            },
        );
        let done = match budget {
            Budget::SamplesPerPixel(n) => stats.passes >= n.max(1),
            Budget::Time(t) => elapsed >= t,
        };
        if done || !go_on {
            break;
        }
    }
    stats.elapsed = start.elapsed();
    stats.discarded = film.discarded;
    (film, stats)
}

/// Film `[0,1)²` position of a sample in `pixel`: uniform within the pixel.
#[inline]
pub fn film_position(scene: &Scene, pixel: usize, jitter: [f64; 2]) -> [f64; 2] {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let (x, y) = (pixel % w, pixel / w);
    [
        crate::math::clamp_unit((x as f64 + jitter[0]) / w as f64),
        crate::math::clamp_unit((y as f64 + jitter[1]) / h as f64),
    ]
}
