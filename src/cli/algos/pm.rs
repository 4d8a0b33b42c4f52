//! Standard photon mapping with a final gather.

use crate::cli::CliError;
use crate::cli::registry::Entry;
use clap::Args;
use light_transport::photon::{MaxRadius, PhotonMapper, PhotonMapping};
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
    /// Photon mapping: a fixed largest lookup radius for the global map, as a fraction of the
    /// scene's bounding-sphere radius (Mitsuba 0.6 uses 0.05) [default: from the map's photon
    /// density, see --radius-alpha].
    #[arg(long)]
    pub global_radius: Option<f64>,
    /// Photon mapping: a fixed largest lookup radius for the caustic map, same units (Mitsuba 0.6
    /// uses 0.0125) [default: from the map's photon density].
    #[arg(long)]
    pub caustic_radius: Option<f64>,
    /// Photon mapping: the largest lookup radius of a map without a fixed one is
    /// √(k / (π α ρ̃)), ρ̃ its typical photon density: estimates stop growing where the map is
    /// sparser than α times that (the paper's α = 0.1).
    #[arg(long, default_value_t = 0.1)]
    pub radius_alpha: f64,
}

impl PmArgs {
    /// The global and caustic maps' radius rules; `--radius-alpha` is checked even when both
    /// radii are fixed.
    pub fn radii(&self) -> Result<(MaxRadius, MaxRadius), CliError> {
        let alpha = self.radius_alpha;
        if !(alpha > 0.0 && alpha <= 1.0) {
            return Err(settings_error(format!(
                "--radius-alpha must be in (0, 1], got {alpha}"
            )));
        }
        let rule = |fixed: Option<f64>| match fixed {
            Some(f) => MaxRadius::Fraction(f),
            None => MaxRadius::Density { alpha },
        };
        Ok((rule(self.global_radius), rule(self.caustic_radius)))
    }
}

/// A photon-mapping settings error for the CLI.
pub fn settings_error(reason: String) -> CliError {
    CliError::Render(light_transport::Error::InvalidParameter {
        name: "pm".into(),
        reason,
    })
}

/// Photon mapping (Jensen 2001) with the storage convention of Fan et al. 2005.
pub const ENTRY: Entry = Entry {
    name: "pm",
    about: "Photon mapping (Jensen): global and caustic maps, final gather with MIS direct light",
    unbiased: false,
    passes: true,
    build: |scene, c, a| {
        let p = &a.pm;
        let (global_radius, caustic_radius) = p.radii()?;
        let settings = PhotonMapping {
            global_paths: p.global_photons,
            caustic_paths: p.caustic_photons,
            gather_rays: p.gather_rays,
            k: p.photon_k,
            global_radius,
            caustic_radius,
            ..PhotonMapping::new(c.max_edges)
        };
        let mapper =
            PhotonMapper::new(scene, settings).map_err(|e| settings_error(e.to_string()))?;
        Ok(Box::new(Passes {
            sampler: c.pass_sampler(),
            estimator: mapper,
            details: PhotonMapper::summary,
        }))
    },
};
