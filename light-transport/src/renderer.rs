//! One way to run any integrator: [`Renderer`] renders a scene within a [`Budget`] into a film,
//! reporting progress and honouring a stop request, whatever the algorithm — the pass-based
//! unbiased estimators ([`Passes`]) and the Metropolis methods on the shared driver
//! ([`Metropolis`]) alike. The command line's integrator registry hands out `Box<dyn Renderer>`,
//! so `render`, `compare` and `reference` run every algorithm through this one trait.

use crate::Result;
use crate::budget::Budget;
use crate::film::{Film, FilmView};
use crate::integrators::{Estimator, Sampling, render};
use crate::metropolis::{Method, MetropolisSettings, MetropolisStats, run_with};
use crate::sampler::PixelSampler;
use crate::scene::Scene;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Progress of a render after a pass or round.
#[derive(Clone, Copy, Debug, Default)]
pub struct Progress {
    /// Samples (mutations) per pixel so far.
    pub samples_per_pixel: f64,
    /// Time since the render started (for Metropolis methods: the bootstrap included).
    pub elapsed: Duration,
    /// Rays traced so far (0 where not counted per round).
    pub rays: u64,
}

/// What a finished render reports.
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// Samples (mutations) per pixel actually taken: the weight of this render when shards are
    /// merged.
    pub samples_per_pixel: f64,
    /// Samples (mutations) taken.
    pub samples: u64,
    /// Rays traced.
    pub rays: u64,
    /// Wall-clock time.
    pub elapsed: Duration,
    /// Samples rejected as NaN or infinite.
    pub discarded: u64,
    /// Whether the render stopped early on request.
    pub interrupted: bool,
    /// What the algorithm has to say beyond that (bootstrap, acceptance per move, …), one line
    /// each.
    pub details: Vec<String>,
    /// The Metropolis driver's statistics, for Metropolis methods.
    pub metropolis: Option<MetropolisStats>,
}

/// How a render is watched: `progress` sees the film after every pass or round (as a view, whose
/// image is built only if the callback asks for it) and may stop the
/// render by returning `false`; `stop` (set by a signal handler) stops it at the end of the
/// current pass, or of the current slice of a Metropolis round.
pub struct Control<'a> {
    /// Called after every pass or round.
    pub progress: &'a mut dyn FnMut(FilmView<'_>, &Progress) -> bool,
    /// A stop request.
    pub stop: Option<&'a AtomicBool>,
}

impl Control<'_> {
    fn stopped(&self) -> bool {
        self.stop.is_some_and(|s| s.load(Ordering::Relaxed))
    }
}

/// An integrator ready to render.
pub trait Renderer: Sync {
    /// Render `scene` within `budget` with master seed `seed`.
    fn render(
        &self,
        scene: &Scene,
        budget: Budget,
        seed: u64,
        control: &mut Control<'_>,
    ) -> Result<(Film, Report)>;
}

/// A pass-based estimator as a [`Renderer`].
pub struct Passes<E> {
    /// The estimator.
    pub estimator: E,
    /// Extra report lines after the render (e.g. ERPT's statistics).
    pub details: fn(&E, f64) -> Vec<String>,
    /// How its samples draw their numbers.
    pub sampler: PixelSampler,
}

impl<E> Passes<E> {
    /// The estimator with the default sampler and no extra report.
    pub fn new(estimator: E) -> Self {
        Self {
            estimator,
            details: |_, _| Vec::new(),
            sampler: PixelSampler::default(),
        }
    }
}

impl<E: Estimator> Renderer for Passes<E> {
    fn render(
        &self,
        scene: &Scene,
        budget: Budget,
        seed: u64,
        control: &mut Control<'_>,
    ) -> Result<(Film, Report)> {
        budget.validate()?;
        let mut interrupted = false;
        let sampling = Sampling {
            seed,
            sampler: self.sampler,
        };
        let (film, stats) = render(scene, &self.estimator, budget, sampling, |film, p| {
            let progress = Progress {
                samples_per_pixel: p.passes as f64,
                elapsed: p.elapsed,
                rays: p.rays,
            };
            let go_on = (control.progress)(FilmView::One(film), &progress);
            interrupted = control.stopped();
            go_on && !interrupted
        });
        let pixels = (scene.camera.width * scene.camera.height) as f64;
        Ok((
            film,
            Report {
                samples_per_pixel: stats.samples_per_pixel,
                samples: stats.samples,
                rays: stats.rays,
                elapsed: stats.elapsed,
                discarded: stats.discarded,
                interrupted,
                details: {
                    let mut d = vec![format!("sampler    {}", self.sampler)];
                    d.extend((self.details)(&self.estimator, pixels));
                    d
                },
                metropolis: None,
            },
        ))
    }
}

/// A Metropolis method with its driver settings as a [`Renderer`] (the budget and seed given to
/// [`Renderer::render`] replace the settings').
pub struct Metropolis<M> {
    /// The method.
    pub method: M,
    /// Chains, bootstrap, seeding.
    pub settings: MetropolisSettings,
}

impl<M: Method> Metropolis<M> {
    /// The summary lines of a render with driver statistics `stats` on `pixels` pixels: the
    /// driver's, then the method's.
    pub fn details(&self, stats: &MetropolisStats, pixels: f64) -> Vec<String> {
        let mut details = stats.summary(pixels);
        details.extend(self.method.details());
        details
    }
}

impl<M: Method> Renderer for Metropolis<M> {
    fn render(
        &self,
        scene: &Scene,
        budget: Budget,
        seed: u64,
        control: &mut Control<'_>,
    ) -> Result<(Film, Report)> {
        let start = Instant::now();
        let settings = MetropolisSettings {
            budget,
            seed,
            ..self.settings
        };
        let pixels = (scene.camera.width * scene.camera.height) as f64;
        let mut film = Film::new(scene.camera.width, scene.camera.height);
        let stop = control.stop;
        let stats = run_with(
            scene,
            &self.method,
            &settings,
            &mut film,
            stop,
            |film, mutations, _| {
                let progress = Progress {
                    samples_per_pixel: mutations as f64 / pixels,
                    elapsed: start.elapsed(),
                    rays: 0,
                };
                (control.progress)(FilmView::One(film), &progress)
            },
        )?;
        let details = self.details(&stats, pixels);
        let report = Report {
            samples_per_pixel: stats.mutations as f64 / pixels,
            samples: stats.mutations,
            rays: stats.rays,
            elapsed: stats.bootstrap_time + stats.seed_time + stats.chain_time,
            discarded: film.discarded,
            interrupted: stats.interrupted,
            details,
            metropolis: Some(stats),
        };
        Ok((film, report))
    }
}
