//! Photon mapping (Jensen 2001) and Metropolis photon sampling (Fan, Chenney & Lai 2005).
//!
//! * [`map`] — photons in a k-d tree and the density estimate of reflected radiance;
//! * [`radius`] — the estimate's largest lookup radius `d_max`, from the map's photon density;
//! * [`trace`] — photon tracing from the lights into a global and a caustic map;
//! * [`mapper`] — standard photon mapping with a final gather (`--algo pm`);
//! * [`metropolis`] — Metropolis photon sampling (`--algo mps`): the maps filled from chains over
//!   complete light-to-eye paths, read by the same final gather.

pub mod map;
pub mod mapper;
pub mod metropolis;
pub mod radius;
pub mod trace;

pub use map::{Lookup, Photon, PhotonMap};
pub use mapper::{PhotonMapper, PhotonMapping};
pub use metropolis::{MpsDefect, MpsSettings, MpsStats, mps_mapper, sample_photons};
pub use radius::MaxRadius;
pub use trace::trace_photons;
