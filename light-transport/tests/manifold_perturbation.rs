//! The manifold perturbation (Jakob & Marschner 2012, §5.1) through a specular chain, checked
//! against densities written here from scratch, on a scene where the specular manifold has a
//! closed form: a planar mirror. A path `… x ↔ m ↔ y …` through a mirror point `m` has the
//! generalised geometry term of the unfolded path,
//! `G(x ↔ m ↔ y) = |cos θ_x| |cos θ_y| / (|x − m| + |m − y|)²`,
//! and the mirror's delta contributes its reflectance `ρ = 0.95`. With the mirror vertex
//! integrated out, the contribution of a path is a function of its non-specular vertices:
//!
//! * `P1 = light → mirror → floor → lens`: `F = L_e G(x_0 ↔ m ↔ x_2) ρ f_floor G(x_2, lens) W_e`;
//! * `P2 = light → floor → mirror → lens`: `F = L_e G(x_0, x_1) f_floor ρ G(x_1 ↔ m ↔ lens) W_e`.
//!
//! Each path has one strategy toward the light (a direction move from the lens) and two toward the
//! eye (a direction move from the light, and a position move of the light point), each chosen with
//! probability ½. The first chain from `x_a` to `x_b` is traced; the second is walked (`P1` from
//! the lens and `P2` from the light walk the mirror vertex; a position move walks the chain from
//! the light point to the next non-specular vertex, which on `P1` is the mirror vertex). A
//! direction move has `T = D(ω') / |cos θ_a| · G(x_a ↔ … ↔ x'_b)`, with `D` the von Mises–Fisher
//! density written here (concentration such that `D(ω) = λ² p(ω)`, `p` the camera's or the
//! emitter's directional density at the current direction); a position move has the Gaussian
//! density of variance `ρ/(2πλ²)` in the light's plane, `ρ` the area of the light (one triangle).
//!
//! Checks: (b) the reported log acceptance ratio equals `ln[I(F(ȳ)) T(x̄|ȳ) / (I(F(x̄)) T(ȳ|x̄))]`
//! from these formulas, in both directions on both paths (the walk's tolerance, 1e-7 of the
//! scene's size, limits the agreement: 1e-5 in the log is asked); (a) `E[h(ȳ)/T(ȳ|x̄)]` over
//! proposals equals the area of a floor patch (`h` its indicator) — which holds only when `T` is
//! the density the sampler draws from *and* walks that should succeed do (a walk failing or found
//! non-reversible loses its mass). z-tests with fixed seeds, |z| < 4.5 (false-positive rate
//! 6.8e-6 per check); the same estimates with `T × 1.15` must fail.

mod common;

use common::vmf_pdf;
use light_transport::geometry::Ray;
use light_transport::math::DVec3;
use light_transport::metropolis::ImportanceKind;
use light_transport::path::{Vertex, VertexKind};
use light_transport::pathspace::{FullPath, Mutations, NewPath, PathState};
use light_transport::scene::builtin::SceneBuilder;
use light_transport::scene::{MaterialDesc, Projection, Scene};
use light_transport::spectrum::Rgb;
use mcmc_core::ChainRng;
use mcmc_core::rng::stream;
use std::f64::consts::{PI, TAU};
use std::sync::OnceLock;

const W: usize = 64;
const H: usize = 48;
const EYE: DVec3 = DVec3::new(2.0, 1.2, 2.5);
const TARGET: DVec3 = DVec3::new(-0.8, 0.3, -0.5);
const ALBEDO: f64 = 0.5;
const MIRROR: f64 = 0.95;
const MIRROR_X: f64 = -1.5;
const LAMBDA: f64 = 50.0;
const Z_LIMIT: f64 = 4.5;
const BROKEN_SCALE: f64 = 1.15;
const LENS_RADIUS: f64 = 0.02;
/// The emitter is a 0.5 × 0.5 quad: two triangles, each a light of this area.
const LIGHT_TRIANGLE_AREA: f64 = 0.125;

fn scene() -> &'static Scene {
    static S: OnceLock<Scene> = OnceLock::new();
    S.get_or_init(|| {
        let mut b = SceneBuilder::new(W, H, EYE, TARGET, 60.0);
        let floor = b.matte(ALBEDO, ALBEDO, ALBEDO);
        let mirror = b.material(MaterialDesc::Mirror {
            kr: Rgb::splat(MIRROR),
        });
        let black = b.matte(0.0, 0.0, 0.0);
        // floor y = 0, normal +y
        b.quad(
            DVec3::new(-2.0, 0.0, -2.0),
            DVec3::Z * 4.0,
            DVec3::X * 4.0,
            floor,
            None,
        );
        // mirror x = −1.5, normal +x
        b.quad(
            DVec3::new(MIRROR_X, 0.0, -2.0),
            DVec3::Y * 2.0,
            DVec3::Z * 4.0,
            mirror,
            None,
        );
        // emitter facing down
        b.quad(
            DVec3::new(-0.25, 1.99, -0.45),
            DVec3::X * 0.5,
            DVec3::Z * 0.5,
            black,
            Some(Rgb::new(20.0, 18.0, 15.0)),
        );
        // A thin lens (radius 0.02, in focus at the floor), so that the lens point moves too.
        let mut d = b.finish();
        if let Some(c) = d.camera.as_mut() {
            c.projection = Projection::Perspective {
                fov: 60f64.to_radians(),
                lens_radius: LENS_RADIUS,
                focal_distance: 4.0,
            };
        }
        Scene::new(&d, None).expect("scene")
    })
}

fn dir(a: DVec3, b: DVec3) -> DVec3 {
    (b - a).normalize()
}

/// The surface point `target`, found by tracing from `origin`.
fn vertex_at(origin: DVec3, target: DVec3) -> Vertex {
    let s = scene();
    let hit = s
        .intersect(&Ray::new(origin, dir(origin, target)))
        .expect("hit");
    assert!((hit.point.p - target).length() < 1e-9, "{:?}", hit.point.p);
    let kind = match s.light_at(hit.point.primitive) {
        Some((i, _)) => VertexKind::Light { light: i as u32 },
        None => VertexKind::Surface,
    };
    Vertex {
        kind,
        point: hit.point,
        wo: DVec3::ZERO,
        bsdf: s.bsdf(&hit.point).ok(),
        beta: Rgb::BLACK,
        delta: false,
        pdf_fwd: 0.0,
        pdf_rev: 0.0,
    }
}

fn lens() -> Vertex {
    let s = scene();
    Vertex {
        kind: VertexKind::Camera,
        point: s.camera.lens_point(s.camera.position()),
        wo: DVec3::ZERO,
        bsdf: None,
        beta: Rgb::BLACK,
        delta: false,
        pdf_fwd: 0.0,
        pdf_rev: 0.0,
    }
}

/// The mirror point between `a` and `b` (reflect `a` through the mirror's plane).
fn mirror_point(a: DVec3, b: DVec3) -> DVec3 {
    let a2 = DVec3::new(2.0 * MIRROR_X - a.x, a.y, a.z);
    let t = (MIRROR_X - a2.x) / (b.x - a2.x);
    a2 + (b - a2) * t
}

fn state(mut vertices: Vec<Vertex>, mirror: usize) -> PathState {
    vertices[mirror].delta = true;
    let mut s = PathState {
        path: FullPath { vertices },
        ..Default::default()
    };
    assert!(
        s.evaluate(scene(), ImportanceKind::Luminance, 1.0),
        "hand-made path carries no light"
    );
    s
}

const X0: DVec3 = DVec3::new(0.0, 1.99, -0.2);
const P1_FLOOR: DVec3 = DVec3::new(-0.6, 0.0, -0.3);
const P2_FLOOR: DVec3 = DVec3::new(-1.0, 0.0, 0.4);

/// `light → mirror → floor → lens`.
fn p1() -> PathState {
    let m = mirror_point(X0, P1_FLOOR);
    let v0 = vertex_at(X0 - DVec3::Y * 0.5, X0);
    let v1 = vertex_at(m + DVec3::X * 0.5, m);
    let v2 = vertex_at(P1_FLOOR + DVec3::Y * 0.5, P1_FLOOR);
    state(vec![v0, v1, v2, lens()], 1)
}

/// `light → floor → mirror → lens`.
fn p2() -> PathState {
    let m = mirror_point(EYE, P2_FLOOR);
    let v0 = vertex_at(X0 - DVec3::Y * 0.5, X0);
    let v1 = vertex_at(P2_FLOOR + DVec3::Y * 0.5, P2_FLOOR);
    let v2 = vertex_at(m + DVec3::X * 0.5, m);
    state(vec![v0, v1, v2, lens()], 2)
}

/// `|cos|` at a point of the scene (`None`: the lens, whose cosine is the viewing axis').
fn cos_at(n: Option<DVec3>, w: DVec3) -> f64 {
    match n {
        Some(n) => n.dot(w).abs(),
        None => scene().camera.forward().dot(w).abs(),
    }
}

/// `G(x ↔ y)`, or through the mirror point `m` (unfolded).
fn geometry(x: DVec3, nx: Option<DVec3>, m: Option<DVec3>, y: DVec3, ny: Option<DVec3>) -> f64 {
    let (first, last, len) = match m {
        Some(m) => (m, m, (m - x).length() + (y - m).length()),
        None => (y, x, (y - x).length()),
    };
    cos_at(nx, dir(x, first)) * cos_at(ny, dir(y, last)) / (len * len)
}

/// The camera's importance of the ray from lens point `lens` toward `to`.
fn we(lens: DVec3, to: DVec3) -> f64 {
    scene().camera.importance(lens, dir(lens, to)).0
}

fn le(x0: DVec3, to: DVec3) -> f64 {
    // A Lambertian emitter facing −y: the luminance of its radiance where it emits.
    let l = 0.2126 * 20.0 + 0.7152 * 18.0 + 0.0722 * 15.0;
    if dir(x0, to).y < 0.0 { l } else { 0.0 }
}

/// `I(F)` of a path of the shape of `P1` (`mirror_first`) or `P2`, from its vertex positions.
fn importance(p: &[DVec3], mirror_first: bool) -> f64 {
    let ny = Some(DVec3::Y);
    let f_floor = ALBEDO / PI;
    if mirror_first {
        le(p[0], p[1])
            * geometry(p[0], Some(-DVec3::Y), Some(p[1]), p[2], ny)
            * MIRROR
            * f_floor
            * geometry(p[2], ny, None, p[3], None)
            * we(p[3], p[2])
    } else {
        le(p[0], p[1])
            * geometry(p[0], Some(-DVec3::Y), None, p[1], ny)
            * f_floor
            * MIRROR
            * geometry(p[1], ny, Some(p[2]), p[3], None)
            * we(p[3], p[2])
    }
}

/// `T(to|from)` of the perturbation from the lens (`from_lens`) or the light, on paths of the
/// shape of `P1` (`mirror_first`) or `P2`.
fn transition(from: &[DVec3], to: &[DVec3], mirror_first: bool, from_lens: bool) -> f64 {
    let s = scene();
    let ny = Some(DVec3::Y);
    let down = Some(-DVec3::Y);
    if from_lens && (to[3] - from[3]).length() > 0.0 {
        // A position move of the lens point (one of the two strategies from the lens): a Gaussian
        // of variance ρ/(2πλ²) = R²/(2λ²) in the lens plane.
        let var = LENS_RADIUS * LENS_RADIUS / (2.0 * LAMBDA * LAMBDA);
        let d2 = (to[3] - from[3]).length_squared();
        0.5 * (-d2 / (2.0 * var)).exp() / (TAU * var)
    } else if from_lens {
        // A direction move from the lens (the other of its two strategies).
        let (wx, wy) = (dir(from[3], from[2]), dir(to[3], to[2]));
        let p = s.camera.importance(from[3], wx).1;
        let d = 0.5 * vmf_pdf(LAMBDA * LAMBDA * p, wx, wy) / cos_at(None, wy);
        if mirror_first {
            d * geometry(to[3], None, None, to[2], ny)
        } else {
            d * geometry(to[3], None, Some(to[2]), to[1], ny)
        }
    } else if (to[0] - from[0]).length() > 0.0 {
        // A position move of the light point (one of the two strategies from the light): a
        // Gaussian of variance ρ/(2πλ²) in the light's plane, ρ the area of its triangle.
        let var = LIGHT_TRIANGLE_AREA / (TAU * LAMBDA * LAMBDA);
        let d2 = (to[0] - from[0]).length_squared();
        0.5 * (-d2 / (2.0 * var)).exp() / (TAU * var)
    } else {
        // A direction move from the light (the other of its two strategies).
        let (wx, wy) = (dir(from[0], from[1]), dir(to[0], to[1]));
        let p = wx.dot(-DVec3::Y).max(0.0) / PI;
        let d = 0.5 * vmf_pdf(LAMBDA * LAMBDA * p, wx, wy) / cos_at(down, wy);
        if mirror_first {
            d * geometry(to[0], down, Some(to[1]), to[2], ny)
        } else {
            d * geometry(to[0], down, None, to[1], ny)
        }
    }
}

fn positions(s: &PathState) -> Vec<DVec3> {
    s.path.vertices.iter().map(|v| v.p()).collect()
}

fn propose(
    name: &str,
    x: &PathState,
    rng: &mut ChainRng,
    y: &mut PathState,
) -> Result<f64, mcmc_core::Failure> {
    let m = Mutations::new(4);
    let settings = m.settings(NewPath::uniform(4));
    let mutation = Mutations::mutation(scene(), &settings, name).expect("registered");
    mutation.propose_ratio(x, rng, y)
}

/// The cases: (path, mirror first, from the lens, mutation, which vertex the numerical check
/// watches — `x_b`, or the light point for the position moves of the last two).
fn cases() -> Vec<(PathState, bool, bool, &'static str, usize)> {
    vec![
        (p1(), true, true, "manifold-light", 2),
        (p1(), true, false, "manifold-eye", 2),
        (p2(), false, true, "manifold-light", 1),
        (p2(), false, false, "manifold-eye", 1),
        (p1(), true, false, "manifold-eye", 0),
        (p2(), false, false, "manifold-eye", 0),
        (p1(), true, true, "manifold-light", 3),
        (p2(), false, true, "manifold-light", 3),
    ]
}

#[test]
fn reported_ratios_match_the_closed_forms() {
    for (x, mirror_first, from_lens, name, _) in cases() {
        let xp = positions(&x);
        let (mut compared, mut failed, mut worst) = (0, 0, 0.0f64);
        let mut y = PathState::default();
        for i in 0..500u64 {
            let mut rng = stream(31, i);
            let Ok(reported) = propose(name, &x, &mut rng, &mut y) else {
                failed += 1;
                continue;
            };
            let yp = positions(&y);
            let mine = importance(&yp, mirror_first).ln()
                + transition(&yp, &xp, mirror_first, from_lens).ln()
                - importance(&xp, mirror_first).ln()
                - transition(&xp, &yp, mirror_first, from_lens).ln();
            if reported == f64::NEG_INFINITY {
                // Only outside the image or the emitter's hemisphere.
                assert!(
                    !mine.is_finite() || y.path.raster(scene()).is_none(),
                    "{name}: −∞ reported, independent {mine}"
                );
                continue;
            }
            compared += 1;
            worst = worst.max((reported - mine).abs());
        }
        println!(
            "{name} on {}: compared {compared}, failed {failed}, worst |Δ ln ratio| {worst:.2e}",
            if mirror_first { "P1" } else { "P2" }
        );
        assert!(compared >= 400, "{name}: only {compared} compared");
        assert!(worst < 1e-5, "{name}: ratios differ by {worst}");
    }
}

/// `(mean, standard error, z)` of `E[h/T]` against `area`, and the same with `T × 1.15`.
fn numerical(case: usize, n: usize, seed: u64) -> ((f64, f64, f64), (f64, f64, f64), usize) {
    let (x, mirror_first, from_lens, name, b) = cases().swap_remove(case);
    let xp = positions(&x);
    let c = xp[b];
    // The patch: sized from the spread of 2000 pilot proposals (other seeds), beside x_b.
    let mut y = PathState::default();
    let mut spread = 0.0;
    let mut pilots = 0;
    for i in 0..2000u64 {
        let mut rng = stream(seed ^ 0xF00D, i);
        if propose(name, &x, &mut rng, &mut y).is_ok() && y.carries_light() {
            spread += (positions(&y)[b] - c).length_squared();
            pilots += 1;
        }
    }
    let sigma = (spread / pilots.max(1) as f64).sqrt();
    // Coordinates in the watched vertex's plane: x and z on the floor and the light (normal ±y),
    // the lens's right and up axes on the lens.
    let forward = scene().camera.forward();
    let right = forward.cross(DVec3::Y).normalize();
    let up = right.cross(forward);
    let coords = |p: DVec3| {
        let d = p - c;
        if b == 3 {
            (d.dot(right), d.dot(up))
        } else {
            (d.x, d.z)
        }
    };
    let (lo, hi) = ((0.1 * sigma, -0.6 * sigma), (1.0 * sigma, 0.5 * sigma));
    let area = (hi.0 - lo.0) * (hi.1 - lo.1);
    let (mut s, mut s2, mut bs, mut bs2, mut hits) = (0.0, 0.0, 0.0, 0.0, 0);
    for i in 0..n as u64 {
        let mut rng = stream(seed, i);
        if propose(name, &x, &mut rng, &mut y).is_err() || !y.carries_light() {
            continue;
        }
        let yp = positions(&y);
        let (u, v) = coords(yp[b]);
        if u < lo.0 || u > hi.0 || v < lo.1 || v > hi.1 {
            continue;
        }
        hits += 1;
        let v = 1.0 / transition(&xp, &yp, mirror_first, from_lens);
        s += v;
        s2 += v * v;
        bs += v / BROKEN_SCALE;
        bs2 += (v / BROKEN_SCALE).powi(2);
    }
    let stats = |s: f64, s2: f64| {
        let mean = s / n as f64;
        let var = (s2 / n as f64 - mean * mean) * n as f64 / (n - 1) as f64;
        let se = (var / n as f64).sqrt();
        (mean, se, (mean - area) / se)
    };
    let (good, broken) = (stats(s, s2), stats(bs, bs2));
    println!(
        "{name} on {}: N = {n}, hits {hits}, area {area:.3e}: E[h/T] = {:.4e} ± {:.1e} (z = {:+.2}); \
         × 1.15: z = {:+.2}",
        if mirror_first { "P1" } else { "P2" },
        good.0,
        good.1,
        good.2,
        broken.2
    );
    (good, broken, hits)
}

#[test]
fn the_sampler_draws_from_the_reported_density() {
    for case in 0..8 {
        let n = std::env::var("MANIFOLD_N")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(100_000);
        let (good, broken, hits) = numerical(case, n, 700 + case as u64);
        assert!(hits >= 1000, "case {case}: only {hits} hits");
        assert!(good.2.abs() < Z_LIMIT, "case {case}: z = {}", good.2);
        assert!(
            broken.2.abs() >= Z_LIMIT,
            "case {case}: the broken density passes"
        );
    }
}
