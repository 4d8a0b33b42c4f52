//! Path-space Metropolis light transport (Veach & Guibas 1997; overview paper §5.3; practical-MLT
//! paper §3) and energy redistribution path tracing (Cline, Talbot & Egbert 2005).
//!
//! The chain state is a full path of vertices ([`FullPath`]) with the importance of each
//! bidirectional strategy that could have produced it ([`PathState`]). Mutations
//! ([`MutationKind`]) propose a candidate and report the log of its acceptance ratio, which is
//! always built from ratios `C*_s = f/p_s` of one strategy (plus branch probabilities and offset
//! densities), so paths with specular vertices — which have no density with respect to area
//! measure — are handled exactly.
//!
//! Files: [`path`] (the path and its strategies), [`state`] (chain state), [`walk`] (tracing and
//! offsets), [`bidirectional`] (bidirectional and new-path mutations), [`lens_subpath`],
//! [`perturbation`] (lens, caustic, multi-chain), [`mutations`] (the mixture and one MH step),
//! [`mlt`] (the integrator on the shared driver), [`erpt`] (energy redistribution).

pub mod bidirectional;
pub mod erpt;
pub mod lens_subpath;
pub mod mlt;
pub mod mutations;
pub mod path;
pub mod perturbation;
pub mod state;
pub mod walk;

pub use bidirectional::{Bidirectional, Deletion, NewPath};
pub use erpt::{Erpt, ErptSettings};
pub use mlt::PathMlt;
pub use mutations::{MutationKind, MutationProbabilities, Mutations};
pub use path::{FullPath, Scratch};
pub use perturbation::PerturbationSettings;
pub use state::PathState;
