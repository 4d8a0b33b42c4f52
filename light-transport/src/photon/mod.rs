//! Photon mapping (Jensen 2001) and Metropolis photon sampling (Fan, Chenney & Lai 2005).
//!
//! * [`map`] — photons in a k-d tree and the density estimate of reflected radiance;
//! * [`trace`] — photon tracing from the lights into a global and a caustic map;
//! * [`mapper`] — standard photon mapping with a final gather (`--algo pm`).
//!
//! Built so far: the photon map, its radiance estimate, photon tracing and standard photon mapping.
//! Not yet: Metropolis photon sampling (`--algo mps`).

pub mod map;
pub mod mapper;
pub mod trace;

pub use map::{Lookup, Photon, PhotonMap};
pub use mapper::{PhotonMapper, PhotonMapping};
pub use trace::trace_photons;
