//! Photon mapping (Jensen 2001) and Metropolis photon sampling (Fan, Chenney & Lai 2005).
//!
//! * [`map`] — photons in a k-d tree and the density estimate of reflected radiance;
//! * [`trace`] — photon tracing from the lights into a global and a caustic map.
//!
//! Built so far: the photon map, its radiance estimate and photon tracing. Not yet: the final
//! gather, standard photon mapping (`--algo pm`) and Metropolis photon sampling (`--algo mps`).

pub mod map;
pub mod trace;

pub use map::{Lookup, Photon, PhotonMap};
pub use trace::trace_photons;
