//! Command-line interface.

mod algos;
mod compare;
mod diff;
mod duration;
mod info;
pub mod interrupt;
mod memory;
mod metropolis;
mod options;
mod pathspace;
mod plot;
mod reference;
mod registry;
mod render;
mod run;
mod scene_arg;
mod shard;

use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// Errors of the command line.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// From the renderer.
    #[error(transparent)]
    Render(#[from] light_transport::Error),
    /// Bad arguments.
    #[error("{0}")]
    Usage(String),
    /// The render was interrupted (its work was written).
    #[error("interrupted (the work done so far was written)")]
    Interrupted,
    /// File system.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// Charted Metropolis light transport: a research renderer.
#[derive(Parser, Debug)]
#[command(name = "charted", version, about)]
pub struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene (a pbrt-v3 file or a built-in scene: cornell, caustic, door, ring, pool, pool-lamp, rooms, lantern, box).
    Render(render::RenderArgs),
    /// Render a long reference image with an unbiased algorithm (default: BDPT, 1024 spp).
    Reference(reference::ReferenceArgs),
    /// Render with several algorithms for the same time and compare their errors over time.
    Compare(compare::CompareArgs),
    /// Merge partial renders (shards) of one scene into one image with correct weights.
    Merge(shard::MergeArgs),
    /// Error metrics of an image against a reference, and an error image.
    Diff(diff::DiffArgs),
    /// Describe a scene: geometry, lights, materials, camera, what was ignored.
    Info(info::InfoArgs),
}

/// Run the command line.
pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        None => run(Cli::parse_from(["charted", "render"])),
        Some(Command::Render(a)) => render::run(a),
        Some(Command::Reference(a)) => reference::run(a),
        Some(Command::Compare(a)) => compare::run(a),
        Some(Command::Merge(a)) => shard::run(a),
        Some(Command::Diff(a)) => diff::run(a),
        Some(Command::Info(a)) => info::run(a),
    }
}
