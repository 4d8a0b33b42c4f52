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
use light_transport::pathspace::{Erpt, ErptSettings, MutationProbabilities, Mutations, PathMlt};
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
    for name in builtin::BUILTIN {
        let scene = scene(name);
        let mut s = ErptSettings::new(MAX_EDGES);
        s.chain_length = 16;
        s.pilot = 2048;
        s.mutations = mutations(MutationProbabilities::manifold());
        let mept = Erpt::new(&scene, s).unwrap();
        let spp = if name.starts_with("pool") { 16.0 } else { 4.0 };
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
        report(name, "mept", p, &stats);
        assert!(chains > 0);
        assert!(p > ALPHA, "{name}: MEPT disagrees with BDPT (p = {p:.2e})");
    }
}

/// Charted MLT whose path-space moves (30% of its mutations) are the manifold perturbation: the
/// technique charts take the perturbed path back into their numbers through the exact Gibbs
/// refresh, as for the Veach–Guibas mutations.
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
            blocks_and_stats(metropolis_runs(&scene, &m, settings(4000, 32.0, 97), 8));
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
