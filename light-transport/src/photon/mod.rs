//! Photon mapping (Jensen 2001) and Metropolis photon sampling (Fan, Chenney & Lai 2005).
//!
//! * [`map`] — photons in a k-d tree and the density estimate of reflected radiance.
//!
//! Built so far: the photon map and its radiance estimate. Not yet: photon tracing, the final
//! gather, standard photon mapping (`--algo pm`) and Metropolis photon sampling (`--algo mps`).

pub mod map;

pub use map::{Lookup, Photon, PhotonMap};
