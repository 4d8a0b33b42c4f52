//! Manifold exploration MLT.

use crate::cli::registry::Entry;
use light_transport::pathspace::PathMlt;

/// MEMLT (Jakob & Marschner 2012): path-space MLT with the manifold perturbation in place of the
/// lens, caustic and multi-chain perturbations.
pub const ENTRY: Entry = Entry {
    name: "memlt",
    about: "Manifold exploration MLT (Jakob & Marschner): bidirectional, manifold perturbation and new-path mutations",
    unbiased: false,
    passes: false,
    build: |_, c, a| {
        let p = &a.pathspace;
        let mutations = p.mutations(c, &a.metropolis, &p.memlt_mutations)?;
        a.metropolis.renderer(
            PathMlt::new(mutations)?
                .with_large_step_mis(a.metropolis.large_step_mis.unwrap_or(false)),
            c.heuristic,
            c.max_edges,
        )
    },
};
