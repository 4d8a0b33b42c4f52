//! Helpers shared by the statistical tests: Welch tests over independent replicates with Holm's
//! correction, and the BDPT reference of the convergence tests (6×6 blocks of a 36×30 image).

#![allow(dead_code)]

use light_transport::Budget;
use light_transport::film::{Film, FilmView, Image};
use light_transport::integrators::{Bdpt, render};
use light_transport::metropolis::{self, Method, MetropolisSettings, MetropolisStats, Seeding};
use light_transport::path::{MisHeuristic, WalkSettings};
use light_transport::renderer::{Control, Progress, Renderer};
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
        roulette: None,
        shadow_roulette: None,
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
        refine_normalisation: true,
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

/// `runs` renders of `renderer` within `budget`, seeds `seed`, `seed + 1`, …, as 6×6 blocks;
/// each must discard nothing and run to its end.
pub fn renderer_runs(
    scene: &Scene,
    renderer: &dyn Renderer,
    budget: Budget,
    seed: u64,
    runs: u64,
) -> Vec<Vec<f64>> {
    (0..runs)
        .map(|r| {
            let mut go_on = |_: FilmView<'_>, _: &Progress| true;
            let mut control = Control {
                progress: &mut go_on,
                stop: None,
            };
            let (film, report) = renderer
                .render(scene, budget, seed + r, &mut control)
                .unwrap();
            assert_eq!(film.discarded, 0);
            assert!(!report.interrupted);
            blocks(&Image::from_film(&film))
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

/// A test scene for shading normals: a box (diffuse walls, open at the front) under a ceiling
/// light, holding four coarsely tessellated mesh spheres with smooth vertex normals — matte
/// (8 × 4 facets), layered plastic (10 × 5), rough metal (8 × 4) and smooth glass (12 × 6) —
/// whose shading normals are up to ~40° from their facets' geometric normals.
pub fn smooth_spheres() -> light_transport::scene::SceneDescription {
    use light_transport::math::DVec3;
    use light_transport::scene::builtin::SceneBuilder;
    use light_transport::scene::{MaterialDesc, RgbTexture};
    use light_transport::spectrum::Rgb;
    let mut s = SceneBuilder::new(
        36,
        30,
        DVec3::new(0.0, 1.0, 6.8),
        DVec3::new(0.0, 1.0, 0.0),
        19.5,
    );
    let white = s.matte(0.7, 0.7, 0.7);
    let red = s.matte(0.6, 0.1, 0.05);
    let black = s.matte(0.0, 0.0, 0.0);
    let plastic = s.material(MaterialDesc::Layered {
        kd: RgbTexture::Constant(Rgb::new(0.2, 0.3, 0.5)),
        ks: Rgb::splat(0.8),
        alpha_u: 0.1,
        alpha_v: 0.1,
        eta: 1.5,
    });
    let metal = s.material(MaterialDesc::Metal {
        eta: Rgb::new(0.2, 0.92, 1.1),
        k: Rgb::new(3.9, 2.45, 2.14),
        alpha_u: 0.2,
        alpha_v: 0.2,
    });
    let glass = s.material(MaterialDesc::Glass {
        eta: 1.5,
        alpha_u: 0.0,
        alpha_v: 0.0,
        kr: Rgb::WHITE,
        kt: Rgb::WHITE,
    });
    let (x, y, z) = (DVec3::X * 2.0, DVec3::Y * 2.0, DVec3::Z * 2.0);
    let o = DVec3::new(-1.0, 0.0, -1.0);
    s.quad(o, z, x, white, None); // floor
    s.quad(o + y, x, z, white, None); // ceiling
    s.quad(o, x, y, white, None); // back
    s.quad(o, y, z, red, None); // left
    s.quad(o + x, z, y, white, None); // right
    s.quad(
        DVec3::new(-0.25, 1.98, -0.25),
        DVec3::X * 0.5,
        DVec3::Z * 0.5,
        black,
        Some(Rgb::splat(15.0)),
    );
    s.mesh_sphere(DVec3::new(-0.5, 0.35, -0.4), 0.35, 8, 4, white);
    s.mesh_sphere(DVec3::new(0.1, 1.2, -0.5), 0.3, 10, 5, plastic);
    s.mesh_sphere(DVec3::new(0.55, 1.0, -0.6), 0.25, 8, 4, metal);
    s.mesh_sphere(DVec3::new(0.45, 0.35, 0.3), 0.35, 12, 6, glass);
    s.finish()
}

/// A test scene where the adjoint correction of shading normals matters everywhere: a matte
/// floor (`y = 0`, geometric normal `+y`) whose vertex normals all lean 30° toward `+x`, seen from
/// above and lit at grazing angles by a wall light on the `+x` side. At the floor the light-side
/// factor `|ω_l·n_s| / |ω_l·n_g|` is about 2, the camera-side one about 0.9.
pub fn tilted_floor() -> light_transport::scene::SceneDescription {
    use light_transport::math::DVec3;
    use light_transport::scene::builtin::SceneBuilder;
    use light_transport::spectrum::Rgb;
    let mut s = SceneBuilder::new(
        36,
        30,
        DVec3::new(-0.5, 3.0, 1.2),
        DVec3::new(0.0, 0.0, 0.0),
        50.0,
    );
    let floor = s.matte(0.6, 0.6, 0.6);
    let black = s.matte(0.0, 0.0, 0.0);
    let a = 30f64.to_radians();
    let ns = DVec3::new(a.sin(), a.cos(), 0.0);
    s.mesh(
        vec![
            DVec3::new(-3.0, 0.0, -3.0),
            DVec3::new(-3.0, 0.0, 3.0),
            DVec3::new(3.0, 0.0, 3.0),
            DVec3::new(3.0, 0.0, -3.0),
        ],
        Some(vec![ns; 4]),
        vec![[0, 1, 2], [0, 2, 3]],
        floor,
    );
    // The wall light at x = 3.5, facing −x.
    s.quad(
        DVec3::new(3.5, 0.3, -2.0),
        DVec3::Z * 4.0,
        DVec3::Y * 1.2,
        black,
        Some(Rgb::splat(4.0)),
    );
    s.finish()
}

/// Density of the von Mises–Fisher distribution about `mean` whose density at `mean` is `peak`,
/// at `w`: `κ e^{κ(μ·w − 1)} / (2π (1 − e^{−2κ}))`, `κ` found here by bisection (written
/// independently of the library's, for the manifold perturbation's density checks).
pub fn vmf_pdf(
    peak: f64,
    mean: light_transport::math::DVec3,
    w: light_transport::math::DVec3,
) -> f64 {
    use std::f64::consts::TAU;
    let at_mean = |k: f64| k / (TAU * (1.0 - (-2.0 * k).exp()));
    let (mut lo, mut hi) = (1e-9f64, 1e12f64);
    for _ in 0..300 {
        let mid = (lo * hi).sqrt();
        if at_mean(mid) < peak {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let k = (lo * hi).sqrt();
    k * (k * (mean.dot(w) - 1.0)).exp() / (TAU * (1.0 - (-2.0 * k).exp()))
}

/// `f` run on a pool of `threads` threads (for tests that images do not depend on the count).
pub fn with_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
        .install(f)
}
