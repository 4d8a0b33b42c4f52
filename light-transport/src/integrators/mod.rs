//! Unbiased integrators — path tracing, light tracing, bidirectional path tracing — and the
//! deterministic pass-based driver they share.
//!
//! A render is a sequence of *passes*; each pass takes one sample per pixel (for light tracing: one
//! light path per pixel). The pixels of a pass are split into fixed chunks processed in parallel;
//! every sample draws from its own stream (`seed`, pass, pixel), and chunk results are merged in
//! chunk order, so images are bit-identical whatever the number of threads.
//!
//! Every sample draws its numbers from a [`PixelStream`]: independent numbers, or the pixel's
//! Owen-scrambled Sobol point of the pass ([`PixelSampler::Sobol`], the default), whose strata
//! lower the variance of pixel estimates where the integrand is smooth (measured in the README).
//!
//! Time budgets end with a *fractional pass* instead of overshooting by up to a whole pass: when
//! the time left is a fraction `q < 1` of the last pass's duration, every pixel takes part in the
//! last pass independently with probability `q` (its own stream decides), and the splats of that
//! pass count as `q` of a pass. Pixel estimates stay unbiased (each pixel averages however many
//! samples it got), and so do splat images: the expected splat sum of the last pass is `q` times a
//! full pass's, and the splat normalisation grows by exactly `q`.

mod bdpt;
pub mod direct;
mod direct_lighting;
mod lt;
mod pt;
pub mod shadow_roulette;

pub use bdpt::{Bdpt, Strategy};
pub use direct_lighting::DirectLighting;
pub use lt::LightTracer;
pub use pt::PathTracer;
pub use shadow_roulette::{ShadowRoulette, mean_luminance};

pub use crate::budget::Budget;
pub use crate::film::Splat;

use crate::film::Film;
use crate::sampler::{PixelSampler, PixelStream};
use crate::scene::Scene;
use crate::spectrum::Rgb;
use mcmc_core::rng::{FastSubstreams, uniform};
use std::time::{Duration, Instant};

/// One sample of an unbiased estimator.
pub trait Estimator: Sync {
    /// Estimate for the sample of `pixel` (its own pixel's value), splatting light-side
    /// contributions into `splats`.
    fn sample(
        &self,
        scene: &Scene,
        pixel: usize,
        stream: &mut PixelStream,
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

/// Where a render's numbers come from: its master seed and how a sample draws them. A bare seed
/// converts into the default sampler ([`PixelSampler::Sobol`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sampling {
    /// Master seed.
    pub seed: u64,
    /// How a sample draws its numbers.
    pub sampler: PixelSampler,
}

impl From<u64> for Sampling {
    fn from(seed: u64) -> Self {
        Self {
            seed,
            sampler: PixelSampler::default(),
        }
    }
}

const CHUNKS: usize = 64;

/// What a chunk of a pass produces: pixel estimates, splats, rays traced.
type ChunkResult = (Vec<(usize, Rgb)>, Vec<Splat>, u64);
const PASS_PURPOSE: u64 = 0x5eed_0001;
const FRACTION_PURPOSE: u64 = 0x5eed_0002;

/// Render `estimator` into a film within `budget`, its numbers drawn as `sampling` says (a seed,
/// or a seed and a [`PixelSampler`]); `progress` is called after every pass and may stop the
/// render early by returning `false`.
pub fn render<E: Estimator>(
    scene: &Scene,
    estimator: &E,
    budget: Budget,
    sampling: impl Into<Sampling>,
    mut progress: impl FnMut(&Film, Progress) -> bool,
) -> (Film, RenderStats) {
    let sampling = sampling.into();
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
            sampling,
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

/// The stream of `pixel`'s sample in pass `pass` of a render with `sampling`, exactly as [`pass`]
/// hands it to the estimator (so a tool can replay one sample of a render).
pub fn pass_stream(sampling: Sampling, pass: u64, pixel: usize) -> PixelStream {
    pass_streams(sampling, pass)(pixel)
}

/// The streams of pass `pass`'s pixels ([`pass_stream`]), their generators keyed once.
fn pass_streams(sampling: Sampling, pass: u64) -> impl Fn(usize) -> PixelStream {
    let generators = FastSubstreams::new(pass_key(sampling.seed, pass), PASS_PURPOSE);
    move |pixel| {
        let rng = generators.get(pixel as u64);
        PixelStream::new(sampling.sampler, sampling.seed, pass, pixel, rng)
    }
}

/// The key of pass `pass`'s per-pixel generators.
fn pass_key(seed: u64, pass: u64) -> u64 {
    seed ^ pass.wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// One pass of `estimator` into `film`: every pixel with probability `q` (all of them when
/// `q ≥ 1`), its splats counted as `q` of a pass (see the module docs). Returns the samples taken
/// and adds the rays traced to `rays`. Deterministic in `(sampling, pass)`, whatever the thread
/// count.
///
/// The pass is cut into `CHUNKS` runs of pixels, handed to the threads in order; each chunk's
/// estimates and splats enter the film in chunk order (so the film's sums do not depend on the
/// threads), as soon as every earlier chunk has. Only the chunks in flight, and those finished
/// ahead of a slower earlier one, hold their splats at a time: estimators that splat a lot
/// (ERPT's chains) would otherwise keep a whole pass of splats.
pub fn pass<E: Estimator>(
    scene: &Scene,
    estimator: &E,
    sampling: impl Into<Sampling>,
    pass: u64,
    q: f64,
    film: &mut Film,
    rays: &mut u64,
) -> u64 {
    let npix = scene.camera.width * scene.camera.height;
    let chunk = npix.div_ceil(CHUNKS);
    let q = q.clamp(0.0, 1.0);
    let sampling = sampling.into();
    let key = pass_key(sampling.seed, pass);
    let streams = pass_streams(sampling, pass);
    let fractions = FastSubstreams::new(key, FRACTION_PURPOSE);
    let run = |c: usize| -> ChunkResult {
        crate::accel::take_ray_count();
        let lo = (c * chunk).min(npix);
        let hi = ((c + 1) * chunk).min(npix);
        let mut samples = Vec::with_capacity(hi - lo);
        let mut splats = Vec::new();
        for pixel in lo..hi {
            if q < 1.0 && uniform(&mut fractions.get(pixel as u64)) >= q {
                continue;
            }
            let mut stream = streams(pixel);
            let v = estimator.sample(scene, pixel, &mut stream, &mut splats);
            samples.push((pixel, v));
        }
        (samples, splats, crate::accel::take_ray_count())
    };
    let merge = std::sync::Mutex::new(InOrder {
        next: 0,
        waiting: std::collections::BTreeMap::new(),
        film,
        taken: 0,
        rays: 0,
        pixel_estimates: estimator.has_pixel_estimate(),
    });
    let next_chunk = std::sync::atomic::AtomicUsize::new(0);
    rayon::scope(|scope| {
        for _ in 0..rayon::current_num_threads().min(CHUNKS) {
            scope.spawn(|_| {
                loop {
                    let c = next_chunk.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    if c >= CHUNKS {
                        break;
                    }
                    let result = run(c);
                    // A poisoned lock means another chunk panicked, which `scope` re-raises.
                    if let Ok(mut m) = merge.lock() {
                        m.arrive(c, result);
                    }
                }
            });
        }
    });
    let m = merge
        .into_inner()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    debug_assert!(m.next == CHUNKS && m.waiting.is_empty());
    *rays += m.rays;
    if estimator.splats() {
        m.film.splat_scale += q;
    }
    m.taken
}

/// The film of a pass with the chunks that finished ahead of an earlier one ([`pass`]).
struct InOrder<'a> {
    /// The next chunk the film takes.
    next: usize,
    waiting: std::collections::BTreeMap<usize, ChunkResult>,
    film: &'a mut Film,
    taken: u64,
    rays: u64,
    pixel_estimates: bool,
}

impl InOrder<'_> {
    /// Chunk `c` is done: it, and every chunk waiting on it, enter the film in order.
    fn arrive(&mut self, c: usize, result: ChunkResult) {
        self.waiting.insert(c, result);
        while let Some((samples, splats, r)) = self.waiting.remove(&self.next) {
            self.taken += samples.len() as u64;
            if self.pixel_estimates {
                for (p, v) in samples {
                    self.film.add_sample(p, v);
                }
            }
            for (r, v) in splats {
                self.film.add_splat(r, v);
            }
            self.rays += r;
            self.next += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin;

    /// Splats whose sum depends on the order it is taken in: every sample adds `1e16` or `±1` to
    /// the first pixel (in floating point, `1e16 + 1 − 1e16` is not `1`), and the chunks take
    /// uneven times, so chunks finish out of order on several threads.
    struct OrderSensitive;

    impl Estimator for OrderSensitive {
        fn sample(
            &self,
            _: &Scene,
            pixel: usize,
            stream: &mut PixelStream,
            splats: &mut Vec<Splat>,
        ) -> Rgb {
            let u = uniform(stream.rng());
            if pixel.is_multiple_of(97) {
                std::thread::sleep(Duration::from_micros(50 * (pixel % 7) as u64));
            }
            let v = match pixel % 3 {
                0 => 1e16,
                1 => -1e16,
                _ => u,
            };
            splats.push(([0.5, 0.5], Rgb::splat(v)));
            Rgb::splat(u)
        }

        fn splats(&self) -> bool {
            true
        }
    }

    /// A pass gives the same film, bit for bit, on 1, 2, 3 and 8 threads: for the order-sensitive
    /// splats above and for BDPT (whose light-tracing strategies splat). Fails if chunks entered
    /// the film in the order they finished.
    #[test]
    fn a_pass_is_the_same_on_any_number_of_threads() {
        let scene = Scene::new(&builtin::builtin("cornell").unwrap(), Some((40, 30))).unwrap();
        let bdpt = bdpt::Bdpt {
            walk: crate::path::WalkSettings { max_edges: 6 },
            heuristic: crate::path::MisHeuristic::Balance,
            roulette: None,
            shadow_roulette: None,
        };
        let films = |estimator: &(dyn Fn(&mut Film, &mut u64) + Sync)| -> Vec<Vec<[u64; 3]>> {
            [1, 2, 3, 8]
                .map(|threads| {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap();
                    let (mut film, mut rays) = (Film::new(40, 30), 0);
                    pool.install(|| estimator(&mut film, &mut rays));
                    film.image()
                        .iter()
                        .map(|p| [0, 1, 2].map(|c| p[c].to_bits()))
                        .collect()
                })
                .to_vec()
        };
        let ordered = films(&|film, rays| {
            pass(&scene, &OrderSensitive, 7, 0, 1.0, film, rays);
        });
        let with_bdpt = films(&|film, rays| {
            pass(&scene, &bdpt, 7, 0, 1.0, film, rays);
            pass(&scene, &bdpt, 7, 1, 0.5, film, rays);
        });
        for f in [ordered, with_bdpt] {
            assert!(f.iter().all(|g| *g == f[0]));
        }
    }

    /// Returns the two film numbers of its sample as a colour.
    struct FilmNumbers;

    impl Estimator for FilmNumbers {
        fn sample(&self, _: &Scene, _: usize, stream: &mut PixelStream, _: &mut Vec<Splat>) -> Rgb {
            use crate::sampler::{CAMERA_STREAM, SampleStream};
            stream.start_stream(CAMERA_STREAM);
            let [u, v] = stream.next_2d();
            Rgb::new(u, v, 0.0)
        }
        fn splats(&self) -> bool {
            false
        }
    }

    /// The pass driver gives each pixel one scrambled Sobol sequence and its passes successive
    /// points: the film numbers of a pixel's first 16 passes put one point in each of the 16
    /// cells of a 4 × 4 grid (and of every other grid of 16 cells, tested in `sampler`), for
    /// each of several pixels. With independent numbers, or with a sequence scrambled afresh
    /// every pass, they do not.
    #[test]
    fn the_passes_of_a_pixel_are_the_points_of_its_sobol_sequence() {
        let scene = Scene::new(&builtin::builtin("cornell").unwrap(), Some((8, 4))).unwrap();
        let cells = |sampler: PixelSampler, pixel: usize| -> Vec<usize> {
            let mut count = vec![0; 16];
            for p in 0..16 {
                let (mut film, mut rays) = (Film::new(8, 4), 0);
                let sampling = Sampling { seed: 3, sampler };
                pass(&scene, &FilmNumbers, sampling, p, 1.0, &mut film, &mut rays);
                let v = film.image()[pixel];
                count[(v[0] * 4.0) as usize * 4 + (v[1] * 4.0) as usize] += 1;
            }
            count
        };
        for pixel in [0, 5, 31] {
            assert_eq!(
                cells(PixelSampler::Sobol, pixel),
                vec![1; 16],
                "pixel {pixel}"
            );
            assert_ne!(cells(PixelSampler::Independent, pixel), vec![1; 16]);
        }
    }
}
