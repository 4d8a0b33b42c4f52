//! `charted reference`: a long unbiased render to compare against (BDPT by default).

use super::CliError;
use super::duration::parse_duration;
use super::options::RenderOptions;
use super::registry::{self, AlgoArgs, Entry};
use super::render::{self, RenderArgs};
use clap::Args;
use std::path::PathBuf;
use std::time::Duration;

/// Options of `reference`.
#[derive(Args, Debug)]
pub struct ReferenceArgs {
    /// Scene: a built-in name or a pbrt-v3 file.
    #[arg(default_value = "cornell")]
    pub scene: String,
    /// Unbiased algorithm.
    #[arg(long, value_parser = registry::algo_parser(), default_value = "bdpt")]
    pub algo: &'static Entry,
    /// Samples per pixel (default 1024 when no --time is given).
    #[arg(long, conflicts_with = "time")]
    pub spp: Option<u64>,
    /// Wall-clock budget.
    #[arg(long, value_parser = parse_duration)]
    pub time: Option<Duration>,
    /// Seed, depth, resolution, exposure, MIS.
    #[command(flatten)]
    pub options: RenderOptions,
    /// Output. Default: `out/<scene>-reference.exr`.
    #[arg(short = 'o', long)]
    pub output: Option<PathBuf>,
}

/// References use seed `S ^ REFERENCE_SEED` so that a reference never replays a render made with
/// the same `--seed` (which would show zero error).
pub const REFERENCE_SEED: u64 = 0x005e_ed0f_4ef0;

pub fn run(mut a: ReferenceArgs) -> Result<(), CliError> {
    if !a.algo.unbiased {
        return Err(CliError::Usage(format!(
            "{} is not an unbiased algorithm; references need one of {}",
            a.algo.name,
            registry::ALGORITHMS
                .iter()
                .filter(|e| e.unbiased)
                .map(|e| e.name)
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    a.options.seed ^= REFERENCE_SEED;
    let name = super::scene_arg::load(&a.scene)?.name;
    render::run(RenderArgs {
        output: Some(
            a.output
                .unwrap_or_else(|| PathBuf::from(format!("out/{name}-reference.exr"))),
        ),
        spp: if a.time.is_none() {
            Some(a.spp.unwrap_or(1024))
        } else {
            None
        },
        time: a.time,
        scene: a.scene,
        algo: a.algo,
        options: a.options,
        algos: AlgoArgs::default_values(),
        write_every: Duration::from_secs(60),
        threads: None,
        quiet: false,
    })
}
