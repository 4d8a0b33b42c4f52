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
}

impl Algo {
    /// Short name.
    pub fn name(&self) -> &'static str {
        match self {
            Algo::Pt => "pt",
            Algo::Lt => "lt",
            Algo::Bdpt => "bdpt",
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
