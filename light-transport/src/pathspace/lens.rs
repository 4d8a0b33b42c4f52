//! The lens perturbation (Veach & Guibas 1997, §5.3.3; practical-MLT paper §3.4): move the image
//! position of a path `(L|D) D S* E` by a pixel offset exponentially distributed between `r1` and
//! `r2`, follow the eye's specular chain, and reconnect the first non-specular vertex to the kept
//! rest. Densities in [`super::perturbation`].

use super::mutation::{Change, Mutation, Registration};
use super::perturbation::{
    CameraSide, PerturbationSettings, camera_chain_of, camera_side_density, camera_side_propose,
};
use super::state::PathState;
use crate::metropolis::ImportanceKind;
use crate::scene::Scene;
use mcmc_core::{ChainRng, Failure};

/// The registration of the lens perturbation.
pub const REGISTRATION: Registration = Registration {
    name: "lens",
    default_weight: 0.2,
    build: |c| Box::new(CameraSidePerturbation::new(c, CameraSide::Lens)),
};

/// A camera-side perturbation on a scene (also the multi-chain perturbation's).
pub(super) struct CameraSidePerturbation<'a> {
    scene: &'a Scene,
    which: CameraSide,
    settings: PerturbationSettings,
    importance: ImportanceKind,
}

impl<'a> CameraSidePerturbation<'a> {
    pub(super) fn new(c: &super::mutation::MutationContext<'a, '_>, which: CameraSide) -> Self {
        Self {
            scene: c.scene,
            which,
            settings: c.settings.perturbation,
            importance: c.settings.importance,
        }
    }
}

impl Mutation for CameraSidePerturbation<'_> {
    fn name(&self) -> &'static str {
        match self.which {
            CameraSide::Lens => REGISTRATION.name,
            CameraSide::MultiChain => super::multi_chain::REGISTRATION.name,
        }
    }

    fn suitability(&self, x: &PathState) -> f64 {
        camera_chain_of(self.scene, self.which, x).is_some() as u8 as f64
    }

    fn propose(&self, x: &PathState, rng: &mut ChainRng, y: &mut PathState) -> Result<(), Failure> {
        camera_side_propose(
            self.scene,
            self.which,
            &self.settings,
            self.importance,
            x,
            rng,
            y,
        )
    }

    fn ln_density(&self, x: &PathState, y: &PathState, change: Change) -> f64 {
        camera_side_density(self.scene, self.which, &self.settings, x, y, change)
    }
}
