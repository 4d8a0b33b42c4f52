//! # light-transport
//!
//! Scenes, ray tracing, materials and path sampling for a research renderer whose Metropolis
//! integrators are built on `mcmc-core` and `mcmc-charts`.

pub mod accel;
pub mod bsdf;
pub mod budget;
pub mod camera;
pub mod cmlt;
pub mod error;
pub mod film;
pub mod geometry;
pub mod integrators;
pub mod light;
pub mod manifold;
pub mod math;
pub mod metropolis;
pub mod path;
pub mod pathspace;
pub mod photon;
pub mod renderer;
pub mod sampler;
pub mod scene;
pub mod spectrum;

pub use budget::Budget;
pub use error::{Error, Result};
pub use spectrum::Rgb;
