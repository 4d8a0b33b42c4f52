//! Options of the path-space integrators (`--algo mlt|erpt`): mutation probabilities, the
//! perturbations' offsets, and ERPT's chains.

use super::CliError;
use super::algo::Common;
use super::metropolis::MetropolisArgs;
use clap::Args;
use light_transport::pathspace::{
    Erpt, ErptSettings, MutationKind, MutationProbabilities, Mutations, PathMlt,
    PerturbationSettings,
};
use light_transport::scene::Scene;
use mcmc_core::Stats;

fn parse_probabilities(s: &str) -> Result<MutationProbabilities, String> {
    s.parse().map_err(|e: light_transport::Error| e.to_string())
}

/// Path-space MLT and ERPT options.
#[derive(Args, Debug, Clone)]
pub struct PathSpaceArgs {
    /// Mutation probabilities of `mlt`, `name=p,...` over bidirectional, lens-subpath, lens,
    /// caustic, multi-chain, new-path (unnamed kinds get 0; normalised).
    #[arg(
        long,
        value_parser = parse_probabilities,
        default_value = "bidirectional=0.25,lens-subpath=0.1,lens=0.2,caustic=0.2,multi-chain=0.15,new-path=0.1"
    )]
    pub mutations: MutationProbabilities,
    /// Mutation probabilities of `erpt` (default: the perturbations only).
    #[arg(
        long,
        value_parser = parse_probabilities,
        default_value = "lens=0.4,caustic=0.3,multi-chain=0.3"
    )]
    pub erpt_mutations: MutationProbabilities,
    /// Smallest pixel offset of the lens and multi-chain perturbations (pixels).
    #[arg(long, default_value_t = 0.1)]
    pub r1: f64,
    /// Largest pixel offset, as a fraction of the image width.
    #[arg(long, default_value_t = 0.1)]
    pub r2: f64,
    /// Smallest angular offset of the caustic and multi-chain perturbations (radians).
    #[arg(long, default_value_t = 1e-4)]
    pub theta1: f64,
    /// Largest angular offset (radians).
    #[arg(long, default_value_t = 0.1)]
    pub theta2: f64,
    /// ERPT: mutations per chain.
    #[arg(long, default_value_t = 100)]
    pub erpt_chain_length: u64,
    /// ERPT: chains started per pixel sample on average (sets the energy quantum).
    #[arg(long, default_value_t = 1.0)]
    pub erpt_chains: f64,
}

impl PathSpaceArgs {
    fn perturbation(&self) -> PerturbationSettings {
        PerturbationSettings {
            r1: self.r1,
            r2_fraction: self.r2,
            theta1: self.theta1,
            theta2: self.theta2,
        }
    }

    /// Path-space MLT.
    pub fn mlt(&self, c: &Common, m: &MetropolisArgs) -> Result<PathMlt, CliError> {
        Ok(PathMlt::new(Mutations {
            max_edges: c.max_edges,
            importance: m.importance(),
            probabilities: self.mutations,
            perturbation: self.perturbation(),
        })?)
    }

    /// ERPT (runs its pilot on `scene`).
    pub fn erpt(&self, scene: &Scene, c: &Common, m: &MetropolisArgs) -> Result<Erpt, CliError> {
        let mut settings = ErptSettings::new(c.max_edges);
        settings.mutations.importance = m.importance();
        settings.mutations.probabilities = self.erpt_mutations;
        settings.mutations.perturbation = self.perturbation();
        settings.chain_length = self.erpt_chain_length;
        settings.chains_per_seed = self.erpt_chains;
        Ok(Erpt::new(scene, settings)?)
    }
}

/// Print ERPT's statistics: quantum, chains, acceptance per mutation kind.
pub fn print_erpt_stats(erpt: &Erpt, pixels: f64) {
    let (stats, chains): (Stats, u64) = erpt.statistics();
    let names: Vec<String> = MutationKind::ALL
        .iter()
        .map(|k| k.name().to_string())
        .collect();
    println!(
        "erpt       energy quantum e_d = {:.4e}, {} chains of {} mutations ({:.2} chains per pixel)",
        erpt.quantum,
        chains,
        erpt.settings.chain_length,
        chains as f64 / pixels
    );
    print!("{}", stats.table(&names));
}

impl PathSpaceArgs {
    /// The documented defaults (parsed from an empty command line, so they cannot drift).
    pub fn default_values() -> Self {
        #[derive(clap::Parser)]
        struct Wrapper {
            #[command(flatten)]
            p: PathSpaceArgs,
        }
        <Wrapper as clap::Parser>::parse_from(["charted"]).p
    }
}
