//! Scenes: the description model, loaders, built-in scenes, and the renderable scene.

pub mod description;
pub mod pbrt;

pub use description::*;
