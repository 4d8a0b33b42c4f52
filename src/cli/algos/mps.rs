//! Metropolis photon sampling (Fan, Chenney & Lai 2005): photon maps from Metropolis chains over
//! complete light-to-eye paths, read by photon mapping's final gather.

use crate::cli::CliError;
use crate::cli::registry::Entry;
use clap::Args;
use light_transport::pathspace::{MutationProbabilities, PathMlt, UserPaths};
use light_transport::photon::{MpsSettings, PhotonMapper, PhotonMapping, mps_mapper};
use light_transport::renderer::Passes;
use light_transport::{Budget, Error};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

fn parse_probabilities(s: &str) -> Result<MutationProbabilities, String> {
    s.parse().map_err(|e: Error| e.to_string())
}

/// Options of Metropolis photon sampling (mps); the final gather takes the pm options.
#[derive(Args, Debug, Clone)]
pub struct MpsArgs {
    /// Metropolis photon sampling: chain mutations per pixel that fill the maps.
    #[arg(long, default_value_t = 4.0)]
    pub photon_mutations: f64,
    /// Metropolis photon sampling: proposal probabilities, `name=p,...` (the paper's Lantern
    /// set; with --user-paths and no --mps-proposals, user-path=0.1 joins and bidirectional
    /// drops to 0.3, the paper's Box set).
    /// [default: bidirectional=0.4,photon-map=0.2,lens=0.2,lens-subpath=0.2]
    #[arg(long, value_parser = parse_probabilities)]
    pub mps_proposals: Option<MutationProbabilities>,
    /// Metropolis photon sampling: user paths (a text file of light-to-diffuse point lists; see
    /// `light_transport::pathspace::user_path`), sampled around by the user-path proposal.
    #[arg(long)]
    pub user_paths: Option<PathBuf>,
    /// Metropolis photon sampling: cone half-angle γ of the photon-map proposal (degrees).
    #[arg(long, default_value_t = 30.0)]
    pub photon_map_gamma: f64,
    /// Metropolis photon sampling: light-walk continuations from a photon's storage point that
    /// must reach the eye before its inverse continuation probability 1/A is estimated (N/r over
    /// the N drawn, unbiased; larger r, less variance, more rays).
    #[arg(long, default_value_t = 4)]
    pub continuations: u64,
    /// Metropolis photon sampling: most continuations drawn per photon (photons reaching it are
    /// counted; their power is biased low).
    #[arg(long, default_value_t = 10_000)]
    pub continuation_cap: u64,
}

/// Metropolis photon sampling.
pub const ENTRY: Entry = Entry {
    name: "mps",
    about: "Metropolis photon sampling (Fan, Chenney & Lai): photon maps from Metropolis light paths, user paths, final gather",
    unbiased: false,
    passes: true,
    build: |scene, c, a| {
        let p = &a.mps;
        let lantern = light_transport::photon::metropolis::proposals();
        let explicit = p.mps_proposals.is_some();
        let mut mutations = a.pathspace.mutations(c, &a.metropolis, &lantern)?;
        if let Some(given) = &p.mps_proposals {
            mutations.probabilities = given.clone();
        }
        mutations.photon.photon_map_gamma = p.photon_map_gamma.to_radians();
        if let Some(file) = &p.user_paths {
            let paths = UserPaths::load(file, scene).map_err(|e| {
                CliError::Render(Error::InvalidParameter {
                    name: "user paths".into(),
                    reason: e.to_string(),
                })
            })?;
            mutations.photon.user_paths = Arc::new(paths);
            if !explicit {
                mutations.probabilities =
                    light_transport::photon::metropolis::proposals_with_user_paths();
            }
        }
        mutations.validate()?;
        let pm = &a.pm;
        let (global_radius, caustic_radius) = pm.radii()?;
        let gather = PhotonMapping {
            gather_rays: pm.gather_rays,
            k: pm.photon_k,
            global_radius,
            caustic_radius,
            ..PhotonMapping::new(c.max_edges)
        };
        // Settings the final gather would refuse are refused before any chain runs.
        PhotonMapper::check(&gather).map_err(|e| super::pm::settings_error(e.to_string()))?;
        let settings = MpsSettings {
            metropolis: light_transport::metropolis::MetropolisSettings {
                budget: Budget::SamplesPerPixel(p.photon_mutations),
                ..a.metropolis.settings()
            },
            gather,
            continuations: p.continuations,
            max_trials: p.continuation_cap,
            defect: None,
        };
        let method = PathMlt::new(mutations)?;
        let start = Instant::now();
        let mut last = Instant::now();
        let (mapper, _stats) = mps_mapper(scene, &method, &settings, None, |m, _| {
            if last.elapsed() > Duration::from_secs(2) {
                eprintln!(
                    "mps: {:.1} M mutations, {:.0} s",
                    m as f64 / 1e6,
                    start.elapsed().as_secs_f64()
                );
                last = Instant::now();
            }
            true
        })
        .map_err(CliError::Render)?;
        Ok(Box::new(Passes {
            sampler: c.pass_sampler(),
            estimator: mapper,
            details: PhotonMapper::summary,
        }))
    },
};
