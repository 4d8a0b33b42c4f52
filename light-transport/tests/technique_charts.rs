//! Every technique chart of every built-in scene honours the chart contract (`mcmc-charts`'
//! checker): `T(R(x)) = x`, and `U' = R(T(U))` is uniform — the exact conditional inverse — on
//! 1D marginals and coordinate pairs (chi-square, Bonferroni, family-wise α = 1e-4 per chart).
//! Specular vertices (Cornell spheres, caustic glass, ring mirror) and layered materials (the
//! door's plastic table) are covered. An inverse that always picks the first lobe of a layered
//! material is caught (on a plastic floor filling the view). Shading normals: the pool's water
//! (a built-in scene) and coarse smooth-shaded mesh spheres of matte, layered, rough metal and glass
//! materials. The partial reparameterisation of
//! chart swaps (§6.1) matches the full inverse, and one that leaves a newly sampled vertex's
//! numbers uniform is caught.

use light_transport::cmlt::{TechniqueChart, camera_numbers, technique_charts};
use light_transport::math::DVec3;
use light_transport::metropolis::ImportanceKind;
use light_transport::pathspace::PathState;
use light_transport::scene::builtin::SceneBuilder;
use light_transport::scene::{MaterialDesc, RgbTexture, Scene, builtin};
use light_transport::spectrum::Rgb;
use mcmc_charts::Chart;
use mcmc_charts::checker::{ChartReport, CheckerConfig, check_chart};
use mcmc_core::ChainRng;
use mcmc_core::rng::{stream, uniform};

mod common;

/// Largest distance between corresponding vertices (infinite for different lengths).
fn distance(a: &PathState, b: &PathState) -> f64 {
    let (va, vb) = (&a.path.vertices, &b.path.vertices);
    if va.len() != vb.len() {
        return f64::INFINITY;
    }
    va.iter()
        .zip(vb)
        .map(|(x, y)| (x.p() - y.p()).length())
        .fold(0.0, f64::max)
}

/// Uniform samples so that about 4000 map to a path (the chi-square tests need counts), from a
/// pilot of 4000; at most `cap` (all of `cap` when the pilot finds fewer than 10).
fn samples<C: Chart<PathState>>(chart: &C, rng: &mut ChainRng, cap: usize) -> usize {
    let mut x = PathState::default();
    let mut u = vec![0.0; chart.dim()];
    let hits = (0..4000)
        .filter(|_| {
            u.iter_mut().for_each(|v| *v = uniform(rng));
            chart.forward(&u, &mut x)
        })
        .count();
    if hits < 10 {
        return cap;
    }
    (4000 * 4000 / hits).clamp(4000, cap)
}

/// The checker's report; `Err(message)` when too few uniform samples map to a path to test the
/// chart (its image is empty or nearly so, e.g. a light the camera cannot see directly).
fn check<C: Chart<PathState>>(chart: &C, seed: u64) -> Result<ChartReport, String> {
    check_with_cap(chart, seed, 400_000)
}

fn check_with_cap<C: Chart<PathState>>(
    chart: &C,
    seed: u64,
    cap: usize,
) -> Result<ChartReport, String> {
    let mut rng = stream(seed, 0);
    let config = CheckerConfig {
        samples: samples(chart, &mut rng, cap),
        alpha: 1e-4,
        // Scene units are metres; retracing a path through several specular vertices carries
        // rounding of about 1e-6 m, while a wrong inverse misses by centimetres or more.
        tolerance: 1e-5,
    };
    match check_chart(chart, &distance, None, &config, &mut rng) {
        Ok(r) => Ok(r),
        Err(mcmc_core::McmcError::Check(m)) if m.contains("succeeded for only") => Err(m),
        Err(e) => panic!("{e}"),
    }
}

const MAX_EDGES: usize = 4;

#[test]
fn every_technique_chart_of_every_builtin_scene_passes_the_checker() {
    use rayon::prelude::*;
    let (mut failures, mut untestable, mut tested) = (Vec::new(), Vec::new(), 0);
    let scenes: Vec<Scene> = builtin::BUILTIN
        .iter()
        .map(|name| Scene::new(&builtin::builtin(name).unwrap(), Some((32, 24))).unwrap())
        .collect();
    // Every chart's check has its own seed: run them in parallel, report in order.
    let charts: Vec<(usize, usize, TechniqueChart<'_>)> = scenes
        .iter()
        .enumerate()
        .flat_map(|(n, scene)| {
            technique_charts(scene, MAX_EDGES, ImportanceKind::Luminance)
                .into_iter()
                .enumerate()
                .map(move |(c, chart)| (n, c, chart))
        })
        .collect();
    let reports: Vec<_> = charts
        .par_iter()
        .map(|(n, c, chart)| check(chart, 1000 * *n as u64 + *c as u64))
        .collect();
    for ((n, _, chart), report) in charts.iter().zip(reports) {
        let name = builtin::BUILTIN[*n];
        let report = match report {
            Ok(r) => r,
            Err(why) => {
                untestable.push(format!("{name} {}: {why}", chart.name()));
                continue;
            }
        };
        tested += 1;
        println!(
            "{name} {}: success {:.3}, round trip {:.1e}, uniformity p = {:.2e}",
            chart.name(),
            report.success_rate,
            report.round_trip.statistic,
            report.inverse_uniformity.statistic
        );
        if !report.passed() {
            failures.push(format!("{name}: {report}"));
        }
    }
    println!(
        "{tested} charts tested; too few paths to test:\n  {}",
        untestable.join("\n  ")
    );
    assert!(tested >= 35, "only {tested} charts could be tested");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Technique charts on smooth-shaded meshes (interpolated vertex normals far from the facets'
/// normals) with layered, rough-metal, matte and glass materials: the inverses stay exact in the
/// shading frame.
#[test]
fn technique_charts_pass_the_checker_on_smooth_shaded_meshes() {
    let scene = Scene::new(&common::smooth_spheres(), Some((32, 24))).unwrap();
    let (mut failures, mut tested) = (Vec::new(), 0);
    for (c, chart) in technique_charts(&scene, MAX_EDGES, ImportanceKind::Luminance)
        .iter()
        .enumerate()
    {
        let Ok(report) = check(chart, 7000 + c as u64) else {
            continue;
        };
        tested += 1;
        println!(
            "smooth spheres {}: success {:.3}, round trip {:.1e}, uniformity p = {:.2e}",
            chart.name(),
            report.success_rate,
            report.round_trip.statistic,
            report.inverse_uniformity.statistic
        );
        if !report.passed() {
            failures.push(report.to_string());
        }
    }
    assert!(tested >= 10, "only {tested} charts could be tested");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The technique chart with a broken inverse: at the first camera scattering vertex, the lobe is
/// always the first one that can produce the direction, instead of one chosen in proportion to
/// its share of the density.
struct FirstLobe<'a>(TechniqueChart<'a>);

impl Chart<PathState> for FirstLobe<'_> {
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn forward(&self, u: &[f64], x: &mut PathState) -> bool {
        self.0.forward(u, x)
    }
    fn ln_density(&self, x: &PathState) -> f64 {
        self.0.ln_density(x)
    }
    fn invert(&self, x: &PathState, u: &mut [f64], rng: &mut ChainRng) -> bool {
        if !self.0.invert(x, u, rng) {
            return false;
        }
        let v = &x.path.vertices;
        let k = self.0.k;
        let (prev, here, next) = (&v[k], &v[k - 1], &v[k - 2]);
        let Some(b) = here.bsdf.as_ref() else {
            return true;
        };
        let wo = (prev.p() - here.p()).normalize();
        let wi = (next.p() - here.p()).normalize();
        if let Some(l) = (0..4).find_map(|j| b.invert_lobe(wo, wi, j, rng)) {
            let at = camera_numbers(2);
            u[at..at + 3].copy_from_slice(&l);
        }
        true
    }
}

/// A floor of layered plastic filling the view under a large light.
fn plastic_floor() -> Scene {
    let mut b = SceneBuilder::new(
        32,
        24,
        DVec3::new(0.0, 1.0, 1.0),
        DVec3::new(0.0, 0.0, 0.0),
        60.0,
    );
    let plastic = b.material(MaterialDesc::Layered {
        kd: RgbTexture::Constant(Rgb::new(0.4, 0.2, 0.1)),
        ks: Rgb::splat(0.8),
        alpha_u: 0.2,
        alpha_v: 0.2,
        eta: 1.5,
    });
    let black = b.matte(0.0, 0.0, 0.0);
    b.quad(
        DVec3::new(-5.0, 0.0, -5.0),
        DVec3::Z * 10.0,
        DVec3::X * 10.0,
        plastic,
        None,
    );
    b.quad(
        DVec3::new(-2.0, 2.0, -2.0),
        DVec3::X * 4.0,
        DVec3::Z * 4.0,
        black,
        Some(Rgb::splat(5.0)),
    );
    Scene::new(&b.finish(), None).unwrap()
}

#[test]
fn an_inverse_choosing_the_first_lobe_of_a_layered_material_is_caught() {
    let scene = plastic_floor();
    let chart = TechniqueChart::new(&scene, 2, 0, ImportanceKind::Luminance).unwrap();
    let good = check(&chart, 5).unwrap();
    let bad = check(&FirstLobe(chart), 5).unwrap();
    println!("exact: {good}\nfirst lobe: {bad}");
    assert!(good.passed());
    assert!(
        !bad.inverse_uniformity.passed,
        "the first-lobe inverse was not caught"
    );
}

/// The charts the CI test cannot reach (rare images), with up to 20 M uniform samples each:
/// `cargo test --release -p light-transport --test technique_charts -- --ignored --nocapture`
/// (about ten minutes).
#[test]
#[ignore]
fn rare_technique_charts_pass_the_checker_with_more_samples() {
    let mut failures = Vec::new();
    for (n, name) in builtin::BUILTIN.iter().enumerate() {
        let scene = Scene::new(&builtin::builtin(name).unwrap(), Some((32, 24))).unwrap();
        for (c, chart) in technique_charts(&scene, MAX_EDGES, ImportanceKind::Luminance)
            .iter()
            .enumerate()
        {
            let seed = 1000 * n as u64 + c as u64;
            if check(chart, seed).is_ok() {
                continue;
            }
            match check_with_cap(chart, seed, 20_000_000) {
                Ok(r) => {
                    println!(
                        "{name} {}: success {:.2e}, round trip {:.1e}, uniformity p = {:.2e}",
                        chart.name(),
                        r.success_rate,
                        r.round_trip.statistic,
                        r.inverse_uniformity.statistic
                    );
                    if !r.passed() {
                        failures.push(format!("{name}: {r}"));
                    }
                }
                Err(why) => println!("{name} {}: still untestable: {why}", chart.name()),
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Columns of the partial reparameterisation `s → s2` (after `tamper`) and of the full inverse of
/// the same paths `x = T_s(U)`, `U` uniform (up to 1500 paths; `None` below 200), and the worst
/// round-trip distances of the two.
#[allow(clippy::type_complexity)]
fn partial_and_full(
    scene: &Scene,
    k: usize,
    (s, s2): (usize, usize),
    tamper: impl Fn(&mut [f64], &mut ChainRng),
) -> Option<(Vec<Vec<f64>>, Vec<Vec<f64>>, f64, f64)> {
    let a = TechniqueChart::new(scene, k, s, ImportanceKind::Luminance).unwrap();
    let b = TechniqueChart::new(scene, k, s2, ImportanceKind::Luminance).unwrap();
    let mut rng = stream(77 + 10 * s as u64 + s2 as u64, 1);
    let (mut x, mut y) = (PathState::default(), PathState::default());
    let mut u = vec![0.0; a.dim()];
    let (mut partial, mut full) = (vec![0.0; b.dim()], vec![0.0; b.dim()]);
    let (mut pa, mut fu): (Vec<Vec<f64>>, Vec<Vec<f64>>) =
        (vec![Vec::new(); b.dim()], vec![Vec::new(); b.dim()]);
    let (mut worst_trip, mut worst_full) = (0.0f64, 0.0f64);
    for _ in 0..400_000 {
        u.iter_mut().for_each(|v| *v = uniform(&mut rng));
        if !a.forward(&u, &mut x) || !(b.ln_density(&x) > f64::NEG_INFINITY) {
            continue;
        }
        assert!(a.invert(&x, &mut u, &mut rng));
        assert!(b.partial_inverse(&x, &a, &u, &mut partial, &mut rng));
        tamper(&mut partial, &mut rng);
        assert!(b.invert(&x, &mut full, &mut rng));
        if b.forward(&partial, &mut y) {
            worst_trip = worst_trip.max(distance(&x, &y));
        } else {
            worst_trip = f64::INFINITY;
        }
        assert!(b.forward(&full, &mut y));
        worst_full = worst_full.max(distance(&x, &y));
        for c in 0..b.dim() {
            pa[c].push(partial[c]);
            fu[c].push(full[c]);
        }
        if pa[0].len() == 1500 {
            break;
        }
    }
    (pa[0].len() >= 200).then_some((pa, fu, worst_trip, worst_full))
}

/// Reparameterising a path from chart `s` to chart `s'` by inverting only the vertices whose
/// numbers differ (§6.1) reproduces the path and gives numbers with the law of the full inverse:
/// for paths `x = T_s(U)`, `U` uniform, each coordinate of the partial `U'` and of a full inverse
/// `U''` of the same paths are compared by two-sample KS tests (Bonferroni over all coordinates
/// and chart pairs, family-wise α = 1e-4).
#[test]
fn partial_reparameterisation_matches_the_full_inverse() {
    let mut p_values = Vec::new();
    let (mut worst_trip, mut worst_full) = (0.0f64, 0.0f64);
    for name in ["cornell", "door"] {
        let scene = Scene::new(&builtin::builtin(name).unwrap(), Some((32, 24))).unwrap();
        let k = 3;
        for s in 0..=k {
            for s2 in 0..=k {
                if s == s2 {
                    continue;
                }
                let Some((pa, fu, trip, full)) = partial_and_full(&scene, k, (s, s2), |_, _| {})
                else {
                    continue;
                };
                assert!(trip.is_finite(), "{name} {s}→{s2}: path lost");
                worst_trip = worst_trip.max(trip);
                worst_full = worst_full.max(full);
                for (c1, c2) in pa.into_iter().zip(fu) {
                    p_values.push(mcmc_core::balance::invariance::ks_two_sample(c1, c2).1);
                }
            }
        }
    }
    let n = p_values.len();
    let min = p_values.iter().cloned().fold(1.0, f64::min);
    println!(
        "{n} KS tests, smallest p = {min:.2e}, worst round trip {worst_trip:.1e} (full inverse {worst_full:.1e})"
    );
    assert!(n > 100);
    // Re-tracing a path that grazes the glass sphere amplifies rounding (up to ~7e-5 here, the
    // same for the full inverse); the partial inverse must do no worse.
    assert!(worst_trip <= worst_full + 1e-12 && worst_full < 1e-3);
    assert!(
        min * n as f64 > 1e-4,
        "smallest p = {min:.2e} over {n} tests"
    );
}

/// The test above, on a deliberately broken partial inverse: moving from `t` to `t + 1` camera
/// vertices, the numbers of camera vertex `t − 1` (a connection endpoint before, a sampled vertex
/// now) are treated as unread and drawn uniformly instead of inverted. The path is usually lost
/// and the KS tests of that vertex's block see the wrong law.
#[test]
fn a_partial_inverse_that_leaves_a_new_sampled_vertex_uniform_is_caught() {
    let scene = Scene::new(&builtin::builtin("door").unwrap(), Some((32, 24))).unwrap();
    let k = 3;
    let mut p_values = Vec::new();
    for s in 1..=k {
        let t = k + 1 - s;
        if t < 2 {
            continue;
        }
        // Camera vertex b = t − 1 has its block at CAMERA_BLOCK + (b − 1) · VERTEX_BLOCK.
        let at = camera_numbers(t);
        let forget = |u: &mut [f64], rng: &mut ChainRng| {
            u[at..at + 4].iter_mut().for_each(|v| *v = uniform(rng));
        };
        let Some((pa, fu, _, _)) = partial_and_full(&scene, k, (s, s - 1), forget) else {
            continue;
        };
        for (c1, c2) in pa.into_iter().zip(fu).skip(at).take(4) {
            p_values.push(mcmc_core::balance::invariance::ks_two_sample(c1, c2).1);
        }
    }
    let n = p_values.len();
    let min = p_values.iter().cloned().fold(1.0, f64::min);
    println!("broken partial inverse: {n} KS tests, smallest p = {min:.2e}");
    assert!(n >= 4);
    assert!(min * n as f64 <= 1e-4, "not caught: smallest p = {min:.2e}");
}
