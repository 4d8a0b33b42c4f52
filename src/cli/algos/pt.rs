//! Path tracing.

use crate::cli::registry::Entry;
use light_transport::integrators::PathTracer;
use light_transport::renderer::Passes;

/// Path tracing with next-event estimation and MIS.
pub const ENTRY: Entry = Entry {
    name: "pt",
    about: "Path tracing with next-event estimation and MIS",
    unbiased: true,
    build: |_, c, _| {
        Ok(Box::new(Passes::new(PathTracer {
            max_edges: c.max_edges,
            heuristic: c.heuristic,
            ..PathTracer::default()
        })))
    },
};
