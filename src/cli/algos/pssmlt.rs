//! Primary-sample-space MLT.

use crate::cli::registry::Entry;
use light_transport::metropolis::{DIRECT_EDGES, Pssmlt, SeparateDirect};
use light_transport::renderer::Metropolis;

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
            large_step_mis: m.large_step_mis,
            direct_apart: false,
        };
        if m.direct_samples > 0 && c.max_edges > DIRECT_EDGES {
            return Ok(Box::new(SeparateDirect::new(
                method,
                m.settings(),
                c.heuristic,
                m.direct_samples,
                m.direct_share,
            )?));
        }
        Ok(Box::new(Metropolis {
            method,
            settings: m.settings(),
        }))
    },
};
