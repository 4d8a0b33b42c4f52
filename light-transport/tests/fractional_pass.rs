//! The fractional last pass of time budgets is unbiased: one full pass plus a pass of 30% of the
//! pixels, against two full passes, for light tracing (splats only) and path tracing (pixel
//! estimates), 24 seeds each, per-block Welch tests, Holm-corrected, α = 1e-4 per comparison
//! (false-positive rate ≤ 2e-4 for the two). A fractional pass whose splats count as a whole pass
//! is caught.

mod common;

use common::{ALPHA, H, MAX_EDGES, W, blocks, min_p};
use light_transport::film::{Film, Image};
use light_transport::integrators::{Estimator, LightTracer, PathTracer, pass};
use light_transport::path::{MisHeuristic, WalkSettings};
use light_transport::scene::{Scene, builtin};

const SEEDS: u64 = 24;

/// Block images of `SEEDS` renders made of one full pass and a pass of a share `q` of the pixels;
/// `splat_share` is what the splat normalisation is told that pass was worth.
fn renders<E: Estimator>(scene: &Scene, e: &E, q: f64, splat_share: f64) -> Vec<Vec<f64>> {
    // Seeds differ between the shares so that the two sets are independent.
    let first = (q * 1e6) as u64;
    (first..first + SEEDS)
        .map(|seed| {
            let mut film = Film::new(W, H);
            let mut rays = 0;
            let full = pass(scene, e, seed, 0, 1.0, &mut film, &mut rays);
            assert_eq!(full as usize, W * H);
            let taken = pass(scene, e, seed, 1, q, &mut film, &mut rays);
            if q < 1.0 {
                let share = taken as f64 / (W * H) as f64;
                assert!(
                    (share - q).abs() < 0.05,
                    "took {share} of the pixels for q = {q}"
                );
            }
            if e.splats() {
                film.splat_scale += splat_share - q;
            }
            blocks(&Image::from_film(&film))
        })
        .collect()
}

fn scene() -> Scene {
    Scene::new(&builtin::builtin("cornell").unwrap(), Some((W, H))).unwrap()
}

#[test]
fn a_fractional_last_pass_is_unbiased() {
    let scene = scene();
    let lt = LightTracer {
        walk: WalkSettings {
            max_edges: MAX_EDGES,
        },
    };
    let pt = PathTracer {
        max_edges: MAX_EDGES,
        heuristic: MisHeuristic::Power,
        roulette_from: None,
        shadow_roulette: None,
    };
    let p_lt = min_p(
        &renders(&scene, &lt, 0.3, 0.3),
        &renders(&scene, &lt, 1.0, 1.0),
    );
    let p_pt = min_p(
        &renders(&scene, &pt, 0.3, 0.3),
        &renders(&scene, &pt, 1.0, 1.0),
    );
    println!("fractional pass: light tracing p = {p_lt:.3e}, path tracing p = {p_pt:.3e}");
    assert!(p_lt > ALPHA, "light tracing: p = {p_lt:.2e}");
    assert!(p_pt > ALPHA, "path tracing: p = {p_pt:.2e}");
}

#[test]
fn a_fractional_pass_counted_as_a_whole_one_is_caught() {
    let scene = scene();
    let lt = LightTracer {
        walk: WalkSettings {
            max_edges: MAX_EDGES,
        },
    };
    let p = min_p(
        &renders(&scene, &lt, 0.3, 1.0),
        &renders(&scene, &lt, 1.0, 1.0),
    );
    println!("fractional pass counted as whole: p = {p:.3e}");
    assert!(p < ALPHA, "not caught: p = {p:.2e}");
}
