//! Bidirectional path tracing.

use crate::cli::registry::{Common, Entry};
use clap::Args;
use light_transport::integrators::Bdpt;
use light_transport::path::{Roulette, WalkSettings};
use light_transport::renderer::Passes;

/// Options of bidirectional path tracing (bdpt).
#[derive(Args, Debug, Clone)]
pub struct BdptArgs {
    /// BDPT and PSSMLT: Russian roulette in both subpath walks from this vertex on (1 = the
    /// first surface vertex; 0 = off, every walk runs to --max-depth).
    #[arg(long, default_value_t = 0)]
    pub roulette: usize,
}

/// Bidirectional path tracing.
pub const ENTRY: Entry = Entry {
    name: "bdpt",
    about: "Bidirectional path tracing, all strategies, MIS",
    unbiased: true,
    build: |_, c, a| {
        let mut b = bdpt(c);
        b.roulette = roulette(&a.bdpt);
        Ok(Box::new(Passes::new(b)))
    },
};

/// The roulette of `--roulette` (`None` for 0).
pub fn roulette(a: &BdptArgs) -> Option<Roulette> {
    (a.roulette > 0).then_some(Roulette { from: a.roulette })
}

/// BDPT with the common options (also the evaluator of PSSMLT), without roulette.
pub fn bdpt(c: &Common) -> Bdpt {
    Bdpt {
        walk: WalkSettings {
            max_edges: c.max_edges,
        },
        heuristic: c.heuristic,
        roulette: None,
    }
}
