//! Light tracing.

use crate::cli::registry::Entry;
use light_transport::integrators::LightTracer;
use light_transport::path::WalkSettings;
use light_transport::renderer::Passes;

/// Light tracing.
pub const ENTRY: Entry = Entry {
    name: "lt",
    about: "Light tracing (splats from light subpaths)",
    unbiased: true,
    build: |_, c, _| {
        Ok(Box::new(Passes::new(LightTracer {
            walk: WalkSettings {
                max_edges: c.max_edges,
            },
        })))
    },
};
