//! The multi-chain perturbation (Veach & Guibas 1997, §5.3.3): the lens perturbation continued
//! through further specular chains — at each non-specular vertex followed by a specular one, the
//! direction toward the next chain turns by an angular offset — until two non-specular vertices
//! meet. Densities in [`super::perturbation`].

use super::lens::CameraSidePerturbation;
use super::mutation::Registration;
use super::perturbation::CameraSide;

/// The registration of the multi-chain perturbation.
pub const REGISTRATION: Registration = Registration {
    name: "multi-chain",
    default_weight: 0.15,
    build: |c| Box::new(CameraSidePerturbation::new(c, CameraSide::MultiChain)),
};
