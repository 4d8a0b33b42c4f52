//! Options of the Metropolis integrators (`--algo pssmlt|mmlt|mlt|memlt|cmlt`; ERPT and MEPT
//! take the direct pass's).

use super::CliError;
use clap::{Args, ValueEnum};
use light_transport::metropolis::{
    DIRECT_EDGES, DirectApart, ImportanceKind, MetropolisSettings, SeparateDirect,
};
use light_transport::path::MisHeuristic;
use light_transport::pathspace::{Erpt, ErptSettings};
use light_transport::renderer::{Metropolis, Passes, Renderer};
use light_transport::sampler::PixelSampler;
use light_transport::scene::Scene;
use mcmc_core::primary_sample::Kelemen;
use mcmc_core::proposals::SmallStep;
/// Small-step kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SmallStepKind {
    /// Kelemen's exponential offsets between s1 and s2.
    Exponential,
    /// Wrapped Gaussian offsets with standard deviation sigma.
    Gaussian,
}

/// Scalar importance of a colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Importance {
    /// Luminance.
    Luminance,
    /// Largest component.
    Max,
}

/// Metropolis options (of `--algo pssmlt`, `mmlt`, and the driver's and direct pass's options of
/// `mlt`, `memlt`, `cmlt`).
#[derive(Args, Debug, Clone)]
pub struct MetropolisArgs {
    /// Probability of a large step (independence proposal).
    #[arg(long, default_value_t = 0.3)]
    pub large_step: f64,
    /// PSSMLT and MMLT (default true): large steps also count as independent samples of the
    /// image, combined with the chains by the balance heuristic (Kelemen et al. 2002; at equal
    /// time 0.92–0.96x the RMSE of false on veach-bidir and door, within noise on the other
    /// built-ins; README). MLT and MEMLT (default false): new paths likewise (0.89–1.06x at equal
    /// time, geometric mean 0.99x; README). false: expected values alone.
    #[arg(long, action = clap::ArgAction::Set)]
    pub large_step_mis: Option<bool>,
    /// PSSMLT, MMLT, MLT, MEMLT, CMLT, ERPT and MEPT: samples per pixel (with --spp) of a pass
    /// that renders the paths of at most two edges apart from the chains (emitters seen directly
    /// or in a mirror, direct illumination; Mitsuba 0.6's separateDirect; README). The chains then
    /// sample longer paths only (ERPT's and MEPT's seeds of at most two edges start no chains).
    /// 0: no such pass, chains on every path (also when --max-depth leaves no longer paths).
    #[arg(long, default_value_t = 16)]
    pub direct_samples: usize,
    /// The share of the wall time (bootstrap included) the direct-lighting pass runs for under
    /// --time; its passes run between the chains' rounds, so a render stopped early holds both.
    #[arg(long, default_value_t = 0.2)]
    pub direct_share: f64,
    /// Small-step kernel.
    #[arg(long, value_enum, default_value_t = SmallStepKind::Exponential)]
    pub small_step: SmallStepKind,
    /// Smallest exponential offset.
    #[arg(long, default_value_t = 1.0 / 1024.0)]
    pub s1: f64,
    /// Largest exponential offset.
    #[arg(long, default_value_t = 1.0 / 64.0)]
    pub s2: f64,
    /// Standard deviation of Gaussian small steps.
    #[arg(long, default_value_t = 0.01)]
    pub sigma: f64,
    /// Number of chains.
    #[arg(long, default_value_t = 1000)]
    pub chains: usize,
    /// Bootstrap samples (per path length for mmlt).
    #[arg(long, default_value_t = 100_000)]
    pub bootstrap: usize,
    /// PSSMLT, MMLT, MLT, MEMLT and CMLT: refine the bootstrap's normalisation with the chains'
    /// independent candidates (large steps; new paths; CMLT's large steps chart by chart) as
    /// they run, so the image's overall scale converges with the render instead of keeping the
    /// bootstrap's error (README). false: the bootstrap's alone.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub refine_normalisation: bool,
    /// Scalar importance of colours.
    #[arg(long, value_enum, default_value_t = Importance::Luminance)]
    pub importance: Importance,
}

impl MetropolisArgs {
    /// The small-step kernel.
    pub fn small_step(&self) -> SmallStep {
        match self.small_step {
            SmallStepKind::Exponential => SmallStep::Exponential {
                s1: self.s1,
                s2: self.s2,
            },
            SmallStepKind::Gaussian => SmallStep::Gaussian { sigma: self.sigma },
        }
    }

    /// The Kelemen proposal.
    pub fn kelemen(&self) -> Result<Kelemen, CliError> {
        Kelemen::new(self.large_step, self.small_step()).map_err(|e| CliError::Usage(e.to_string()))
    }

    /// The importance kind.
    pub fn importance(&self) -> ImportanceKind {
        match self.importance {
            Importance::Luminance => ImportanceKind::Luminance,
            Importance::Max => ImportanceKind::MaxComponent,
        }
    }

    /// `method` on the shared driver as a renderer, with its direct lighting rendered apart
    /// (`--direct-samples`, `--direct-share`) unless that is off or `max_edges` leaves the chains
    /// no longer paths.
    pub fn renderer<M: DirectApart + 'static>(
        &self,
        method: M,
        heuristic: MisHeuristic,
        max_edges: usize,
    ) -> Result<Box<dyn Renderer>, CliError> {
        if self.direct_samples > 0 && max_edges > DIRECT_EDGES {
            return Ok(Box::new(SeparateDirect::new(
                method,
                self.settings(),
                heuristic,
                self.direct_samples,
                self.direct_share,
            )?));
        }
        Ok(Box::new(Metropolis {
            method,
            settings: self.settings(),
        }))
    }

    /// Energy redistribution path tracing (ERPT, or MEPT by its mutations) with `settings` as a
    /// renderer of passes drawing their numbers by `sampler`, with its direct lighting rendered
    /// apart as for the methods above (its seeds of at most two edges start no chains) unless
    /// that is off or `settings` leaves the chains no longer paths.
    pub fn erpt_renderer(
        &self,
        scene: &Scene,
        mut settings: ErptSettings,
        sampler: PixelSampler,
        heuristic: MisHeuristic,
    ) -> Result<Box<dyn Renderer>, CliError> {
        let max_edges = settings.mutations.max_edges;
        settings.direct_apart = self.direct_samples > 0 && max_edges > DIRECT_EDGES;
        let passes = Passes {
            sampler,
            estimator: Erpt::new(scene, settings.clone())?,
            details: Erpt::summary,
        };
        if !settings.direct_apart {
            return Ok(Box::new(passes));
        }
        Ok(Box::new(SeparateDirect::around(
            passes,
            max_edges,
            heuristic,
            self.direct_samples,
            self.direct_share,
        )?))
    }

    /// Driver settings (the budget and seed come with each render).
    pub fn settings(&self) -> MetropolisSettings {
        MetropolisSettings {
            chains: self.chains,
            bootstrap: self.bootstrap,
            refine_normalisation: self.refine_normalisation,
            ..MetropolisSettings::default()
        }
    }
}
