//! Options of charted MLT (`--algo cmlt`).

use super::CliError;
use super::algo::Common;
use super::metropolis::MetropolisArgs;
use super::pathspace::PathSpaceArgs;
use clap::Args;
use light_transport::cmlt::Cmlt;
use light_transport::scene::Scene;

/// Charted MLT options.
#[derive(Args, Debug, Clone)]
pub struct CmltArgs {
    /// Mean mutations between chart swaps (serial tempering; 0 disables swaps).
    #[arg(long, default_value_t = 16.0)]
    pub swap_every: f64,
    /// Probability of an inverse primary-space perturbation per mutation.
    #[arg(long, default_value_t = 0.0)]
    pub ipsm: f64,
    /// Probability of a path-space mutation per mutation (the identity chart; mix from
    /// --mutations).
    #[arg(long, default_value_t = 0.0)]
    pub pathspace: f64,
    /// Uniform samples per technique chart in the pilot estimating technique energies.
    #[arg(long, default_value_t = 1000)]
    pub cmlt_pilot: usize,
}

impl CmltArgs {
    /// The documented defaults (parsed from an empty command line).
    pub fn default_values() -> Self {
        #[derive(clap::Parser)]
        struct Wrapper {
            #[command(flatten)]
            c: CmltArgs,
        }
        <Wrapper as clap::Parser>::parse_from(["charted"]).c
    }

    /// CMLT on `scene` (runs the technique-energy pilot).
    pub fn cmlt(
        &self,
        scene: &Scene,
        c: &Common,
        m: &MetropolisArgs,
        p: &PathSpaceArgs,
    ) -> Result<Cmlt, CliError> {
        let mutations = p.mlt(c, m)?.mutations;
        Ok(Cmlt::new(
            scene,
            c.max_edges,
            m.importance(),
            m.small_step(),
            m.large_step,
            self.swap_every,
            self.ipsm,
            self.pathspace,
            mutations,
            self.cmlt_pilot,
        )?)
    }
}
