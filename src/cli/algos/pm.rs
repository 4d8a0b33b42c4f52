//! Standard photon mapping with a final gather.

use crate::cli::CliError;
use crate::cli::registry::Entry;
use clap::Args;
use light_transport::photon::{PhotonMapper, PhotonMapping};
use light_transport::renderer::Passes;

/// Options of photon mapping (pm).
#[derive(Args, Debug, Clone)]
pub struct PmArgs {
    /// Photon mapping: light subpaths traced for the global map.
    #[arg(long, default_value_t = 200_000)]
    pub global_photons: u64,
    /// Photon mapping: light subpaths traced for the caustic map (their caustic photons are kept).
    #[arg(long, default_value_t = 200_000)]
    pub caustic_photons: u64,
    /// Photon mapping: final-gather rays per pixel sample.
    #[arg(long, default_value_t = 16)]
    pub gather_rays: usize,
    /// Photon mapping: photons per radiance estimate (the paper's n).
    #[arg(long, default_value_t = 60)]
    pub photon_k: usize,
    /// Photon mapping: largest lookup radius of the global map, as a fraction of the scene's
    /// bounding-sphere radius.
    #[arg(long, default_value_t = 0.05)]
    pub global_radius: f64,
    /// Photon mapping: largest lookup radius of the caustic map, same units.
    #[arg(long, default_value_t = 0.0125)]
    pub caustic_radius: f64,
}

/// Photon mapping (Jensen 2001) with the storage convention of Fan et al. 2005.
pub const ENTRY: Entry = Entry {
    name: "pm",
    about: "Photon mapping (Jensen): global and caustic maps, final gather with MIS direct light",
    unbiased: false,
    build: |scene, c, a| {
        let p = &a.pm;
        let settings = PhotonMapping {
            global_paths: p.global_photons,
            caustic_paths: p.caustic_photons,
            gather_rays: p.gather_rays,
            k: p.photon_k,
            global_radius: p.global_radius,
            caustic_radius: p.caustic_radius,
            ..PhotonMapping::new(c.max_edges)
        };
        let mapper = PhotonMapper::new(scene, settings).map_err(|e| {
            CliError::Render(light_transport::Error::InvalidParameter {
                name: "pm".into(),
                reason: e.to_string(),
            })
        })?;
        Ok(Box::new(Passes {
            estimator: mapper,
            details: PhotonMapper::summary,
        }))
    },
};
