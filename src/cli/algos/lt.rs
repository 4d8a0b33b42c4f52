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
    passes: true,
    build: |_, c, _| {
        Ok(Box::new(Passes {
            sampler: c.pass_sampler(),
            ..Passes::new(LightTracer {
                walk: WalkSettings {
                    max_edges: c.max_edges,
                },
            })
        }))
    },
};
