//! Direct lighting apart from the chains: the paths of at most two edges (an emitter seen
//! directly, direct illumination, an emitter seen in a mirror) are rendered by a direct-lighting
//! pass ([`DirectLighting`]: next-event estimation and BSDF sampling combined by MIS, every lobe
//! followed at a mirror or glass surface), the longer ones by a Metropolis method's chains.
//! Mitsuba 0.6's MLT integrators render direct illumination apart by default (`separateDirect`,
//! with 16 `directSamples` per pixel).
//!
//! Why: multiplexed MLT allots its chains to path lengths in proportion to their energy, so on a
//! scene lit mostly directly most chains sample the paths that a path tracer handles best (72% of
//! the chains on the Cornell box sample one or two edges; README). The two estimates cover disjoint
//! sets of paths, so their sum estimates the image: one film holds the pass's per-pixel estimates
//! and the chains' splats side by side ([`crate::film::Film::image`] adds them). The pass runs
//! pass by pass between the chains' rounds, keeping pace with them, so that a render stopped early
//! still holds an estimate of every path.
//!
//! The chains are any [`Chains`] renderer whose image leaves those paths out: a Metropolis
//! method on the driver ([`SeparateDirect::new`]), or energy redistribution path tracing, whose
//! passes of seeds and chains skip the short seeds ([`SeparateDirect::around`],
//! [`crate::pathspace::ErptSettings::direct_apart`]).

use super::driver::{Method, MetropolisSettings};
use crate::budget::Budget;
use crate::film::{Film, FilmView, Image};
use crate::integrators::Estimator;
use crate::integrators::{DirectLighting, Sampling, pass};
use crate::path::MisHeuristic;
use crate::renderer::{Control, Metropolis, Passes, Progress, Renderer, Report};
use crate::sampler::PixelSampler;
use crate::scene::Scene;
use crate::{Error, Result};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// Longest paths the direct pass renders: the emitter seen directly and direct illumination.
pub const DIRECT_EDGES: usize = 2;

/// A Metropolis method whose chains can leave the paths of the direct pass to it.
pub trait DirectApart: Method + Sized {
    /// This method with chains on paths of more than [`DIRECT_EDGES`] edges only (its image alone
    /// then lacks the shorter ones).
    fn without_direct(self) -> Self;
    /// Longest paths the method samples.
    fn max_edges(&self) -> usize;
}

/// A renderer of the paths longer than [`DIRECT_EDGES`] edges, run beside the direct pass.
pub trait Chains: Renderer {
    /// Correct `report`'s figures for the direct passes that ran between the chains' rounds for
    /// `direct_time` in all (`pixels`: of the image). Nothing by default.
    fn discount(&self, _report: &mut Report, _pixels: f64, _direct_time: Duration) {}
}

impl<M: Method> Chains for Metropolis<M> {
    /// The chains' time and rates without the passes.
    fn discount(&self, report: &mut Report, pixels: f64, direct_time: Duration) {
        if let Some(stats) = report.metropolis.as_mut() {
            stats.chain_time = stats.chain_time.saturating_sub(direct_time);
            report.details = self.details(stats, pixels);
        }
    }
}

/// Energy redistribution path tracing's passes (their time includes the direct passes run
/// between them; ERPT reports no rates of its own).
impl<E: Estimator> Chains for Passes<E> {}

/// A Metropolis method (or ERPT) with direct lighting rendered apart (module docs).
pub struct SeparateDirect<R> {
    /// The chains, on paths of more than [`DIRECT_EDGES`] edges.
    pub chains: R,
    /// The direct pass.
    pub direct: DirectLighting,
    /// Samples per pixel of the direct pass under a samples-per-pixel budget (spread over the
    /// chains' rounds in proportion to their mutations).
    pub samples_per_pixel: usize,
    /// Share of the wall time the direct pass runs for under a time budget (the bootstrap
    /// counted; the chains run for the rest).
    pub time_share: f64,
}

impl<M: DirectApart> SeparateDirect<Metropolis<M>> {
    /// `method` with its paths of at most [`DIRECT_EDGES`] edges rendered apart by the
    /// direct-lighting pass (MIS by `heuristic` between light and BSDF sampling): `samples_per_pixel` samples per pixel under a
    /// samples-per-pixel budget, `time_share` of a time budget. Errors if the method samples no
    /// path longer than [`DIRECT_EDGES`] edges (nothing would be left to the chains: render such a
    /// scene without a direct pass), without samples, or with a share outside (0, 1).
    pub fn new(
        method: M,
        settings: MetropolisSettings,
        heuristic: MisHeuristic,
        samples_per_pixel: usize,
        time_share: f64,
    ) -> Result<Self> {
        let max_edges = method.max_edges();
        let chains = Metropolis {
            method: method.without_direct(),
            settings,
        };
        SeparateDirect::around(chains, max_edges, heuristic, samples_per_pixel, time_share)
    }
}

impl<R: Chains> SeparateDirect<R> {
    /// `chains`, a renderer whose image already leaves out the paths of at most
    /// [`DIRECT_EDGES`] edges (of paths up to `max_edges` edges), with those paths rendered by
    /// the direct pass, as [`SeparateDirect::new`] does.
    pub fn around(
        chains: R,
        max_edges: usize,
        heuristic: MisHeuristic,
        samples_per_pixel: usize,
        time_share: f64,
    ) -> Result<Self> {
        if max_edges <= DIRECT_EDGES {
            return Err(Error::InvalidParameter {
                name: "direct pass".into(),
                reason: format!(
                    "a direct pass needs paths longer than {DIRECT_EDGES} edges for the chains (the maximum is {max_edges})"
                ),
            });
        }
        if samples_per_pixel == 0 || !(time_share > 0.0 && time_share < 1.0) {
            return Err(Error::InvalidParameter {
                name: "direct pass".into(),
                reason: format!(
                    "needs at least one sample per pixel (got {samples_per_pixel}) and a share of the time strictly between 0 and 1 (got {time_share})"
                ),
            });
        }
        Ok(Self {
            chains,
            direct: DirectLighting { heuristic },
            samples_per_pixel,
            time_share,
        })
    }
}

/// The direct pass so far: its own film, built pass by pass (pass `i` from the same numbers
/// whenever it runs, so the film does not depend on when the passes ran).
struct DirectSoFar {
    film: Film,
    passes: u64,
    samples: u64,
    rays: u64,
    time: Duration,
}

impl DirectSoFar {
    /// One more whole pass.
    fn pass(&mut self, scene: &Scene, direct: &DirectLighting, seed: u64) {
        let t = Instant::now();
        let sampling = Sampling {
            seed,
            sampler: PixelSampler::default(),
        };
        self.samples += pass(
            scene,
            direct,
            sampling,
            self.passes,
            1.0,
            &mut self.film,
            &mut self.rays,
        );
        self.passes += 1;
        self.time += t.elapsed();
    }

    /// The summary line.
    fn line(&self) -> String {
        format!(
            "direct     paths of ≤ {DIRECT_EDGES} edges apart from the chains: {} samples per pixel in {:.2} s{}",
            self.passes,
            self.time.as_secs_f64(),
            if self.film.discarded > 0 {
                format!(", {} non-finite discarded", self.film.discarded)
            } else {
                String::new()
            }
        )
    }
}

impl<R: Chains> Renderer for SeparateDirect<R> {
    /// The direct pass keeps pace with the chains: one pass first, then after every round of the
    /// chains as many passes as keep it at its share (of the samples per pixel the budget asks
    /// for, or of the time so far), the rest at the end under a samples-per-pixel budget. So a
    /// render stopped at any point after the bootstrap holds both estimates, and the progress
    /// callback sees the film with both.
    fn render(
        &self,
        scene: &Scene,
        budget: Budget,
        seed: u64,
        control: &mut Control<'_>,
    ) -> Result<(Film, Report)> {
        budget.validate()?;
        let start = Instant::now();
        let stop = control.stop;
        let stopped = || stop.is_some_and(|s| s.load(Ordering::Relaxed));
        let planned = self.samples_per_pixel as u64;
        let (width, height) = (scene.camera.width, scene.camera.height);
        let mut direct = DirectSoFar {
            film: Film::new(width, height),
            passes: 0,
            samples: 0,
            rays: 0,
            time: Duration::ZERO,
        };
        direct.pass(scene, &self.direct, seed);
        if stopped() {
            // Stopped during the first pass: its work is all there is (no estimate of the
            // longer paths, so no samples to weigh it by in a merge).
            let report = Report {
                interrupted: true,
                elapsed: start.elapsed(),
                details: vec![direct.line(), "chains     not run (interrupted)".into()],
                discarded: direct.film.discarded,
                rays: direct.rays,
                ..Report::default()
            };
            return Ok((direct.film, report));
        }
        // Whether a pass is owed once the chains have made `spp` mutations per pixel: under a
        // samples-per-pixel budget the same share of the planned passes, under a time budget
        // passes until the pass has had its share of the time so far.
        let owed = |direct: &DirectSoFar, spp: f64| match budget {
            Budget::SamplesPerPixel(m) => {
                direct.passes < planned.min((planned as f64 * spp / m).ceil() as u64)
            }
            Budget::Time(_) => {
                direct.time.as_secs_f64() < self.time_share * start.elapsed().as_secs_f64()
            }
        };
        let chain_budget = match budget {
            Budget::SamplesPerPixel(m) => Budget::SamplesPerPixel(m),
            Budget::Time(t) => Budget::Time(
                t.saturating_sub(start.elapsed())
                    .max(Duration::from_millis(1)),
            ),
        };
        let before_chains = direct.time;
        let result = {
            let direct = &mut direct;
            let mut progress = |film: FilmView<'_>, p: &Progress| {
                while owed(direct, p.samples_per_pixel) && !stopped() {
                    direct.pass(scene, &self.direct, seed);
                }
                let p = Progress {
                    elapsed: start.elapsed(),
                    ..*p
                };
                match film {
                    FilmView::One(chains) => {
                        (control.progress)(FilmView::Merged(&direct.film, chains), &p)
                    }
                    // Chains that report two films themselves: their merge is built here.
                    FilmView::Merged(a, b) => {
                        let mut chains = a.clone();
                        chains.merge(b);
                        (control.progress)(FilmView::Merged(&direct.film, &chains), &p)
                    }
                }
            };
            let mut chain_control = Control {
                progress: &mut progress,
                stop,
            };
            self.chains
                .render(scene, chain_budget, seed, &mut chain_control)
        };
        let (chains, mut report) = match result {
            // No longer path carried light in the bootstrap: its estimate of them is 0, and
            // the image is the direct pass's (unless that is black too), which takes the whole
            // budget.
            Err(Error::NoLight { paths })
                if Image::from_film(&direct.film).mean().max_component() > 0.0 =>
            {
                let done = |d: &DirectSoFar| match budget {
                    Budget::SamplesPerPixel(_) => d.passes >= planned,
                    Budget::Time(t) => start.elapsed() >= t,
                };
                while !done(&direct) && !stopped() {
                    direct.pass(scene, &self.direct, seed);
                }
                let report = Report {
                    samples_per_pixel: direct.passes as f64,
                    samples: direct.samples,
                    elapsed: start.elapsed(),
                    details: vec![
                        direct.line(),
                        format!(
                            "chains     none: no path longer than {DIRECT_EDGES} edges carried light in {paths} bootstrap paths"
                        ),
                    ],
                    discarded: direct.film.discarded,
                    rays: direct.rays,
                    interrupted: stopped(),
                    ..Report::default()
                };
                return Ok((direct.film, report));
            }
            other => other?,
        };
        // The chains' time and rates without the passes run between their rounds.
        self.chains.discount(
            &mut report,
            (width * height) as f64,
            direct.time.saturating_sub(before_chains),
        );
        if let Budget::SamplesPerPixel(_) = budget {
            while direct.passes < planned && !stopped() {
                direct.pass(scene, &self.direct, seed);
            }
        }
        report.interrupted |= stopped();
        report.details.insert(0, direct.line());
        let mut film = direct.film;
        film.merge_owned(chains);
        report.rays += direct.rays;
        report.discarded = film.discarded;
        report.elapsed = start.elapsed();
        Ok((film, report))
    }
}
