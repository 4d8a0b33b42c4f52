//! Path tracing.

use super::bdpt::{shadow_note, shadow_roulette};
use crate::cli::registry::Entry;
use light_transport::integrators::PathTracer;
use light_transport::renderer::Passes;

/// Path tracing with next-event estimation and MIS.
pub const ENTRY: Entry = Entry {
    name: "pt",
    about: "Path tracing with next-event estimation and MIS",
    unbiased: true,
    passes: true,
    build: |scene, c, a| {
        let mut pt = PathTracer {
            max_edges: c.max_edges,
            heuristic: c.heuristic,
            ..PathTracer::default()
        };
        pt.shadow_roulette = shadow_roulette(&a.bdpt, scene, &pt)?;
        Ok(Box::new(Passes {
            sampler: c.pass_sampler(),
            estimator: pt,
            details: |pt, _| shadow_note(pt.shadow_roulette),
        }))
    },
};
