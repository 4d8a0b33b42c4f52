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
    /// BDPT, PSSMLT and PT: Russian roulette in the walks from this vertex on (1 = the first
    /// surface vertex; 0 = off, every walk runs to --max-depth). Default: 1 in the light walks
    /// of BDPT and PSSMLT (at equal time 0.79–1.03× and 0.78–1.09× the RMSE of none on
    /// veach-bidir and the built-ins), off for PT (from vertex 3: 0.77× on door, 0.99–1.06×
    /// elsewhere; README).
    #[arg(long)]
    pub roulette: Option<usize>,
    /// BDPT and PSSMLT: which walks --roulette stops: light subpaths only (the default; camera
    /// paths then keep the densities their MIS weights assume) or both (worse on ring and pool:
    /// PSSMLT 1.52–1.72×, BDPT up to 1.45× the RMSE of light walks only; README).
    #[arg(long, value_enum)]
    pub roulette_walks: Option<RouletteWalks>,
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
    passes: true,
    build: |scene, c, a| {
        let mut b = bdpt(c);
        b.roulette = roulette(&a.bdpt)?;
        b.shadow_roulette = shadow_roulette(&a.bdpt, scene, &b)?;
        Ok(Box::new(Passes {
            sampler: c.pass_sampler(),
            estimator: b,
            details: |b, _| {
                let mut notes = Roulette::report(b.roulette);
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

/// Which subpath walks `--roulette` stops.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RouletteWalks {
    /// Camera and light subpaths.
    Both,
    /// Light subpaths only.
    Light,
}

/// The first vertex at which the walks of BDPT and PSSMLT may stop when `--roulette` is not given
/// (light walks only, unless `--roulette-walks both`).
pub const DEFAULT_ROULETTE_FROM: usize = 1;

/// The roulette of `--roulette` and `--roulette-walks` (`None` for 0).
pub fn roulette(a: &BdptArgs) -> Result<Option<Roulette>, CliError> {
    let from = a.roulette.unwrap_or(DEFAULT_ROULETTE_FROM);
    if from == 0 && a.roulette_walks.is_some() {
        return Err(CliError::Usage(
            "--roulette-walks needs --roulette N ≥ 1 (the first vertex that may stop; 0 is off)"
                .into(),
        ));
    }
    Ok((from > 0).then_some(Roulette {
        from,
        camera: a.roulette_walks == Some(RouletteWalks::Both),
    }))
}

/// Path tracing's roulette of `--roulette` (`None` for 0 or none given): the first vertex at
/// which a path may stop. `--roulette-walks` is an error: a path tracer has camera walks only.
pub fn path_roulette(a: &BdptArgs) -> Result<Option<usize>, CliError> {
    if a.roulette_walks.is_some() {
        return Err(CliError::Usage(
            "--roulette-walks applies to bdpt and pssmlt: a path tracer has camera walks only"
                .into(),
        ));
    }
    Ok(a.roulette.filter(|&from| from > 0))
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
