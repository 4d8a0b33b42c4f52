//! Multiplexed MLT.

use crate::cli::registry::Entry;
use light_transport::metropolis::Mmlt;
use light_transport::path::WalkSettings;

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
            large_step_mis: m.large_step_mis.unwrap_or(true),
            direct_apart: false,
        };
        m.renderer(method, c.heuristic, c.max_edges)
    },
};
