//! Bidirectional path tracing.

use crate::cli::registry::{Common, Entry};
use light_transport::integrators::Bdpt;
use light_transport::path::WalkSettings;
use light_transport::renderer::Passes;

/// Bidirectional path tracing.
pub const ENTRY: Entry = Entry {
    name: "bdpt",
    about: "Bidirectional path tracing, all strategies, MIS",
    unbiased: true,
    build: |_, c, _| Ok(Box::new(Passes::new(bdpt(c)))),
};

/// BDPT with the common options (also the evaluator of PSSMLT).
pub fn bdpt(c: &Common) -> Bdpt {
    Bdpt {
        walk: WalkSettings {
            max_edges: c.max_edges,
        },
        heuristic: c.heuristic,
    }
}
