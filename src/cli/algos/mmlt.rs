//! Multiplexed MLT.

use crate::cli::registry::Entry;
use light_transport::metropolis::{DIRECT_EDGES, Mmlt, SeparateDirect};
use light_transport::path::WalkSettings;
use light_transport::renderer::Metropolis;

/// Multiplexed MLT (Hachisuka, Kaplanyan & Dachsbacher 2014).
pub const ENTRY: Entry = Entry {
    name: "mmlt",
    about: "Multiplexed MLT (Hachisuka et al.): one strategy per sample, chains per path length",
    unbiased: false,
    passes: false,
    build: |_, c, a| {
        let m = &a.metropolis;
        let method = Mmlt {
            walk: WalkSettings {
                max_edges: c.max_edges,
            },
            heuristic: c.heuristic,
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
