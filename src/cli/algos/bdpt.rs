//! Bidirectional path tracing.

use crate::cli::CliError;
use crate::cli::registry::{Common, Entry};
use clap::Args;
use light_transport::integrators::{Bdpt, Estimator, ShadowRoulette, mean_luminance};
use light_transport::path::{Roulette, WalkSettings};
use light_transport::renderer::Passes;
use light_transport::scene::Scene;

/// Options of bidirectional path tracing (bdpt).
#[derive(Args, Debug, Clone)]
pub struct BdptArgs {
    /// BDPT and PSSMLT: Russian roulette in both subpath walks from this vertex on (1 = the
    /// first surface vertex; 0 = off, every walk runs to --max-depth).
    #[arg(long, default_value_t = 0)]
    pub roulette: usize,
    /// Which walks --roulette stops: both, or light subpaths only (camera paths then keep the
    /// densities their MIS weights assume; in 20 s renders of the built-ins it gave 0.81–0.95×
    /// the error of no roulette, where roulette in both walks gave 0.67–1.35×).
    #[arg(long, value_enum, default_value_t = RouletteWalks::Both)]
    pub roulette_walks: RouletteWalks,
    /// BDPT and PT: Russian roulette on the shadow rays of contributions below this fraction
    /// of the image's mean luminance (estimated by a pilot of 4096 samples); 0 = off, every
    /// shadow ray is traced.
    #[arg(long, default_value_t = 0.0)]
    pub shadow_roulette: f64,
}

/// Pilot samples that estimate the image's mean luminance for --shadow-roulette.
const PILOT_SAMPLES: usize = 4096;
/// Their seed (fixed: the same threshold for any thread count and run).
const PILOT_SEED: u64 = 0x5AD0_F011;

/// Bidirectional path tracing.
pub const ENTRY: Entry = Entry {
    name: "bdpt",
    about: "Bidirectional path tracing, all strategies, MIS",
    unbiased: true,
    build: |scene, c, a| {
        let mut b = bdpt(c);
        b.roulette = roulette(&a.bdpt);
        b.shadow_roulette = shadow_roulette(&a.bdpt, scene, &b)?;
        Ok(Box::new(Passes {
            estimator: b,
            details: |b, _| {
                let mut notes = roulette_note(b.roulette);
                notes.extend(shadow_note(b.shadow_roulette));
                notes
            },
        }))
    },
};

/// The shadow-ray roulette of `--shadow-roulette` for `estimator` (which must trace every shadow
/// ray: it is the pilot), `None` for 0 or an image that the pilot sees black.
pub fn shadow_roulette<E: Estimator>(
    a: &BdptArgs,
    scene: &Scene,
    estimator: &E,
) -> Result<Option<ShadowRoulette>, CliError> {
    let fraction = a.shadow_roulette;
    if !(fraction >= 0.0 && fraction.is_finite()) {
        return Err(CliError::Render(light_transport::Error::InvalidParameter {
            name: "shadow-roulette".into(),
            reason: format!("must be a finite fraction ≥ 0, got {fraction}"),
        }));
    }
    if fraction == 0.0 {
        return Ok(None);
    }
    let mean = mean_luminance(estimator, scene, PILOT_SAMPLES, PILOT_SEED);
    if !(mean > 0.0) {
        eprintln!(
            "note: --shadow-roulette is off: its pilot of {PILOT_SAMPLES} samples saw a black image"
        );
        return Ok(None);
    }
    Ok(Some(ShadowRoulette {
        threshold: fraction * mean,
    }))
}

/// The report line of a shadow-ray roulette.
pub fn shadow_note(r: Option<ShadowRoulette>) -> Vec<String> {
    r.map(|r| {
        vec![format!(
            "shadow     roulette on shadow rays of contributions below luminance {:.3e}",
            r.threshold
        )]
    })
    .unwrap_or_default()
}

/// The report line of a roulette in the subpath walks.
pub fn roulette_note(r: Option<Roulette>) -> Vec<String> {
    r.map(|r| {
        let walks = if r.camera {
            "camera and light"
        } else {
            "light"
        };
        vec![format!(
            "roulette   {walks} subpaths may stop from vertex {} on",
            r.from
        )]
    })
    .unwrap_or_default()
}

/// Which subpath walks `--roulette` stops.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RouletteWalks {
    /// Camera and light subpaths.
    Both,
    /// Light subpaths only.
    Light,
}

/// The roulette of `--roulette` and `--roulette-walks` (`None` for 0).
pub fn roulette(a: &BdptArgs) -> Option<Roulette> {
    (a.roulette > 0).then_some(Roulette {
        from: a.roulette,
        camera: a.roulette_walks == RouletteWalks::Both,
    })
}

/// BDPT with the common options (also the evaluator of PSSMLT), without roulette.
pub fn bdpt(c: &Common) -> Bdpt {
    Bdpt {
        walk: WalkSettings {
            max_edges: c.max_edges,
        },
        heuristic: c.heuristic,
        roulette: None,
        shadow_roulette: None,
    }
}
