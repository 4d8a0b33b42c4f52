//! Loader of the **pbrt-v3 scene format** (and pbrt-v4 spellings where cheap) into a
//! [`SceneDescription`].
//!
//! Supported: `Camera "perspective"`, `Film "image"`, every transform directive (`Identity`,
//! `Translate`, `Rotate`, `Scale`, `LookAt`, `Transform`, `ConcatTransform`, `CoordinateSystem`,
//! `CoordSysTransform`), `TransformBegin/End`, `AttributeBegin/End`, `ReverseOrientation`,
//! `WorldBegin/End`, `Include` (relative to the including file; cycles are errors),
//! `Material`/`MakeNamedMaterial`/`NamedMaterial` (see [`materials`]), `Texture` (see
//! `textures.rs`), `Shape "trianglemesh"|"plymesh"|"sphere"` (see `shapes.rs`, [`ply`]),
//! `AreaLightSource "diffuse"`, `LightSource "point"|"infinite"` (see `lights.rs`).
//!
//! Directives that only choose pbrt's machinery (`Integrator`, `Sampler`, `PixelFilter`,
//! `Accelerator`, …) are recorded in [`SceneDescription::ignored`]. Everything else — unknown
//! directives, types or parameters, a parameter the chosen type would not use, spectral values,
//! malformed numbers, wrong array lengths, missing files — is an [`Error::Scene`] naming the file
//! and the line. Relative file names (`Include`, PLY meshes, images) resolve against the directory
//! of the file that names them.
//!
//! ```no_run
//! let scene = light_transport::scene::pbrt::load(std::path::Path::new("scene.pbrt"))?;
//! println!("{} meshes, {} warnings", scene.meshes.len(), scene.warnings.len());
//! # Ok::<(), light_transport::Error>(())
//! ```

mod camera;
mod lights;
pub mod materials;
mod params;
mod parser;
pub mod ply;
mod shapes;
mod state;
mod textures;
mod tokenizer;
mod transform;

pub use camera::MAX_RESOLUTION;
pub use materials::{roughness_to_alpha_v3, roughness_to_alpha_v4};

use crate::error::{Error, Result};
use crate::scene::description::SceneDescription;
use std::path::Path;

/// Load a pbrt scene file.
pub fn load(path: &Path) -> Result<SceneDescription> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let text = tokenizer::text_of(bytes);
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let key = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    parser::Loader::new(text, path.to_path_buf(), dir, key).run()
}

/// Load a scene from text; `name` is the file name used in messages and relative names resolve
/// against `base_dir`.
pub fn load_str(text: &str, base_dir: &Path, name: &str) -> Result<SceneDescription> {
    let lexical = base_dir.join(name);
    let key = std::fs::canonicalize(&lexical).unwrap_or(lexical);
    parser::Loader::new(text.to_string(), name.into(), base_dir.to_path_buf(), key).run()
}
