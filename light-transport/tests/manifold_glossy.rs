//! The manifold perturbation through glossy vertices (Jakob & Marschner 2012, §5.2), checked
//! against densities written here from scratch on a scene whose offset manifold is simple: a flat
//! rough-metal wall without shading normals, so that a glossy vertex's shading frame is constant
//! and keeping its offset `o` means reflecting about one fixed world-space microfacet normal `m`.
//!
//! The path `x_0 (light) → g (wall) → x_2 (floor) → lens` has three strategies per direction. The
//! wall is glossy (GGX α = 0.05), so each time the perturbation passes `g` it joins the chain with
//! probability `ψ = (1 − cos θ_q)/(1 − cos(θ_q + Δθ))`, `tan θ_q = 3α` (q = 0.9), Δθ = 0.05:
//!
//! * toward the light: from the lens, `x_2` moves and `g` is walked on its offset manifold (ψ) or
//!   kept (1 − ψ); from `x_2`, `g` moves freely (1 − ψ; with ψ the chain would end at the light,
//!   which is no strategy); the lens point moves;
//! * toward the eye: from the light, `g` is followed about `m` to a new `x_2` (ψ) or `g` moves
//!   freely (1 − ψ); from `g`, `x_2` moves; the light point moves and `g` is walked (ψ) or kept.
//!
//! `T` here: `(1/3) P(classification) D(ω')/|cos θ_a| G_a` for a direction move (`D` the von
//! Mises–Fisher density with `D(ω) = λ² p(ω)`, `G_a` the plain geometry term, or through `g` about
//! the fixed `m` by central differences of the traced map from directions to floor points), a
//! Gaussian of variance `ρ/(2πλ²)` for a position move. `f` is the ordinary area-measure
//! contribution (the wall's BSDF value is the library's GGX; everything else is written here),
//! and a chain through `g` puts `f` in the measure of `(x_b, o)`: `f |det ∂x_g/∂o|`, from central
//! differences of `o(x_g)` with the neighbours fixed (eq. 12 for one glossy vertex).
//!
//! Checks: the reported log acceptance ratio against these formulas in both directions (the walk's
//! tolerance limits agreement: 1e-5 asked); the same comparison must fail for the library's
//! deliberate defects (eq. 12's determinant left out, the von Mises–Fisher density without its
//! `κ`, the first chain's geometry term left out); `E[h/T]` over proposals equals a patch's area
//! for one watched vertex in four glossy strategies (z-tests with fixed seeds, |z| < 4.5:
//! false-positive rate 6.8e-6 per check), and the same estimate with `T × 1.15` fails.

mod common;

use common::vmf_pdf;
use light_transport::bsdf::TransportMode;
use light_transport::geometry::Ray;
use light_transport::math::DVec3;
use light_transport::metropolis::ImportanceKind;
use light_transport::path::{Vertex, VertexKind};
use light_transport::pathspace::{FullPath, ManifoldDefect, Mutations, NewPath, PathState};
use light_transport::scene::builtin::SceneBuilder;
use light_transport::scene::{MaterialDesc, Projection, Scene};
use light_transport::spectrum::Rgb;
use mcmc_core::ChainRng;
use mcmc_core::rng::stream;
use std::f64::consts::{PI, TAU};
use std::sync::OnceLock;

const EYE: DVec3 = DVec3::new(2.0, 1.2, 2.5);
const ALBEDO: f64 = 0.5;
const WALL_X: f64 = -1.5;
const ALPHA: f64 = 0.05;
const LAMBDA: f64 = 50.0;
const Z_LIMIT: f64 = 4.5;
const BROKEN_SCALE: f64 = 1.15;
const LENS_RADIUS: f64 = 0.02;
const LIGHT_TRIANGLE_AREA: f64 = 0.125;
const X0: DVec3 = DVec3::new(0.0, 1.99, -0.2);
const FLOOR: DVec3 = DVec3::new(-0.6, 0.0, -0.3);

fn scene() -> &'static Scene {
    static S: OnceLock<Scene> = OnceLock::new();
    S.get_or_init(|| {
        let mut b = SceneBuilder::new(64, 48, EYE, DVec3::new(-0.8, 0.3, -0.5), 60.0);
        let floor = b.matte(ALBEDO, ALBEDO, ALBEDO);
        let metal = b.material(MaterialDesc::Metal {
            eta: Rgb::new(0.2, 0.92, 1.1),
            k: Rgb::new(3.9, 2.45, 2.14),
            alpha_u: ALPHA,
            alpha_v: ALPHA,
        });
        let black = b.matte(0.0, 0.0, 0.0);
        b.quad(
            DVec3::new(-2.0, 0.0, -2.0),
            DVec3::Z * 4.0,
            DVec3::X * 4.0,
            floor,
            None,
        );
        b.quad(
            DVec3::new(WALL_X, 0.0, -2.0),
            DVec3::Y * 2.0,
            DVec3::Z * 4.0,
            metal,
            None,
        );
        b.quad(
            DVec3::new(-0.25, 1.99, -0.45),
            DVec3::X * 0.5,
            DVec3::Z * 0.5,
            black,
            Some(Rgb::new(20.0, 18.0, 15.0)),
        );
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

/// `light → g → floor → lens`, `g` beside the wall's mirror point so that its offset is not 0.
fn path() -> PathState {
    let s = scene();
    let a2 = DVec3::new(2.0 * WALL_X - X0.x, X0.y, X0.z);
    let t = (WALL_X - a2.x) / (FLOOR.x - a2.x);
    let g = a2 + (FLOOR - a2) * t + DVec3::new(0.0, 0.03, 0.02);
    let lens = Vertex {
        kind: VertexKind::Camera,
        point: s.camera.lens_point(s.camera.position()),
        wo: DVec3::ZERO,
        bsdf: None,
        beta: Rgb::BLACK,
        delta: false,
        pdf_fwd: 0.0,
        pdf_rev: 0.0,
    };
    let vertices = vec![
        vertex_at(X0 - DVec3::Y * 0.5, X0),
        vertex_at(g + DVec3::X * 0.5, g),
        vertex_at(FLOOR + DVec3::Y * 0.5, FLOOR),
        lens,
    ];
    let mut st = PathState {
        path: FullPath { vertices },
        ..Default::default()
    };
    assert!(st.evaluate(s, ImportanceKind::Luminance, 1.0), "no light");
    st
}

fn positions(s: &PathState) -> Vec<DVec3> {
    s.path.vertices.iter().map(|v| v.p()).collect()
}

/// ψ of the wall (eq. 28 with the GGX quantile).
fn psi() -> f64 {
    let theta = (3.0 * ALPHA).atan();
    (1.0 - theta.cos()) / (1.0 - (theta + 0.05).cos())
}

fn lum(r: f64, g: f64, b: f64) -> f64 {
    0.2126 * r + 0.7152 * g + 0.0722 * b
}

/// The wall's microfacet normal at `g` between `x0` and `x2`.
fn micro_normal(x0: DVec3, g: DVec3, x2: DVec3) -> DVec3 {
    (dir(g, x0) + dir(g, x2)).normalize()
}

/// `|det ∂x_g/∂o|` with the neighbours fixed: `o` in the wall's (y, z) frame, by central
/// differences.
fn offset_jacobian(x0: DVec3, g: DVec3, x2: DVec3) -> f64 {
    let h = 1e-6;
    let o = |g: DVec3| {
        let m = micro_normal(x0, g, x2);
        (m.y, m.z)
    };
    let d = |e: DVec3| {
        let (a, b) = (o(g + e * h), o(g - e * h));
        ((a.0 - b.0) / (2.0 * h), (a.1 - b.1) / (2.0 * h))
    };
    let (cy, cz) = (d(DVec3::Y), d(DVec3::Z));
    1.0 / (cy.0 * cz.1 - cy.1 * cz.0).abs()
}

/// The camera's importance, `(W_e, directional density)`.
fn camera(lens: DVec3, w: DVec3) -> (f64, f64) {
    let (we, pdf, _) = scene().camera.importance(lens, w);
    (we, pdf)
}

/// `f` of `light → g → floor → lens` in area measure, as a luminance.
fn f_area(p: &[DVec3]) -> f64 {
    let s = scene();
    let (x0, g, x2, lens) = (p[0], p[1], p[2], p[3]);
    if dir(x0, g).y >= 0.0 {
        return 0.0;
    }
    let hit = s
        .intersect(&Ray::new(g + DVec3::X * 0.5, -DVec3::X))
        .expect("wall");
    let mut point = hit.point;
    point.p = g;
    let bsdf = s.bsdf(&point).expect("metal");
    let fg = bsdf.eval(dir(g, x2), dir(g, x0), TransportMode::Radiance);
    let le = Rgb::new(20.0, 18.0, 15.0);
    let c = le * fg;
    let geo = |a: DVec3, na: DVec3, b: DVec3, nb: DVec3| {
        let w = dir(a, b);
        na.dot(w).abs() * nb.dot(w).abs() / (b - a).length_squared()
    };
    let cam_cos = s.camera.forward().dot(dir(lens, x2)).abs();
    lum(c.0[0], c.0[1], c.0[2])
        * geo(x0, DVec3::Y, g, DVec3::X)
        * geo(g, DVec3::X, x2, DVec3::Y)
        * (ALBEDO / PI)
        * (cam_cos * DVec3::Y.dot(dir(x2, lens)).abs() / (lens - x2).length_squared())
        * camera(lens, dir(lens, x2)).0
}

/// The strategies, told apart by which vertices moved.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Move {
    /// From the lens, `x_2` moved, `g` walked (ψ) — or kept (`walked` false).
    LensDirection { walked: bool },
    /// From `x_2`, `g` moved (1 − ψ).
    FloorDirection,
    /// The lens point moved.
    LensPosition,
    /// From the light, `g` followed about `m` to a new `x_2` (ψ) — or `g` moved freely.
    LightDirection { followed: bool },
    /// From `g`, `x_2` moved.
    GlossyDirection,
    /// The light point moved, `g` walked (ψ) or kept.
    LightPosition { walked: bool },
}

fn classify(x: &[DVec3], y: &[DVec3], toward_light: bool) -> Move {
    let moved = |i: usize| (x[i] - y[i]).length() > 1e-12;
    if toward_light {
        if moved(3) {
            Move::LensPosition
        } else if moved(2) {
            Move::LensDirection { walked: moved(1) }
        } else {
            Move::FloorDirection
        }
    } else if moved(0) {
        Move::LightPosition { walked: moved(1) }
    } else if moved(2) && moved(1) {
        Move::LightDirection { followed: true }
    } else if moved(2) {
        Move::GlossyDirection
    } else {
        Move::LightDirection { followed: false }
    }
}

/// Whether the move puts `g` in a chain (and `f` in the measure of `o`).
fn chained(m: Move) -> bool {
    matches!(
        m,
        Move::LensDirection { walked: true }
            | Move::LightDirection { followed: true }
            | Move::LightPosition { walked: true }
    )
}

fn geometry(a: DVec3, na: f64, b: DVec3, nb: DVec3) -> f64 {
    na * nb.dot(dir(b, a)).abs() / (b - a).length_squared()
}

/// `G_a` of the light's direction followed about `m` to the floor: `|cos θ_0| / (dA_2/dω)`, the
/// area per solid angle from central differences of the traced map.
fn followed_geometry(x0: DVec3, w0: DVec3, m: DVec3) -> f64 {
    let floor_point = |w: DVec3| {
        let t = (WALL_X - x0.x) / w.x;
        let g = x0 + w * t;
        let r = w - m * (2.0 * w.dot(m));
        g + r * (-g.y / r.y)
    };
    let e1 = w0.cross(DVec3::Z).normalize();
    let e2 = w0.cross(e1);
    let h = 1e-6;
    let d = |e: DVec3| {
        (floor_point((w0 + e * h).normalize()) - floor_point((w0 - e * h).normalize())) / (2.0 * h)
    };
    let area = d(e1).cross(d(e2)).length();
    w0.y.abs() / area
}

/// `T(to|from)` of the move `m` (the probability of its strategy included).
fn transition(from: &[DVec3], to: &[DVec3], m: Move) -> f64 {
    let s = scene();
    let p = psi();
    let choose = 1.0 / 3.0;
    let vmf =
        |mean: DVec3, w: DVec3, pdf: f64, cos: f64| vmf_pdf(LAMBDA * LAMBDA * pdf, mean, w) / cos;
    let gauss = |var: f64, a: DVec3, b: DVec3| {
        (-(b - a).length_squared() / (2.0 * var)).exp() / (TAU * var)
    };
    let cam_cos = |w: DVec3| s.camera.forward().dot(w).abs();
    match m {
        Move::LensPosition => {
            choose
                * gauss(
                    LENS_RADIUS * LENS_RADIUS / (2.0 * LAMBDA * LAMBDA),
                    from[3],
                    to[3],
                )
        }
        Move::LightPosition { walked } => {
            let class = if walked { p } else { 1.0 - p };
            choose
                * class
                * gauss(
                    LIGHT_TRIANGLE_AREA / (TAU * LAMBDA * LAMBDA),
                    from[0],
                    to[0],
                )
        }
        Move::LensDirection { walked } => {
            let class = if walked { p } else { 1.0 - p };
            let (wx, wy) = (dir(from[3], from[2]), dir(to[3], to[2]));
            choose
                * class
                * vmf(wx, wy, camera(from[3], wx).1, cam_cos(wy))
                * geometry(to[3], cam_cos(wy), to[2], DVec3::Y)
        }
        Move::FloorDirection => {
            let (wx, wy) = (dir(from[2], from[1]), dir(to[2], to[1]));
            choose
                * (1.0 - p)
                * vmf(wx, wy, wx.y.abs() / PI, wy.y.abs())
                * geometry(to[2], wy.y.abs(), to[1], DVec3::X)
        }
        Move::LightDirection { followed } => {
            let (wx, wy) = (dir(from[0], from[1]), dir(to[0], to[1]));
            let d = vmf(wx, wy, wx.y.abs() / PI, wy.y.abs());
            if followed {
                let mn = micro_normal(to[0], to[1], to[2]);
                choose * p * d * followed_geometry(to[0], wy, mn)
            } else {
                choose * (1.0 - p) * d * geometry(to[0], wy.y.abs(), to[1], DVec3::X)
            }
        }
        Move::GlossyDirection => {
            // The GGX sampling density at g (the library's), arriving from the light.
            let hit = s
                .intersect(&Ray::new(from[1] + DVec3::X * 0.5, -DVec3::X))
                .expect("wall");
            let mut point = hit.point;
            point.p = from[1];
            let bsdf = s.bsdf(&point).expect("metal");
            let (wx, wy) = (dir(from[1], from[2]), dir(to[1], to[2]));
            let pdf = bsdf.pdf(dir(from[1], from[0]), wx);
            choose * vmf(wx, wy, pdf, wy.x.abs()) * geometry(to[1], wy.x.abs(), to[2], DVec3::Y)
        }
    }
}

/// `f` in the measure the move uses.
fn target(p: &[DVec3], m: Move) -> f64 {
    let f = f_area(p);
    if chained(m) {
        f * offset_jacobian(p[0], p[1], p[2])
    } else {
        f
    }
}

fn propose(
    name: &str,
    defect: Option<ManifoldDefect>,
    x: &PathState,
    rng: &mut ChainRng,
    y: &mut PathState,
) -> Result<f64, mcmc_core::Failure> {
    let mut m = Mutations::new(4);
    m.manifold.defect = defect;
    let settings = m.settings(NewPath::uniform(4));
    let mutation = Mutations::mutation(scene(), &settings, name).expect("registered");
    mutation.propose_ratio(x, rng, y)
}

/// Worst `|Δ ln ratio|` over 600 proposals per direction, and the moves seen.
fn compare(defect: Option<ManifoldDefect>) -> (f64, Vec<(Move, usize)>) {
    let x = path();
    let xp = positions(&x);
    let mut worst = 0.0f64;
    let mut seen: Vec<(Move, usize)> = Vec::new();
    let mut y = PathState::default();
    for (name, toward_light) in [("manifold-light", true), ("manifold-eye", false)] {
        for i in 0..600u64 {
            let mut rng = stream(57, i);
            let Ok(reported) = propose(name, defect, &x, &mut rng, &mut y) else {
                continue;
            };
            let yp = positions(&y);
            let m = classify(&xp, &yp, toward_light);
            let mine = target(&yp, m).ln() + transition(&yp, &xp, m).ln()
                - target(&xp, m).ln()
                - transition(&xp, &yp, m).ln();
            if reported == f64::NEG_INFINITY {
                assert!(
                    !mine.is_finite() || y.path.raster(scene()).is_none() || !y.carries_light(),
                    "{name} {m:?}: −∞ reported, independent {mine}"
                );
                continue;
            }
            worst = worst.max((reported - mine).abs());
            match seen.iter_mut().find(|(k, _)| *k == m) {
                Some((_, n)) => *n += 1,
                None => seen.push((m, 1)),
            }
        }
    }
    (worst, seen)
}

#[test]
fn reported_ratios_match_the_independent_densities() {
    let (worst, seen) = compare(None);
    println!(
        "ψ = {:.3}; moves compared: {seen:?}; worst |Δ ln ratio| {worst:.2e}",
        psi()
    );
    assert_eq!(seen.len(), 9, "every strategy and classification seen");
    assert!(seen.iter().all(|(_, n)| *n >= 20), "{seen:?}");
    assert!(worst < 1e-5, "ratios differ by {worst}");
}

#[test]
fn the_defects_change_the_ratios() {
    for defect in [
        ManifoldDefect::GlossyDeterminant,
        ManifoldDefect::VmfNormaliser,
        ManifoldDefect::FirstChainGeometry,
    ] {
        let (worst, _) = compare(Some(defect));
        println!("{defect:?}: worst |Δ ln ratio| {worst:.2e}");
        assert!(worst > 1e-2, "{defect:?} goes unnoticed ({worst:.2e})");
    }
}

/// `E[h 1{move = m}/T]` over proposals against the patch's area (`h`: the watched vertex in a
/// patch beside its current place, sized by the median move of pilot proposals).
fn numerical(name: &str, m: Move, watched: usize, n: usize, seed: u64) -> (f64, f64, usize) {
    let x = path();
    let xp = positions(&x);
    let toward_light = name == "manifold-light";
    let c = xp[watched];
    let mut y = PathState::default();
    // The median distance moved (robust to the walk's rare long moves).
    let mut spread = Vec::new();
    for i in 0..4000u64 {
        let mut rng = stream(seed ^ 0xF00D, i);
        if propose(name, None, &x, &mut rng, &mut y).is_ok() && y.carries_light() {
            let yp = positions(&y);
            if classify(&xp, &yp, toward_light) == m {
                spread.push((yp[watched] - c).length());
            }
        }
    }
    spread.sort_by(f64::total_cmp);
    let sigma = spread.get(spread.len() / 2).copied().unwrap_or(0.0);
    // Coordinates on the floor and on the light: x and z.
    let (lo, hi) = ((0.1 * sigma, -0.6 * sigma), (1.0 * sigma, 0.5 * sigma));
    let area = (hi.0 - lo.0) * (hi.1 - lo.1);
    let (mut s, mut s2, mut hits) = (0.0, 0.0, 0);
    for i in 0..n as u64 {
        let mut rng = stream(seed, i);
        if propose(name, None, &x, &mut rng, &mut y).is_err() || !y.carries_light() {
            continue;
        }
        let yp = positions(&y);
        if classify(&xp, &yp, toward_light) != m {
            continue;
        }
        let d = yp[watched] - c;
        if d.x < lo.0 || d.x > hi.0 || d.z < lo.1 || d.z > hi.1 {
            continue;
        }
        hits += 1;
        let v = 1.0 / transition(&xp, &yp, m);
        s += v;
        s2 += v * v;
    }
    let mean = s / n as f64;
    let var = (s2 / n as f64 - mean * mean) * n as f64 / (n - 1) as f64;
    let se = (var / n as f64).sqrt();
    let z = (mean - area) / se;
    let z_broken = (mean / BROKEN_SCALE - area) / (se / BROKEN_SCALE);
    println!(
        "{name} {m:?}: N = {n}, hits {hits}, area {area:.3e}: E[h/T] = {mean:.4e} ± {se:.1e} \
         (z = {z:+.2}); × 1.15: z = {z_broken:+.2}"
    );
    (z, z_broken, hits)
}

#[test]
fn the_sampler_draws_from_the_reported_density_on_glossy_chains() {
    let n = std::env::var("MANIFOLD_N")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(200_000);
    let cases = [
        ("manifold-eye", Move::LightDirection { followed: true }, 2),
        ("manifold-light", Move::LensDirection { walked: true }, 2),
        ("manifold-light", Move::LensDirection { walked: false }, 2),
        ("manifold-eye", Move::LightPosition { walked: true }, 0),
    ];
    for (k, (name, m, watched)) in cases.into_iter().enumerate() {
        let (z, z_broken, hits) = numerical(name, m, watched, n, 900 + k as u64);
        assert!(hits >= 500, "{name} {m:?}: only {hits} hits");
        assert!(z.abs() < Z_LIMIT, "{name} {m:?}: z = {z}");
        assert!(
            z_broken.abs() >= Z_LIMIT,
            "{name} {m:?}: the broken density passes"
        );
    }
}

/// The pilot of `Δθ` (appendix A1) from the glossy path: it measures the wall's microfacet normal
/// turning in proposals that leave it free, more for larger steps (smaller λ); on a path without
/// glossy vertices there is nothing to measure.
#[test]
fn the_pilot_measures_the_normal_change() {
    use light_transport::pathspace::normal_change::measure_normal_change;
    let x = path();
    let mut m = Mutations::new(4);
    let at = |m: &Mutations| {
        measure_normal_change(scene(), m, std::slice::from_ref(&x), 3)
            .expect("pilot")
            .expect("glossy normals changed")
    };
    let fine = at(&m);
    m.manifold.lambda = 5.0;
    let coarse = at(&m);
    println!("λ = 50: {fine}; λ = 5: {coarse}");
    assert!(fine.delta_theta > 0.0 && fine.samples >= 10);
    assert!(coarse.delta_theta > 2.0 * fine.delta_theta);
    // The same path with a matte wall: no glossy vertex.
    let mut matte = x.clone();
    matte.path.vertices[1].bsdf = matte.path.vertices[2].bsdf.clone();
    assert!(
        measure_normal_change(scene(), &m, std::slice::from_ref(&matte), 3)
            .expect("pilot")
            .is_none()
    );
}
