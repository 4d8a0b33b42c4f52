//! Manifold exploration (Jakob & Marschner 2012, §5): MEMLT, MEPT and the manifold perturbation
//! on its own converge to BDPT.
//!
//! Statistical verdicts as in `pathspace.rs`: Welch t-tests per 6×6 block between 8 independent
//! runs and 16 BDPT batches, Holm-corrected within each comparison, α = 1e-4 (false-positive rate
//! ≤ 1e-4 per comparison). Seeds are fixed, so the verdicts are reproducible.

mod common;

use common::{
    ALPHA, H, MAX_EDGES, W, bdpt_batches, blocks, blocks_and_stats, metropolis_runs, min_p,
    settings,
};
use light_transport::Budget;
use light_transport::film::Image;
use light_transport::integrators::render;
use light_transport::metropolis::{ImportanceKind, Method};
use light_transport::pathspace::{
    Erpt, ErptSettings, ManifoldDefect, MutationProbabilities, Mutations, PathMlt,
};
use light_transport::scene::{Scene, builtin};
use mcmc_core::proposals::{MixtureRule, Selection};

fn scene(name: &str) -> Scene {
    Scene::new(&builtin::builtin(name).unwrap(), Some((W, H))).unwrap()
}

fn mutations(probabilities: MutationProbabilities) -> Mutations {
    Mutations {
        probabilities,
        importance: ImportanceKind::Luminance,
        rule: MixtureRule::PerComponent,
        selection: Selection::Suitability,
        ..Mutations::new(MAX_EDGES)
    }
}

fn report(name: &str, what: &str, p: f64, stats: &mcmc_core::Stats) {
    let kinds = light_transport::pathspace::mutations::names();
    let rates: Vec<String> = stats
        .kinds
        .iter()
        .zip(&kinds)
        .filter(|(k, _)| k.proposed > 0)
        .map(|(k, n)| {
            format!(
                "{n} {:.1}% of {}",
                100.0 * k.accepted as f64 / k.proposed as f64,
                k.proposed
            )
        })
        .collect();
    println!("{name} {what}: p = {p:.3e}; {}", rates.join(", "));
}

#[test]
fn memlt_converges_to_bdpt_on_every_builtin_scene() {
    let mlt = PathMlt::new(mutations(MutationProbabilities::manifold_exploration())).unwrap();
    for name in builtin::BUILTIN {
        let scene = scene(name);
        let (images, stats) =
            blocks_and_stats(metropolis_runs(&scene, &mlt, settings(4000, 32.0, 91), 8));
        let p = min_p(&images, &bdpt_batches(&scene));
        report(name, "memlt", p, &stats);
        assert!(p > ALPHA, "{name}: MEMLT disagrees with BDPT (p = {p:.2e})");
    }
}

/// The convergence test sees a wrong transition density. At λ = 50 and 32 mutations per pixel the
/// chains barely leave their seeds (which are unbiased), so a wrong kernel has no time to show;
/// here λ = 5 (larger steps), 128 mutations per pixel, the manifold perturbation in both
/// directions (0.45 each) with new paths (0.1), on the Cornell box, whose glass sphere magnifies
/// strongly. A perturbation whose `T` forgets the first chain's generalised geometry term
/// (sampling `f G` instead of `f`) is caught, and the correct one passes at the same settings.
/// Measured: broken p = 8.3e-7, correct p = 1.0. (With the bidirectional mutation in the mixture
/// too the broken one gave p = 1.7e-4 — too close to α; on the pool the same defect is not seen at
/// all, p ≥ 0.02: its magnification through gentle waves is nearly constant, so `f G` and `f`
/// differ little.)
#[test]
fn memlt_without_the_first_chains_geometry_term_is_caught() {
    let scene = scene("cornell");
    let reference = bdpt_batches(&scene);
    for defect in [Some(ManifoldDefect::FirstChainGeometry), None] {
        let mut m = mutations(
            MutationProbabilities::of(&[
                ("manifold-light", 0.45),
                ("manifold-eye", 0.45),
                ("new-path", 0.1),
            ])
            .unwrap(),
        );
        m.manifold.lambda = 5.0;
        m.manifold.defect = defect;
        let mlt = PathMlt::new(m).unwrap();
        let (images, stats) =
            blocks_and_stats(metropolis_runs(&scene, &mlt, settings(4000, 128.0, 91), 8));
        let p = min_p(&images, &reference);
        report(
            "cornell",
            &format!("memlt λ = 5, defect {defect:?}"),
            p,
            &stats,
        );
        if defect.is_some() {
            assert!(p < ALPHA, "the broken MEMLT passes (p = {p:.2e})");
        } else {
            assert!(
                p > ALPHA,
                "MEMLT at λ = 5 disagrees with BDPT (p = {p:.2e})"
            );
        }
    }
}

#[test]
fn each_manifold_direction_with_new_paths_converges_to_bdpt() {
    for name in ["cornell", "pool"] {
        let scene = scene(name);
        let reference = bdpt_batches(&scene);
        for which in ["manifold-light", "manifold-eye"] {
            let mlt = PathMlt::new(mutations(
                MutationProbabilities::with_new_path(which).unwrap(),
            ))
            .unwrap();
            let (images, stats) =
                blocks_and_stats(metropolis_runs(&scene, &mlt, settings(4000, 32.0, 93), 8));
            let p = min_p(&images, &reference);
            report(name, which, p, &stats);
            let i = light_transport::pathspace::mutations::index_of(which).unwrap();
            assert!(
                stats.kinds[i].accepted > 0,
                "{name}: {which} never accepted"
            );
            assert!(
                p > ALPHA,
                "{name}: {which} disagrees with BDPT (p = {p:.2e})"
            );
        }
    }
}

#[test]
fn mept_converges_to_bdpt_on_every_builtin_scene() {
    use rayon::prelude::*;
    // The scenes are independent (own seeds): run them side by side, report in order.
    let results: Vec<_> = builtin::BUILTIN
        .par_iter()
        .map(|name| {
            let scene = scene(name);
            let mut s = ErptSettings::new(MAX_EDGES);
            s.chain_length = 16;
            s.pilot = 2048;
            s.mutations = mutations(MutationProbabilities::manifold());
            // The pool's seeds need 16 per pixel (rare bright caustic paths, see `pathspace.rs`);
            // an eighth of a chain per seed keeps its cost near the other scenes'.
            if name.starts_with("pool") {
                s.chains_per_seed = 0.125;
            }
            let mept = Erpt::new(&scene, s).unwrap();
            let spp = if name.starts_with("pool") { 16.0 } else { 4.0 };
            let t = std::time::Instant::now();
            let images: Vec<Vec<f64>> = (0..8)
                .map(|r| {
                    let (film, _) = render(
                        &scene,
                        &mept,
                        Budget::SamplesPerPixel(spp),
                        900 + r,
                        |_, _| true,
                    );
                    assert_eq!(film.discarded, 0);
                    blocks(&Image::from_film(&film))
                })
                .collect();
            let p = min_p(&images, &bdpt_batches(&scene));
            let (stats, chains) = mept.statistics();
            (name, t.elapsed().as_secs_f64(), p, stats, chains)
        })
        .collect();
    for (name, secs, p, stats, chains) in results {
        report(name, &format!("mept ({secs:.1} s)"), p, &stats);
        assert!(chains > 0);
        assert!(p > ALPHA, "{name}: MEPT disagrees with BDPT (p = {p:.2e})");
    }
}

/// Charted MLT whose path-space moves (30% of its mutations) are the manifold perturbation: the
/// technique charts take the perturbed path back into their numbers through the exact Gibbs
/// refresh, as for the Veach–Guibas mutations.
///
/// 16 runs: the chains make about 35 mutations each here, so a run's image is mostly its seeds,
/// and since the bootstrap walks once for every path length (`Method::shares_bootstrap_keys`)
/// seeds of different lengths can share a camera walk: run images are more skewed, which
/// Welch's test on 8 of them does not survive. With 8 runs seed 97 gave p = 4.4e-7 on `cornell`
/// (seeds 197 and 297: p = 1.0); 16 and 32 runs from the same seed gave 0.48 and 1.0, so the 8
/// runs held an outlier, not a bias. The build before the shared bootstrap read 0.26–0.54 on
/// those three seeds with 8 runs.
#[test]
fn cmlt_with_manifold_moves_converges_to_bdpt() {
    use light_transport::cmlt::{Cmlt, CmltSettings};
    for name in ["cornell", "pool"] {
        let scene = scene(name);
        let cmlt_settings = CmltSettings {
            max_edges: MAX_EDGES,
            pathspace: 0.3,
            pilot: 500,
            mutations: mutations(MutationProbabilities::manifold()),
            ..Default::default()
        };
        let m = Cmlt::new(&scene, cmlt_settings).unwrap();
        let (images, stats) =
            blocks_and_stats(metropolis_runs(&scene, &m, settings(4000, 32.0, 97), 16));
        let p = min_p(&images, &bdpt_batches(&scene));
        let kinds = m.kinds();
        let moved: Vec<String> = stats
            .kinds
            .iter()
            .zip(&kinds)
            .filter(|(k, n)| n.starts_with("path: manifold") && k.proposed > 0)
            .map(|(k, n)| format!("{n} {:.1}% of {}", 100.0 * k.acceptance_rate(), k.proposed))
            .collect();
        println!("{name} cmlt + manifold: p = {p:.3e}; {}", moved.join(", "));
        assert!(!moved.is_empty(), "{name}: no manifold move was made");
        assert!(
            p > ALPHA,
            "{name}: CMLT with manifold moves disagrees with BDPT (p = {p:.2e})"
        );
    }
}

/// λ tuned in a warm-up on copies of the seeded chains, then frozen: the recorded chains still
/// converge to BDPT, and the warm-up's last batch is near the target acceptance.
#[test]
fn memlt_with_tuned_lambda_converges_to_bdpt() {
    let scene = scene("pool");
    let mut m = mutations(MutationProbabilities::manifold_exploration());
    m.manifold.target_acceptance = Some(0.5);
    let mlt = PathMlt::new(m).unwrap();
    let (images, stats) =
        blocks_and_stats(metropolis_runs(&scene, &mlt, settings(4000, 32.0, 95), 8));
    let p = min_p(&images, &bdpt_batches(&scene));
    let t = mlt.tuning().expect("tuned");
    report("pool", &format!("memlt, {t}"), p, &stats);
    assert!((t.acceptance - 0.5).abs() < 0.1, "{t}");
    assert!(t.lambda < t.initial, "{t}");
    assert!(
        p > ALPHA,
        "MEMLT with tuned λ disagrees with BDPT (p = {p:.2e})"
    );
    let bad = Mutations {
        manifold: light_transport::pathspace::ManifoldPerturbationSettings {
            target_acceptance: Some(1.5),
            ..Default::default()
        },
        ..mutations(MutationProbabilities::manifold_exploration())
    };
    assert!(
        PathMlt::new(bad).is_err(),
        "a target acceptance of 1.5 is refused"
    );
}
