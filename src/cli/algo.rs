//! The algorithms the CLI can run, and how each is built from the common options.

use clap::ValueEnum;
use light_transport::integrators::{Bdpt, LightTracer, PathTracer};
use light_transport::path::{MisHeuristic, WalkSettings};

/// A rendering algorithm.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Algo {
    /// Path tracing with next-event estimation and MIS.
    Pt,
    /// Light tracing (splats from light subpaths).
    Lt,
    /// Bidirectional path tracing, all strategies, MIS.
    Bdpt,
    /// Primary-sample-space MLT (Kelemen) on BDPT with all connections.
    Pssmlt,
    /// Multiplexed MLT (Hachisuka et al.): one strategy per sample, chains per path length.
    Mmlt,
    /// Path-space MLT (Veach & Guibas): bidirectional, lens-subpath, perturbation and new-path
    /// mutations.
    Mlt,
    /// Energy redistribution path tracing (Cline et al.): short perturbation chains from
    /// path-traced seeds.
    Erpt,
    /// Charted MLT: technique charts with path inversion, chart swaps by serial tempering or replica exchange (--swaps).
    Cmlt,
}

impl Algo {
    /// Short name.
    pub fn name(&self) -> &'static str {
        match self {
            Algo::Pt => "pt",
            Algo::Lt => "lt",
            Algo::Bdpt => "bdpt",
            Algo::Pssmlt => "pssmlt",
            Algo::Mmlt => "mmlt",
            Algo::Mlt => "mlt",
            Algo::Erpt => "erpt",
            Algo::Cmlt => "cmlt",
        }
    }
}

/// Options every rendering command shares.
#[derive(clap::Args, Debug, Clone)]
pub struct RenderOptions {
    /// Master seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Maximum number of bounces (pbrt's maxdepth; paths have at most maxdepth + 1 edges).
    #[arg(long, default_value_t = 8)]
    pub max_depth: usize,
    /// Override the image size, e.g. 320x240.
    #[arg(long, value_parser = super::scene_arg::parse_resolution)]
    pub resolution: Option<(usize, usize)>,
    /// PNG exposure in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f64,
    /// MIS heuristic.
    #[arg(long, value_enum, default_value_t = super::render::Heuristic::Power)]
    pub mis: super::render::Heuristic,
}

impl RenderOptions {
    /// The integrator options they imply.
    pub fn common(&self) -> Common {
        Common {
            max_edges: self.max_depth + 1,
            heuristic: self.mis.into(),
        }
    }
}

/// Options shared by the unbiased integrators.
#[derive(Clone, Copy, Debug)]
pub struct Common {
    /// Maximum path length in edges.
    pub max_edges: usize,
    /// MIS heuristic.
    pub heuristic: MisHeuristic,
}

pub fn path_tracer(c: &Common) -> PathTracer {
    PathTracer {
        max_edges: c.max_edges,
        heuristic: c.heuristic,
        roulette_after: None,
    }
}

pub fn light_tracer(c: &Common) -> LightTracer {
    LightTracer {
        walk: WalkSettings {
            max_edges: c.max_edges,
        },
    }
}

pub fn bdpt(c: &Common) -> Bdpt {
    Bdpt {
        walk: WalkSettings {
            max_edges: c.max_edges,
        },
        heuristic: c.heuristic,
    }
}

pub fn pssmlt(
    c: &Common,
    m: &super::metropolis::MetropolisArgs,
) -> Result<light_transport::metropolis::Pssmlt, super::CliError> {
    Ok(light_transport::metropolis::Pssmlt {
        bdpt: bdpt(c),
        kelemen: m.kelemen()?,
        importance: m.importance(),
    })
}

pub fn mmlt(
    c: &Common,
    m: &super::metropolis::MetropolisArgs,
) -> Result<light_transport::metropolis::Mmlt, super::CliError> {
    Ok(light_transport::metropolis::Mmlt {
        walk: WalkSettings {
            max_edges: c.max_edges,
        },
        heuristic: c.heuristic,
        kelemen: m.kelemen()?,
        importance: m.importance(),
    })
}
