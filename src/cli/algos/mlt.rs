//! Path-space MLT.

use crate::cli::registry::Entry;
use light_transport::pathspace::PathMlt;

/// Path-space MLT (Veach & Guibas 1997).
pub const ENTRY: Entry = Entry {
    name: "mlt",
    about: "Path-space MLT (Veach & Guibas): bidirectional, lens-subpath, perturbation and new-path mutations",
    unbiased: false,
    passes: false,
    build: |_, c, a| {
        let mutations = a
            .pathspace
            .mutations(c, &a.metropolis, &a.pathspace.mutations)?;
        a.metropolis.renderer(
            PathMlt::new(mutations)?
                .with_large_step_mis(a.metropolis.large_step_mis.unwrap_or(false)),
            c.heuristic,
            c.max_edges,
        )
    },
};
