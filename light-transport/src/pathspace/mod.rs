//! Path-space Metropolis light transport (Veach & Guibas 1997; overview paper §5.3; practical-MLT
//! paper §3) and energy redistribution path tracing (Cline, Talbot & Egbert 2005).
//!
//! The chain state is a full path of vertices ([`FullPath`]) with the importance of each
//! bidirectional strategy that could have produced it ([`PathState`]). Every move implements one
//! interface, [`Mutation`]: suitability for a path, a proposal that records which vertices it
//! changed ([`Change`]), and the density of making a given change in one common measure, built
//! from ratios `C*_s = f/p_s` of bidirectional strategies (plus branch probabilities and offset
//! densities), so paths with specular vertices — which have no density with respect to area
//! measure — are handled exactly. The mutations run as `mcmc_core` proposals in a mixture with
//! either transition rule ([`mutations`]).
//!
//! Files: [`path`] (the path and its strategies), [`state`] (chain state), [`walk`] (tracing and
//! offsets), [`mutation`] (the interface), [`mutations`] (the registry and the mixture), one file
//! per mutation ([`bidirectional`], [`lens_subpath`], [`lens`], [`caustic`], [`multi_chain`],
//! [`new_path`], [`manifold_perturbation`]; [`perturbation`] holds what the perturbations share), [`mlt`] (the integrator on
//! the shared driver), [`erpt`] (energy redistribution).

pub mod bidirectional;
pub mod caustic;
pub mod erpt;
pub mod lambda_tuning;
pub mod lens;
pub mod lens_subpath;
pub mod manifold_perturbation;
pub mod mlt;
pub mod multi_chain;
pub mod mutation;
pub mod mutations;
pub mod new_path;
pub mod normal_change;
pub mod path;
pub mod perturbation;
pub mod photon_map_proposal;
pub mod state;
pub mod user_path;
pub mod walk;

pub use bidirectional::{Bidirectional, Deletion};
pub use erpt::{Erpt, ErptSettings};
pub use manifold_perturbation::{
    ManifoldDefect, ManifoldPerturbation, ManifoldPerturbationSettings, Toward,
};
pub use mlt::PathMlt;
pub use mutation::{Change, Mutation, MutationContext, MutationProposal, Registration};
pub use mutations::{
    MutationProbabilities, MutationSettings, Mutations, PhotonProposals, REGISTRY, UserPathRule,
};
pub use new_path::NewPath;
pub use path::{FullPath, Resume, Traced, Walks};
pub use perturbation::PerturbationSettings;
pub use photon_map_proposal::PhotonMapProposal;
pub use state::PathState;
pub use user_path::{UserPath, UserPathError, UserPathProposal, UserPaths};
