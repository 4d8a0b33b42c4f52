//! Manifold exploration path tracing.

use crate::cli::registry::Entry;
use light_transport::pathspace::ErptSettings;

/// MEPT (Jakob & Marschner 2012): energy redistribution path tracing with the manifold
/// perturbation in place of its perturbations.
pub const ENTRY: Entry = Entry {
    name: "mept",
    about: "Manifold exploration path tracing (Jakob & Marschner): ERPT chains of manifold perturbations",
    unbiased: true,
    passes: true,
    build: |scene, c, a| {
        let p = &a.pathspace;
        let mut settings = ErptSettings::new(c.max_edges);
        settings.mutations = p.mutations(c, &a.metropolis, &p.mept_mutations)?;
        settings.chain_length = p.erpt_chain_length;
        settings.chains_per_seed = p.erpt_chains;
        settings.max_chains = p.erpt_max_chains;
        a.metropolis
            .erpt_renderer(scene, settings, c.pass_sampler(), c.heuristic)
    },
};
