//! Charted Metropolis light transport in the renderer (charted-MLT paper §5–6): the bidirectional
//! techniques as [`mcmc_charts`] charts with exact path inversion.

pub mod integrator;
pub mod replica;
pub mod technique;

pub use integrator::{
    Cmlt, CmltKernel, CmltMove, CmltSettings, CmltState, SwapKind, TechniqueAtlas, TechniqueJoint,
    TechniqueTarget, UnitIntegrand,
};
pub use technique::{
    TechniqueChart, camera_numbers, light_numbers, technique_charts, unit_integrand,
};
