//! Primary-sample-space MLT.

use crate::cli::registry::Entry;
use light_transport::metropolis::Pssmlt;

/// PSSMLT (Kelemen et al. 2002) on BDPT with all connections.
pub const ENTRY: Entry = Entry {
    name: "pssmlt",
    about: "Primary-sample-space MLT (Kelemen) on BDPT with all connections",
    unbiased: false,
    passes: false,
    build: |_, c, a| {
        let m = &a.metropolis;
        let mut bdpt = super::bdpt::bdpt(c);
        bdpt.roulette = super::bdpt::roulette(&a.bdpt)?;
        let method = Pssmlt {
            bdpt,
            kelemen: m.kelemen()?,
            importance: m.importance(),
            large_step_mis: m.large_step_mis.unwrap_or(true),
            direct_apart: false,
        };
        m.renderer(method, c.heuristic, c.max_edges)
    },
};
