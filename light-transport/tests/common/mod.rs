//! Helpers shared by the statistical tests: Welch tests over independent replicates with Holm's
//! correction, and the BDPT reference of the convergence tests (6×6 blocks of a 36×30 image).

#![allow(dead_code)]

use light_transport::Budget;
use light_transport::film::{Film, Image};
use light_transport::integrators::{Bdpt, render};
use light_transport::metropolis::{self, Method, MetropolisSettings, MetropolisStats, Seeding};
use light_transport::path::{MisHeuristic, WalkSettings};
use light_transport::scene::Scene;
use mcmc_core::Stats;
use mcmc_core::balance::holm;
use statrs::distribution::{ContinuousCDF, StudentsT};

/// Significance level of every comparison (after Holm's correction within a comparison).
pub const ALPHA: f64 = 1e-4;

/// Welch t-test of two sets of independent replicate vectors, per component, Holm-corrected: the
/// smallest adjusted p-value. `b` may have zero variance (an exact reference).
pub fn min_p(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let var = |v: &[f64], m: f64| {
        if v.len() > 1 {
            v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64
        } else {
            0.0
        }
    };
    let mut p = Vec::new();
    for j in 0..a[0].len() {
        let va: Vec<f64> = a.iter().map(|r| r[j]).collect();
        let vb: Vec<f64> = b.iter().map(|r| r[j]).collect();
        let (ma, mb) = (mean(&va), mean(&vb));
        let (sa, sb) = (
            var(&va, ma) / va.len() as f64,
            var(&vb, mb) / vb.len() as f64,
        );
        if sa + sb == 0.0 {
            p.push(if (ma - mb).abs() < 1e-12 { 1.0 } else { 0.0 });
            continue;
        }
        let t = (ma - mb).abs() / (sa + sb).sqrt();
        let df = (sa + sb).powi(2)
            / (sa * sa / (va.len() as f64 - 1.0).max(1.0)
                + if vb.len() > 1 {
                    sb * sb / (vb.len() as f64 - 1.0)
                } else {
                    0.0
                });
        p.push(2.0 * StudentsT::new(0.0, 1.0, df.max(1.0)).unwrap().sf(t));
    }
    holm(&p).into_iter().fold(1.0, f64::min)
}

/// Image size and block size of the convergence tests.
pub const W: usize = 36;
pub const H: usize = 30;
pub const BLOCK: usize = 6;
pub const MAX_EDGES: usize = 6;

pub fn blocks(img: &Image) -> Vec<f64> {
    let bw = W / BLOCK;
    let mut out = vec![0.0; bw * (H / BLOCK)];
    for (i, p) in img.pixels.iter().enumerate() {
        out[(i / W / BLOCK) * bw + i % W / BLOCK] += (p[0] + p[1] + p[2]) / (BLOCK * BLOCK) as f64;
    }
    out
}

pub fn bdpt_batches(scene: &Scene) -> Vec<Vec<f64>> {
    let bdpt = Bdpt {
        walk: WalkSettings {
            max_edges: MAX_EDGES,
        },
        heuristic: MisHeuristic::Power,
    };
    (0..16)
        .map(|b| {
            blocks(&Image::from_film(
                &render(
                    scene,
                    &bdpt,
                    Budget::SamplesPerPixel(8.0),
                    500 + b,
                    |_, _| true,
                )
                .0,
            ))
        })
        .collect()
}

/// Driver settings of the convergence tests: 64 chains, resampled seeds.
pub fn settings(bootstrap: usize, mutations_per_pixel: f64, seed: u64) -> MetropolisSettings {
    MetropolisSettings {
        chains: 64,
        bootstrap,
        budget: Budget::SamplesPerPixel(mutations_per_pixel),
        seed,
        seeding: Seeding::Resample,
    }
}

/// `runs` independent renders of `m`: run `r` uses `settings` with seed `settings.seed + r`.
pub fn metropolis_runs<M: Method>(
    scene: &Scene,
    m: &M,
    settings: MetropolisSettings,
    runs: u64,
) -> Vec<(Film, MetropolisStats)> {
    (0..runs)
        .map(|r| {
            let s = MetropolisSettings {
                seed: settings.seed + r,
                ..settings
            };
            metropolis::run(scene, m, &s, |_, _, _| true).unwrap()
        })
        .collect()
}

/// The block images of `runs` (which must have discarded nothing) and their merged statistics.
pub fn blocks_and_stats(runs: Vec<(Film, MetropolisStats)>) -> (Vec<Vec<f64>>, Stats) {
    let mut all = Stats::default();
    let images = runs
        .into_iter()
        .map(|(film, stats)| {
            assert_eq!(film.discarded, 0);
            all.merge(&stats.stats);
            blocks(&Image::from_film(&film))
        })
        .collect();
    (images, all)
}
