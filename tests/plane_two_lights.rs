//! Convergence of the six algorithms of the charted-MLT paper's Table 1 (the
//! `plane_two_lights` example) to an independent plain Monte Carlo reference, and a deliberately
//! broken CMLT-IPSM (forgetting the `p_i` ratio) that the test must catch.
//!
//! For each algorithm, `RUNS` independent runs of `N` samples; the image is cut into 8×8-pixel
//! blocks and each block's mean (summed over channels) is compared with the reference by a t-test
//! (`RUNS − 1` degrees of freedom, the reference's standard error added to the run-to-run
//! variance), Holm-corrected over the 256 blocks at α = 1e-3 per algorithm: the probability that
//! some correct algorithm fails by chance is ≤ 0.6% (up to the t approximation), and the seeds are
//! fixed.

#[allow(dead_code)]
#[path = "../examples/support/mod.rs"]
mod support;

#[allow(dead_code)]
#[path = "../examples/plane_two_lights/algorithms.rs"]
mod algorithms;
#[allow(dead_code)]
#[path = "../examples/plane_two_lights/charts.rs"]
mod charts;
#[allow(dead_code)]
#[path = "../examples/plane_two_lights/image.rs"]
mod image;
#[allow(dead_code)]
#[path = "../examples/plane_two_lights/scene.rs"]
mod scene;

use algorithms::{Algorithm, bootstrap, reference, run};
use image::{Image, SIZE};
use mcmc_core::balance::holm;
use mcmc_core::rng::{stream, substream};
use rayon::prelude::*;
use statrs::distribution::{ContinuousCDF, StudentsT};

const RUNS: usize = 6;
const N: usize = 1 << 18;
const BLOCK: usize = 8;

fn blocks(img: &Image) -> Vec<f64> {
    let nb = SIZE / BLOCK;
    let mut out = vec![0.0; nb * nb];
    for (k, p) in img.data.iter().enumerate() {
        let (r, c) = (k / SIZE / BLOCK, k % SIZE / BLOCK);
        out[r * nb + c] += (p[0] + p[1] + p[2]) / (BLOCK * BLOCK) as f64;
    }
    out
}

/// The smallest Holm-adjusted p-value over blocks for `alg`.
fn verdict(
    alg: Algorithm,
    reference: &[f64],
    ref_se: &[f64],
    norm: &algorithms::Normalisation,
) -> f64 {
    let runs: Vec<Vec<f64>> = (0..RUNS)
        .into_par_iter()
        .map(|r| blocks(&run(alg, N, norm, &mut substream(77, alg as u64, r as u64)).image))
        .collect();
    let t = StudentsT::new(0.0, 1.0, (RUNS - 1) as f64).unwrap();
    let p: Vec<f64> = (0..reference.len())
        .map(|b| {
            let v: Vec<f64> = runs.iter().map(|r| r[b]).collect();
            let m = v.iter().sum::<f64>() / RUNS as f64;
            let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (RUNS - 1) as f64;
            let se = (var / RUNS as f64 + ref_se[b] * ref_se[b]).sqrt();
            2.0 * t.sf(((m - reference[b]) / se).abs())
        })
        .collect();
    holm(&p).into_iter().fold(1.0, f64::min)
}

#[test]
fn every_algorithm_converges_to_the_reference_and_a_broken_ipsm_does_not() {
    // Reference block means and their standard errors (pixels are independent).
    let (r, _, var) = reference(512, 1);
    let reference = blocks(&r);
    let nb = SIZE / BLOCK;
    let mut block_var = vec![0.0; nb * nb];
    for (k, v) in var.iter().enumerate() {
        block_var[(k / SIZE / BLOCK) * nb + k % SIZE / BLOCK] +=
            v / ((BLOCK * BLOCK) as f64).powi(2);
    }
    let ref_se: Vec<f64> = block_var.iter().map(|v| v.sqrt()).collect();
    let norm = bootstrap(1 << 20, &mut stream(2, 0));
    for alg in Algorithm::WITH_ST {
        let p = verdict(alg, &reference, &ref_se, &norm);
        println!("{:<12} min Holm-adjusted p = {p:.3e}", alg.name());
        assert!(
            p > 1e-3,
            "{} disagrees with the reference (p = {p:.2e})",
            alg.name()
        );
    }
    let p = verdict(Algorithm::CmltIpsmBroken, &reference, &ref_se, &norm);
    println!(
        "{:<12} min Holm-adjusted p = {p:.3e}",
        "IPSM without p_i ratio"
    );
    assert!(p < 1e-3, "the broken IPSM was not caught (p = {p:.2e})");
}
