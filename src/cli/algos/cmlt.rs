//! Charted MLT (`--algo cmlt`) and its options.

use crate::cli::CliError;
use crate::cli::registry::{AlgoArgs, Common, Entry};
use clap::Args;
use light_transport::cmlt::{Cmlt, CmltSettings, DensityEstimation, SwapKind};
use light_transport::scene::Scene;
use mcmc_charts::moves::IndependenceRule;

/// Charted MLT (Pantaleoni 2017).
pub const ENTRY: Entry = Entry {
    name: "cmlt",
    about: "Charted MLT: technique charts with path inversion, chart swaps by serial tempering or replica exchange (--swaps)",
    unbiased: false,
    passes: false,
    build: |scene, c, a| {
        a.metropolis
            .renderer(a.cmlt.cmlt(scene, c, a)?, c.heuristic, c.max_edges)
    },
};

/// How chart swaps are made.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Swaps {
    /// Serial tempering (the paper's default).
    Serial,
    /// Replica exchange between chains of different charts.
    Replica,
}

/// Charted MLT options.
#[derive(Args, Debug, Clone)]
pub struct CmltArgs {
    /// How chains change technique chart: `serial` (serial tempering: a chain moves its own path
    /// to another chart) or `replica` (replica exchange: chains keep their chart and exchange
    /// paths with chains of other charts).
    #[arg(long, value_enum, default_value_t = Swaps::Serial)]
    pub swaps: Swaps,
    /// Serial tempering: mean mutations between chart swaps. Replica exchange: mutations per
    /// chain between exchange rounds. 0 disables swaps.
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
    /// Probability of a density-estimation move per mutation (charted-MLT paper §5.3): an
    /// independence sampler mixing merges with a stored light vertex and bidirectional
    /// connections by their expected density (eq. 29). Slightly biased (the merge probability
    /// is approximated; see the README); off by default.
    #[arg(long, default_value_t = 0.0)]
    pub density_estimation: f64,
    /// Share of merges (the rest are connections) in the density-estimation move.
    #[arg(long, default_value_t = 0.5)]
    pub merge_share: f64,
    /// Merge radius, as a fraction of the scene's bounding-sphere radius (the merge density's
    /// bias grows with it).
    #[arg(long, default_value_t = 0.005)]
    pub merge_radius: f64,
    /// Light subpaths in the light-vertex map (rebuilt every round).
    #[arg(long, default_value_t = 20_000)]
    pub merge_light_paths: usize,
    /// A merge chooses among at most this many stored vertices (lookups finding more are
    /// counted in the summary: they bias the merge density).
    #[arg(long, default_value_t = 4)]
    pub merge_cap: usize,
    /// Combine merges and connections by eq. 28 (each its own density) instead of eq. 29.
    #[arg(long)]
    pub merge_per_component: bool,
}

impl CmltArgs {
    /// CMLT on `scene` (runs the technique-energy pilot).
    pub fn cmlt(&self, scene: &Scene, c: &Common, a: &AlgoArgs) -> Result<Cmlt, CliError> {
        let m = &a.metropolis;
        let settings = CmltSettings {
            max_edges: c.max_edges,
            min_edges: 1,
            importance: m.importance(),
            small_step: m.small_step(),
            large_step: m.large_step,
            swaps: match self.swaps {
                Swaps::Serial => SwapKind::SerialTempering,
                Swaps::Replica => SwapKind::ReplicaExchange,
            },
            swap_every: self.swap_every,
            ipsm: self.ipsm,
            pathspace: self.pathspace,
            mutations: a.pathspace.mutations(c, m, &a.pathspace.mutations)?,
            pilot: self.cmlt_pilot,
            density_estimation: DensityEstimation {
                probability: self.density_estimation,
                merge_share: self.merge_share,
                radius: self.merge_radius,
                light_paths: self.merge_light_paths,
                cap: self.merge_cap,
                rule: if self.merge_per_component {
                    IndependenceRule::PerComponent
                } else {
                    IndependenceRule::Expected
                },
                ..DensityEstimation::default()
            },
        };
        Ok(Cmlt::new(scene, settings)?)
    }
}
