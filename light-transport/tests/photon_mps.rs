//! Metropolis photon sampling (Fan, Chenney & Lai 2005) stores photons whose power is unbiased:
//! the summed power of its global photons in a floor patch of the Cornell box matches the flux
//! arriving there, estimated by photon (light) tracing with the same light-path lengths.
//!
//! MPS stores a global photon at the second non-specular vertex from the eye of a path of at most
//! `K` edges, so its light prefixes have at most `K − 2` edges; the light tracer runs with `K − 2`.
//! Every floor point sees camera-visible diffuse walls, so the continuation probability `A` is
//! positive over the patch and the photon map is unbiased there (`photon::metropolis` docs).
//!
//! A second test counts where photons go in the built-in `rooms` (a bright light behind a thin
//! divider, seen only through a doorway): photon tracing stores most of its photons in the far
//! room, many of them just behind the divider where lookups from the near room's floor reach them
//! (energy bleeding); MPS stores a photon only where a gather from the eye reads it, so behind the
//! divider it stores far fewer (deterministic counts for fixed seeds; the test asserts a factor 4
//! between the shares).
//!
//! Welch's t over 16 independent MPS runs (seeds 1…16) against 16 batches of 60 000 light paths,
//! |t| < 5 (two-sided false-positive rate below 5e-4 for ≥ 15 degrees of freedom). The defect
//! that drops `1/A` (`T = 1`) must be caught (|t| ≥ 5).

use light_transport::math::DVec3;
use light_transport::metropolis::MetropolisSettings;
use light_transport::pathspace::{Mutations, PathMlt};
use light_transport::photon::metropolis::{power_in_box, proposals};
use light_transport::photon::{MpsDefect, MpsSettings, sample_photons, trace_photons};
use light_transport::scene::{Scene, builtin};
use light_transport::{Budget, Rgb};

const K: usize = 6;
const RUNS: u64 = 16;
const LO: DVec3 = DVec3::new(-0.8, 0.2, -1.01);
const HI: DVec3 = DVec3::new(0.8, 1.8, -0.99);

fn scene() -> Scene {
    Scene::new(
        &builtin::builtin("cornell").expect("cornell"),
        Some((24, 24)),
    )
    .expect("scene")
}

fn mean_var(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let v = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, v / n)
}

/// MPS with the paper's Lantern proposals on paths of at most `K` edges.
fn mps_method() -> PathMlt {
    let mut mutations = Mutations::new(K);
    mutations.probabilities = proposals();
    PathMlt::new(mutations).expect("mutations")
}

/// 64 chains, 4000 bootstrap samples per length, `mutations` per pixel.
fn mps_settings(seed: u64, mutations: f64, defect: Option<MpsDefect>) -> MpsSettings {
    MpsSettings {
        metropolis: MetropolisSettings {
            chains: 64,
            bootstrap: 4000,
            budget: Budget::SamplesPerPixel(mutations),
            seed,
            ..MetropolisSettings::default()
        },
        defect,
        ..MpsSettings::new(K)
    }
}

fn mps_patch_power(scene: &Scene, seed: u64, defect: Option<MpsDefect>) -> Rgb {
    let settings = mps_settings(seed, 192.0, defect);
    let (global, _, _) =
        sample_photons(scene, &mps_method(), &settings, None, |_, _| true).expect("mps");
    power_in_box(&global, LO, HI)
}

fn light_tracing_batches(scene: &Scene) -> Vec<f64> {
    (0..RUNS)
        .map(|b| {
            let (global, _) = trace_photons(scene, 60_000, K - 2, 0x17_0000 + b);
            power_in_box(&global, LO, HI).luminance()
        })
        .collect()
}

fn t_statistic(a: &[f64], b: &[f64]) -> f64 {
    let ((ma, va), (mb, vb)) = (mean_var(a), mean_var(b));
    (ma - mb) / (va + vb).sqrt()
}

#[test]
fn mps_photon_power_matches_light_tracing_flux() {
    let scene = scene();
    let lt = light_tracing_batches(&scene);
    let mps: Vec<f64> = (1..=RUNS)
        .map(|s| mps_patch_power(&scene, s, None).luminance())
        .collect();
    let t = t_statistic(&mps, &lt);
    let (m, _) = mean_var(&mps);
    let (l, _) = mean_var(&lt);
    println!(
        "patch flux: MPS {m:.5e}, light tracing {l:.5e}, ratio {:.4}, t = {t:.2}",
        m / l
    );
    assert!(t.abs() < 5.0, "MPS photon power is biased: t = {t:.2}");
}

#[test]
fn mps_without_the_continuation_probability_is_caught() {
    let scene = scene();
    let lt = light_tracing_batches(&scene);
    let mps: Vec<f64> = (1..=RUNS)
        .map(|s| {
            mps_patch_power(&scene, s, Some(MpsDefect::WithoutContinuationProbability)).luminance()
        })
        .collect();
    let t = t_statistic(&mps, &lt);
    let (m, _) = mean_var(&mps);
    let (l, _) = mean_var(&lt);
    println!(
        "defect T = 1: MPS {m:.5e}, light tracing {l:.5e}, ratio {:.4}, t = {t:.2}",
        m / l
    );
    assert!(t.abs() >= 5.0, "the defect was not caught: t = {t:.2}");
}

/// Share of `photons` in the slab just behind the part of the divider of `rooms` the camera sees
/// (`−0.4 < x < −0.01`, within a lookup radius of the near room's side; `z > −1`, away from the
/// doorway) and in the far room (`x < −0.01`).
fn behind_the_divider(photons: &[light_transport::photon::Photon]) -> (f64, f64) {
    let n = photons.len().max(1) as f64;
    let slab = photons
        .iter()
        .filter(|p| p.p.x > -0.4 && p.p.x < -0.01 && p.p.z > -1.0)
        .count() as f64;
    let far = photons.iter().filter(|p| p.p.x < -0.01).count() as f64;
    (slab / n, far / n)
}

#[test]
fn mps_stores_few_photons_behind_the_divider_of_rooms() {
    let scene =
        Scene::new(&builtin::builtin("rooms").expect("rooms"), Some((60, 45))).expect("scene");
    let (traced, _) = trace_photons(&scene, 100_000, K - 2, 0x600D);
    let settings = mps_settings(7, 64.0, None);
    let (global, _, _) =
        sample_photons(&scene, &mps_method(), &settings, None, |_, _| true).expect("mps");
    let (pm_slab, pm_far) = behind_the_divider(&traced);
    let (mps_slab, mps_far) = behind_the_divider(&global);
    println!(
        "rooms: photon tracing {} photons, {:.1}% just behind the divider, {:.1}% in the far room; \
         MPS {} photons, {:.2}% just behind the divider, {:.1}% in the far room",
        traced.len(),
        100.0 * pm_slab,
        100.0 * pm_far,
        global.len(),
        100.0 * mps_slab,
        100.0 * mps_far
    );
    assert!(
        pm_slab > 4.0 * mps_slab,
        "MPS does not avoid the far side of the divider"
    );
}

/// The same comparison with 64 runs of each (≈ 1 min per estimator), which resolves the ratio to
/// ≈ ±2%: the correct power passes (measured 1.021 ± 0.020, t = +1.06) and `1/A` estimated by
/// `(N − 1)/(r − 1)` is caught (measured 1.12, t = +5.6; this was the first version's estimator).
/// Also a Cornell box without the spheres (32 runs; measured 0.991 ± 0.015, t = −0.58).
/// `cargo test --release -p light-transport --test photon_mps -- --ignored --nocapture`
#[test]
#[ignore]
fn mps_photon_power_matches_light_tracing_flux_64_runs() {
    let scene = scene();
    let lt: Vec<f64> = (0..64)
        .map(|b| {
            let (global, _) = trace_photons(&scene, 60_000, K - 2, 0x27_0000 + b);
            power_in_box(&global, LO, HI).luminance()
        })
        .collect();
    let (l, _) = mean_var(&lt);
    for defect in [None, Some(MpsDefect::HaldaneInverse)] {
        let mps: Vec<f64> = (101..=164)
            .map(|s| mps_patch_power(&scene, s, defect).luminance())
            .collect();
        let t = t_statistic(&mps, &lt);
        let (m, vm) = mean_var(&mps);
        println!(
            "64 runs, {defect:?}: MPS {m:.5e} ± {:.1e}, light tracing {l:.5e}, ratio {:.4} ± {:.4}, t = {t:.2}",
            vm.sqrt(),
            m / l,
            vm.sqrt() / l
        );
        match defect {
            None => assert!(t.abs() < 5.0, "MPS photon power is biased: t = {t:.2}"),
            Some(_) => assert!(t.abs() >= 5.0, "the defect was not caught: t = {t:.2}"),
        }
    }
}

#[test]
#[ignore]
fn mps_photon_power_matches_light_tracing_flux_without_spheres() {
    use light_transport::scene::builtin::SceneBuilder;
    let mut s = SceneBuilder::new(
        24,
        24,
        DVec3::new(0.0, 1.0, 6.8),
        DVec3::new(0.0, 1.0, 0.0),
        19.5,
    );
    let white = s.matte(0.725, 0.71, 0.68);
    let black = s.matte(0.0, 0.0, 0.0);
    s.cornell_walls([white; 5]);
    s.quad(
        DVec3::new(-0.24, 1.98, -0.22),
        DVec3::X * 0.47,
        DVec3::Z * 0.38,
        black,
        Some(Rgb::new(17.0, 12.0, 4.0)),
    );
    let scene = Scene::new(&s.finish(), None).expect("scene");
    let lt: Vec<f64> = (0..32)
        .map(|b| {
            let (global, _) = trace_photons(&scene, 60_000, K - 2, 0x37_0000 + b);
            power_in_box(&global, LO, HI).luminance()
        })
        .collect();
    let mps: Vec<f64> = (201..=232)
        .map(|s| mps_patch_power(&scene, s, None).luminance())
        .collect();
    let t = t_statistic(&mps, &lt);
    let (m, vm) = mean_var(&mps);
    let (l, _) = mean_var(&lt);
    println!(
        "no spheres, 32 runs: MPS {m:.5e} ± {:.1e}, light tracing {l:.5e}, ratio {:.4} ± {:.4}, t = {t:.2}",
        vm.sqrt(),
        m / l,
        vm.sqrt() / l
    );
    assert!(t.abs() < 5.0, "MPS photon power is biased: t = {t:.2}");
}
