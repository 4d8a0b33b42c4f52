//! Options and runner of the Metropolis integrators (`--algo pssmlt|mmlt`).

use super::CliError;
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use light_transport::film::Film;
use light_transport::metropolis::{
    self, Budget, ImportanceKind, Method, MetropolisSettings, MetropolisStats,
};
use light_transport::scene::Scene;
use mcmc_core::primary_sample::Kelemen;
use mcmc_core::proposals::SmallStep;
use std::time::Duration;

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

/// Metropolis options (used by `--algo pssmlt` and `--algo mmlt`).
#[derive(Args, Debug, Clone)]
pub struct MetropolisArgs {
    /// Probability of a large step (independence proposal).
    #[arg(long, default_value_t = 0.3)]
    pub large_step: f64,
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
    /// Scalar importance of colours.
    #[arg(long, value_enum, default_value_t = Importance::Luminance)]
    pub importance: Importance,
}

impl MetropolisArgs {
    /// The documented defaults.
    pub fn default_values() -> Self {
        Self {
            large_step: 0.3,
            small_step: SmallStepKind::Exponential,
            s1: 1.0 / 1024.0,
            s2: 1.0 / 64.0,
            sigma: 0.01,
            chains: 1000,
            bootstrap: 100_000,
            importance: Importance::Luminance,
        }
    }

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

    /// Driver settings for a budget.
    pub fn settings(&self, budget: Budget, seed: u64) -> MetropolisSettings {
        MetropolisSettings {
            chains: self.chains,
            bootstrap: self.bootstrap,
            budget,
            seed,
            seeding: Default::default(),
        }
    }
}

/// Run a Metropolis method with a progress bar; `every` sees the film after each round.
pub fn run_method<M: Method>(
    scene: &Scene,
    method: &M,
    settings: &MetropolisSettings,
    quiet: bool,
    mut every: impl FnMut(&Film, u64, Duration) -> bool,
) -> Result<(Film, MetropolisStats), CliError> {
    let pixels = (scene.camera.width * scene.camera.height) as f64;
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        match settings.budget {
            Budget::MutationsPerPixel(m) => ProgressBar::new((m * pixels) as u64),
            Budget::Time(t) => ProgressBar::new(t.as_millis() as u64),
        }
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message("bootstrap");
    let out = metropolis::run(scene, method, settings, |film, mutations, elapsed| {
        match settings.budget {
            Budget::MutationsPerPixel(_) => bar.set_position(mutations),
            Budget::Time(_) => bar.set_position(elapsed.as_millis() as u64),
        }
        bar.set_message(format!(
            "{:.1} mutations/pixel, {:.2} M mutations/s",
            mutations as f64 / pixels,
            mutations as f64 / elapsed.as_secs_f64().max(1e-9) / 1e6
        ));
        every(film, mutations, elapsed)
    })?;
    bar.finish_and_clear();
    Ok(out)
}

/// Print the statistics of a Metropolis render.
pub fn print_stats(s: &MetropolisStats, pixels: f64) {
    println!(
        "bootstrap  {:.2} s, normalisation b = {:.5e} ({} of the samples carry light{}), seeding {:.2} s",
        s.bootstrap_time.as_secs_f64(),
        s.normalisation,
        s.bootstrap_nonzero,
        if s.bootstrap_discarded > 0 {
            format!(", {} non-finite discarded", s.bootstrap_discarded)
        } else {
            String::new()
        },
        s.seed_time.as_secs_f64()
    );
    if s.group_chains.len() > 1 {
        let groups: Vec<String> = s
            .group_chains
            .iter()
            .enumerate()
            .filter(|(_, c)| **c > 0)
            .map(|(g, c)| format!("k={}:{c}", g + 1))
            .collect();
        println!("chains     per path length {}", groups.join(" "));
    }
    let secs = s.chain_time.as_secs_f64().max(1e-9);
    println!(
        "chains     {:.2} s, {} mutations ({:.1} per pixel), {:.2} M mutations/s, {:.2} M rays/s",
        secs,
        s.mutations,
        s.mutations as f64 / pixels,
        s.mutations as f64 / secs / 1e6,
        s.rays as f64 / secs / 1e6
    );
    print!("{}", s.stats.table(&s.kinds));
}
