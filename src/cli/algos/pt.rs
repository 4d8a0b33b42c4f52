//! Path tracing.

use super::bdpt::{path_roulette, shadow_note, shadow_roulette};
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
            roulette_from: path_roulette(&a.bdpt)?,
            ..PathTracer::default()
        };
        pt.shadow_roulette = shadow_roulette(&a.bdpt, scene, &pt)?;
        Ok(Box::new(Passes {
            sampler: c.pass_sampler(),
            estimator: pt,
            details: |pt, _| {
                let mut notes: Vec<String> = pt
                    .roulette_from
                    .map(|from| format!("roulette   paths may stop from vertex {from} on"))
                    .into_iter()
                    .collect();
                notes.extend(shadow_note(pt.shadow_roulette));
                notes
            },
        }))
    },
};
