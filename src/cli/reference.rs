//! `charted reference`: a long unbiased render to compare against (BDPT by default).

use super::CliError;
use super::algo::Algo;
use super::duration::parse_duration;
use super::render::{self, Heuristic, RenderArgs};
use super::scene_arg::parse_resolution;
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
    #[arg(long, value_enum, default_value_t = Algo::Bdpt)]
    pub algo: Algo,
    /// Samples per pixel (default 1024 when no --time is given).
    #[arg(long, conflicts_with = "time")]
    pub spp: Option<u64>,
    /// Wall-clock budget.
    #[arg(long, value_parser = parse_duration)]
    pub time: Option<Duration>,
    /// Output. Default: `out/<scene>-reference.exr`.
    #[arg(short = 'o', long)]
    pub output: Option<PathBuf>,
    /// Maximum number of bounces.
    #[arg(long, default_value_t = 8)]
    pub max_depth: usize,
    /// Override the image size.
    #[arg(long, value_parser = parse_resolution)]
    pub resolution: Option<(usize, usize)>,
    /// Master seed.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
}

pub fn run(a: ReferenceArgs) -> Result<(), CliError> {
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
        seed: a.seed,
        max_depth: a.max_depth,
        resolution: a.resolution,
        exposure: 0.0,
        mis: Heuristic::Power,
        write_every: Duration::from_secs(60),
        threads: None,
        quiet: false,
    })
}
