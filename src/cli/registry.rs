//! The integrator registry: every algorithm the command line can run, with a one-line
//! description, whether it is unbiased, and how it is built from the options. `render`,
//! `compare` and `reference` dispatch through it and run what it builds as a
//! [`light_transport::renderer::Renderer`]. Adding an algorithm is one file in `algos/` and one
//! line in [`ALGORITHMS`] (and, when it has options of its own, one flattened group in
//! [`AlgoArgs`]).

use super::CliError;
use super::algos;
use clap::Args;
use clap::builder::{PossibleValuesParser, TypedValueParser};
use light_transport::path::MisHeuristic;
use light_transport::renderer::Renderer;
use light_transport::sampler::PixelSampler;
use light_transport::scene::Scene;

/// How an algorithm is built on a scene from the options.
pub type Build = fn(&Scene, &Common, &AlgoArgs) -> Result<Box<dyn Renderer>, CliError>;

/// A registered algorithm.
pub struct Entry {
    /// Name on the command line.
    pub name: &'static str,
    /// What it is.
    pub about: &'static str,
    /// Whether it is an unbiased estimator (usable for references).
    pub unbiased: bool,
    /// Whether it runs in passes of one sample per pixel (and so takes `--sampler`).
    pub passes: bool,
    /// Build it on a scene from the options.
    pub build: Build,
}

impl std::fmt::Debug for Entry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name)
    }
}

/// Every algorithm, in the order of `--help`.
pub const ALGORITHMS: &[Entry] = &[
    algos::pt::ENTRY,
    algos::lt::ENTRY,
    algos::bdpt::ENTRY,
    algos::pssmlt::ENTRY,
    algos::mmlt::ENTRY,
    algos::mlt::ENTRY,
    algos::erpt::ENTRY,
    algos::memlt::ENTRY,
    algos::mept::ENTRY,
    algos::cmlt::ENTRY,
    algos::pm::ENTRY,
    algos::mps::ENTRY,
];

/// The algorithm called `name`.
pub fn find(name: &str) -> Option<&'static Entry> {
    ALGORITHMS.iter().find(|e| e.name == name)
}

/// A clap parser of algorithm names (its help lists them).
pub fn algo_parser() -> impl TypedValueParser<Value = &'static Entry> {
    PossibleValuesParser::new(
        ALGORITHMS
            .iter()
            .map(|e| clap::builder::PossibleValue::new(e.name).help(e.about)),
    )
    .map(|s| find(&s).unwrap_or(&ALGORITHMS[0]))
}

/// Options every algorithm shares.
#[derive(Clone, Copy, Debug)]
pub struct Common {
    /// Maximum path length in edges.
    pub max_edges: usize,
    /// MIS heuristic.
    pub heuristic: MisHeuristic,
    /// The sampler asked for (pass-based algorithms only; `None`: their default).
    pub sampler: Option<PixelSampler>,
}

impl Common {
    /// The sampler of a pass-based algorithm.
    pub fn pass_sampler(&self) -> PixelSampler {
        self.sampler.unwrap_or_default()
    }
}

/// Build `entry` on `scene`: its own constructor, after refusing options it does not take.
pub fn build(
    entry: &Entry,
    scene: &Scene,
    common: &Common,
    args: &AlgoArgs,
) -> Result<Box<dyn Renderer>, CliError> {
    if common.sampler.is_some() && !entry.passes {
        let passes: Vec<&str> = ALGORITHMS
            .iter()
            .filter(|e| e.passes)
            .map(|e| e.name)
            .collect();
        return Err(CliError::Usage(format!(
            "--sampler applies to the algorithms that render in passes ({}), not to {}",
            passes.join(", "),
            entry.name
        )));
    }
    (entry.build)(scene, common, args)
}

/// The option groups of the algorithms (each algorithm reads the ones it uses).
#[derive(Args, Debug, Clone)]
pub struct AlgoArgs {
    /// BDPT options (bdpt).
    #[command(flatten)]
    pub bdpt: algos::bdpt::BdptArgs,
    /// Metropolis options (pssmlt, mmlt, mlt, cmlt).
    #[command(flatten)]
    pub metropolis: super::metropolis::MetropolisArgs,
    /// Path-space options (mlt, erpt, cmlt's path-space moves).
    #[command(flatten)]
    pub pathspace: super::pathspace::PathSpaceArgs,
    /// Charted MLT options (cmlt).
    #[command(flatten)]
    pub cmlt: algos::cmlt::CmltArgs,
    /// Photon mapping options (pm).
    #[command(flatten)]
    pub pm: algos::pm::PmArgs,
    /// Metropolis photon sampling options (mps).
    #[command(flatten)]
    pub mps: algos::mps::MpsArgs,
}

impl AlgoArgs {
    /// The documented defaults (parsed from an empty command line, so they cannot drift).
    pub fn default_values() -> Self {
        #[derive(clap::Parser)]
        struct Wrapper {
            #[command(flatten)]
            a: AlgoArgs,
        }
        <Wrapper as clap::Parser>::parse_from(["charted"]).a
    }
}
