//! Charted Metropolis light transport in the renderer (charted-MLT paper §5–6): the bidirectional
//! techniques as [`mcmc_charts`] charts with exact path inversion, and density estimation as an
//! independence sampler in those charts (§5.3).

pub mod density_estimation;
pub mod integrator;
pub mod light_vertex_map;
pub mod replica;
pub mod technique;

pub use density_estimation::{DensityEstimation, LightVertices, MergeCounters, MergeSampler};
pub use integrator::{
    Cmlt, CmltKernel, CmltMove, CmltSettings, CmltState, LARGE_STEP, SwapKind, TechniqueAtlas,
    TechniqueJoint, TechniqueTarget, UnitIntegrand,
};
pub use light_vertex_map::LightVertexMap;
pub use technique::{
    TechniqueChart, camera_numbers, light_numbers, technique_charts, unit_integrand,
};
