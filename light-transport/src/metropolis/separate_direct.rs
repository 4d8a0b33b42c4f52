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
//! and the chains' splats side by side ([`crate::film::Film::image`] adds them).

use super::driver::{Method, MetropolisSettings};
use crate::budget::Budget;
use crate::film::{Film, Image};
use crate::integrators::DirectLighting;
use crate::path::MisHeuristic;
use crate::renderer::{Control, Metropolis, Passes, Progress, Renderer, Report};
use crate::scene::Scene;
use crate::{Error, Result};
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

/// A Metropolis method with direct lighting rendered apart (module docs).
pub struct SeparateDirect<M> {
    /// The chains, on paths of more than [`DIRECT_EDGES`] edges.
    pub chains: Metropolis<M>,
    /// The direct pass.
    pub direct: DirectLighting,
    /// Samples per pixel of the direct pass under a samples-per-pixel budget.
    pub samples_per_pixel: usize,
    /// Share of a time budget the direct pass runs for (the chains run for the rest).
    pub time_share: f64,
}

impl<M: DirectApart> SeparateDirect<M> {
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
        if method.max_edges() <= DIRECT_EDGES {
            return Err(Error::InvalidParameter {
                name: "direct pass".into(),
                reason: format!(
                    "a direct pass needs paths longer than {DIRECT_EDGES} edges for the chains (the maximum is {})",
                    method.max_edges()
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
            chains: Metropolis {
                method: method.without_direct(),
                settings,
            },
            direct: DirectLighting { heuristic },
            samples_per_pixel,
            time_share,
        })
    }
}

impl<M: Method> Renderer for SeparateDirect<M> {
    /// The direct pass first (a fixed number of samples per pixel, or a share of a time budget,
    /// the chains running for what is left), then the chains; the progress callback sees the
    /// film with both.
    fn render(
        &self,
        scene: &Scene,
        budget: Budget,
        seed: u64,
        control: &mut Control<'_>,
    ) -> Result<(Film, Report)> {
        budget.validate()?;
        let start = Instant::now();
        let mut silent = |_: &Film, _: &Progress| true;
        let mut direct_control = Control {
            progress: &mut silent,
            stop: control.stop,
        };
        let (direct, direct_report) = Passes::new(self.direct).render(
            scene,
            match budget {
                Budget::SamplesPerPixel(_) => {
                    Budget::SamplesPerPixel(self.samples_per_pixel as f64)
                }
                Budget::Time(t) => Budget::Time(t.mul_f64(self.time_share)),
            },
            seed,
            &mut direct_control,
        )?;
        let direct_line = format!(
            "direct     paths of ≤ {DIRECT_EDGES} edges apart from the chains: {:.1} samples per pixel in {:.2} s{}",
            direct_report.samples_per_pixel,
            direct_report.elapsed.as_secs_f64(),
            if direct.discarded > 0 {
                format!(", {} non-finite discarded", direct.discarded)
            } else {
                String::new()
            }
        );
        if direct_report.interrupted {
            // Stopped during the direct pass: its work is all there is.
            let report = Report {
                interrupted: true,
                elapsed: start.elapsed(),
                details: vec![direct_line, "chains     not run (interrupted)".into()],
                discarded: direct.discarded,
                rays: direct_report.rays,
                ..Report::default()
            };
            return Ok((direct, report));
        }
        let chain_budget = match budget {
            Budget::SamplesPerPixel(m) => Budget::SamplesPerPixel(m),
            Budget::Time(t) => Budget::Time(
                t.saturating_sub(start.elapsed())
                    .max(Duration::from_millis(1)),
            ),
        };
        let mut progress = |film: &Film, p: &Progress| {
            let mut both = direct.clone();
            both.merge(film);
            let p = Progress {
                elapsed: start.elapsed(),
                ..*p
            };
            (control.progress)(&both, &p)
        };
        let mut chain_control = Control {
            progress: &mut progress,
            stop: control.stop,
        };
        let (chains, mut report) = match self.chains.render(
            scene,
            chain_budget,
            seed,
            &mut chain_control,
        ) {
            // No longer path carried light in the bootstrap: its estimate of them is 0, and
            // the image is the direct pass's (unless that is black too).
            Err(Error::NoLight { paths })
                if Image::from_film(&direct).mean().max_component() > 0.0 =>
            {
                let report = Report {
                    samples_per_pixel: direct_report.samples_per_pixel,
                    samples: direct_report.samples,
                    elapsed: start.elapsed(),
                    details: vec![
                        direct_line,
                        format!(
                            "chains     none: no path longer than {DIRECT_EDGES} edges carried light in {paths} bootstrap paths"
                        ),
                    ],
                    discarded: direct.discarded,
                    rays: direct_report.rays,
                    ..Report::default()
                };
                return Ok((direct, report));
            }
            other => other?,
        };
        let mut film = direct.clone();
        film.merge(&chains);
        report.details.insert(0, direct_line);
        report.rays += direct_report.rays;
        report.discarded = film.discarded;
        report.elapsed += direct_report.elapsed;
        Ok((film, report))
    }
}
