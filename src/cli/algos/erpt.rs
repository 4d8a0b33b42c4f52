//! Energy redistribution path tracing.

use crate::cli::registry::Entry;
use light_transport::pathspace::ErptSettings;

/// ERPT (Cline, Talbot & Egbert 2005).
pub const ENTRY: Entry = Entry {
    name: "erpt",
    about: "Energy redistribution path tracing (Cline et al.): short perturbation chains from path-traced seeds",
    unbiased: true,
    passes: true,
    build: |scene, c, a| {
        let p = &a.pathspace;
        let mut settings = ErptSettings::new(c.max_edges);
        settings.mutations = p.mutations(c, &a.metropolis, &p.erpt_mutations)?;
        settings.chain_length = p.erpt_chain_length;
        settings.chains_per_seed = p.erpt_chains;
        settings.max_chains = p.erpt_max_chains;
        a.metropolis
            .erpt_renderer(scene, settings, c.pass_sampler(), c.heuristic)
    },
};
