//! Errors a user can meet: bad scene files, bad parameters, I/O.

use std::path::PathBuf;
use thiserror::Error;

/// Where in a scene file something was written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Location {
    /// The file.
    pub file: PathBuf,
    /// 1-based line.
    pub line: usize,
}

impl std::fmt::Display for Location {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.file.display(), self.line)
    }
}

/// Errors of scene loading and rendering.
#[derive(Debug, Error)]
pub enum Error {
    /// A scene file is malformed or asks for something unsupported.
    #[error("{location}: {message}")]
    Scene {
        /// Where.
        location: Location,
        /// What.
        message: String,
    },
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A scene is invalid as a whole (no camera, no light, …).
    #[error("invalid scene: {0}")]
    InvalidScene(String),
    /// No bootstrap path of a Metropolis method carried light.
    #[error(
        "invalid scene: no light reached the camera in {paths} bootstrap paths: nothing to render (raise --bootstrap, or check the lights)"
    )]
    NoLight {
        /// Bootstrap paths tried.
        paths: usize,
    },
    /// A user-given parameter is out of range.
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter {
        /// Its name.
        name: String,
        /// Why.
        reason: String,
    },
    /// An image could not be written or read.
    #[error("image {path}: {message}")]
    Image {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

impl Error {
    /// A scene-file error at `location`.
    pub fn scene(location: &Location, message: impl Into<String>) -> Self {
        Error::Scene {
            location: location.clone(),
            message: message.into(),
        }
    }
}

/// Result with [`enum@Error`].
pub type Result<T> = std::result::Result<T, Error>;
