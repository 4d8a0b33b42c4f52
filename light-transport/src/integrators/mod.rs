//! Unbiased integrators — path tracing, light tracing, bidirectional path tracing — and the
//! deterministic pass-based driver they share.
//!
//! A render is a sequence of *passes*; each pass takes one sample per pixel (for light tracing: one
//! light path per pixel). The pixels of a pass are split into fixed chunks processed in parallel;
//! every sample draws from its own stream (`seed`, pass, pixel), and chunk results are merged in
//! chunk order, so images are bit-identical whatever the number of threads.
//!
//! Time budgets end with a *fractional pass* instead of overshooting by up to a whole pass: when
//! the time left is a fraction `q < 1` of the last pass's duration, every pixel takes part in the
//! last pass independently with probability `q` (its own stream decides), and the splats of that
//! pass count as `q` of a pass. Pixel estimates stay unbiased (each pixel averages however many
//! samples it got), and so do splat images: the expected splat sum of the last pass is `q` times a
//! full pass's, and the splat normalisation grows by exactly `q`.

mod bdpt;
pub mod direct;
mod lt;
mod pt;
pub mod shadow_roulette;

pub use bdpt::Bdpt;
pub use lt::LightTracer;
pub use pt::PathTracer;
pub use shadow_roulette::{ShadowRoulette, mean_luminance};

pub use crate::budget::Budget;
pub use crate::film::Splat;

use crate::film::Film;
use crate::sampler::IndependentStream;
use crate::scene::Scene;
use crate::spectrum::Rgb;
use mcmc_core::rng::uniform;
use rayon::prelude::*;
use std::time::{Duration, Instant};

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
    /// Passes started (the last one may have been fractional).
    pub passes: u64,
    /// Passes' worth of samples: `passes`, or `passes − 1 + q` after a fractional last pass (the
    /// weight of this render when shards are merged).
    pub samples_per_pixel: f64,
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
const FRACTION_PURPOSE: u64 = 0x5eed_0002;

/// Render `estimator` into a film within `budget`; `progress` is called after every pass and may
/// stop the render early by returning `false`.
pub fn render<E: Estimator>(
    scene: &Scene,
    estimator: &E,
    budget: Budget,
    seed: u64,
    mut progress: impl FnMut(&Film, Progress) -> bool,
) -> (Film, RenderStats) {
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    let start = Instant::now();
    let mut stats = RenderStats::default();
    let planned = match budget {
        Budget::SamplesPerPixel(n) => Some((n.ceil() as u64).max(1)),
        Budget::Time(_) => None,
    };
    let mut last_pass: Option<Duration> = None;
    loop {
        // The share of the pixels this pass samples: 1, or the fraction of a pass the time left
        // allows when less than a whole pass remains.
        let q = match (budget, last_pass) {
            (Budget::Time(t), Some(d)) if !d.is_zero() => {
                (t.saturating_sub(start.elapsed()).as_secs_f64() / d.as_secs_f64()).min(1.0)
            }
            // A fractional sample count ends with the fraction of a pass it asks for.
            (Budget::SamplesPerPixel(n), _) => (n - stats.passes as f64).clamp(0.0, 1.0),
            _ => 1.0,
        };
        let pass_start = Instant::now();
        let taken = pass(
            scene,
            estimator,
            seed,
            stats.passes,
            q,
            &mut film,
            &mut stats.rays,
        );
        stats.passes += 1;
        stats.samples += taken;
        stats.samples_per_pixel += q;
        last_pass = Some(pass_start.elapsed());
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
            Budget::SamplesPerPixel(_) => planned.is_some_and(|p| stats.passes >= p),
            Budget::Time(t) => q < 1.0 || elapsed >= t,
        };
        if done || !go_on {
            break;
        }
    }
    stats.elapsed = start.elapsed();
    stats.discarded = film.discarded;
    (film, stats)
}

/// One pass of `estimator` into `film`: every pixel with probability `q` (all of them when
/// `q ≥ 1`), its splats counted as `q` of a pass (see the module docs). Returns the samples taken
/// and adds the rays traced to `rays`. Deterministic in `(seed, pass)`, whatever the thread count.
pub fn pass<E: Estimator>(
    scene: &Scene,
    estimator: &E,
    seed: u64,
    pass: u64,
    q: f64,
    film: &mut Film,
    rays: &mut u64,
) -> u64 {
    let npix = scene.camera.width * scene.camera.height;
    let chunk = npix.div_ceil(CHUNKS);
    let q = q.clamp(0.0, 1.0);
    let key = seed ^ pass.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    let results: Vec<ChunkResult> = (0..CHUNKS)
        .into_par_iter()
        .map(|c| {
            crate::accel::take_ray_count();
            let lo = (c * chunk).min(npix);
            let hi = ((c + 1) * chunk).min(npix);
            let mut samples = Vec::with_capacity(hi - lo);
            let mut splats = Vec::new();
            for pixel in lo..hi {
                if q < 1.0
                    && uniform(&mut mcmc_core::rng::substream(
                        key,
                        FRACTION_PURPOSE,
                        pixel as u64,
                    )) >= q
                {
                    continue;
                }
                let mut stream = IndependentStream::new(mcmc_core::rng::substream(
                    key,
                    PASS_PURPOSE,
                    pixel as u64,
                ));
                let v = estimator.sample(scene, pixel, &mut stream, &mut splats);
                samples.push((pixel, v));
            }
            (samples, splats, crate::accel::take_ray_count())
        })
        .collect();
    let mut taken = 0;
    for (samples, splats, r) in results {
        taken += samples.len() as u64;
        if estimator.has_pixel_estimate() {
            for (p, v) in samples {
                film.add_sample(p, v);
            }
        }
        for (r, v) in splats {
            film.add_splat(r, v);
        }
        *rays += r;
    }
    if estimator.splats() {
        film.splat_scale += q;
    }
    taken
}
