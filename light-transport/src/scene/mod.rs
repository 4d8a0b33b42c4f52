//! Scenes: the description model, loaders, built-in scenes, and the renderable scene.

mod build;
pub mod builtin;
pub mod description;
pub mod pbrt;
pub mod photon_scenes;

pub use build::{NONE, Scene, validate_resolution};
pub use description::*;
