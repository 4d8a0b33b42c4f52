//! Independent checks of the transition densities of the path-space MLT mutations (Veach & Guibas
//! 1997): each mutation is verified on its own, its reported acceptance ratio checked against
//! densities written here from scratch, and those densities checked against numerical estimates.
//!
//! The mutations never compute `f` or `T`: they report
//! `ln[I(f(ȳ)) T(x̄|ȳ) / (I(f(x̄)) T(ȳ|x̄))]` through ratios `C*_s = f/p_s` of bidirectional
//! strategies. This file evaluates, for non-specular paths `v_0 … v_k` (light endpoint first,
//! pinhole lens last — a fixed point that carries no measure):
//!
//! * the measurement contribution `f = Le G Π (f_s G) W_e` with its own geometry terms and
//!   visibility (only `Le`, the BSDF values and `W_e` come from the library);
//! * the area-product densities of every mutation, from a pinhole model of the camera written here
//!   (raster map, pixels per steradian), the BSDF densities and the emitter's cosine density. Only
//!   the discrete deletion/addition probabilities of the bidirectional mutation are the library's.
//!
//! Two kinds of checks:
//!
//! * **(b) pointwise**: for 2000 finite proposals per mutation from 17 current paths of 1 … 5
//!   edges, the log ratio from these `f` and `T` equals the mutation's reported value to 1e-6
//!   (relative); proposals giving `Err` or `−∞` are counted, and a `−∞` where this file's
//!   `f(ȳ) T(x̄|ȳ)` is positive is an error. The bidirectional mutation's deletion and number of new
//!   vertices are replayed from a copy of its generator (they are its first draws).
//! * **(a) numerical**: `E[h(ȳ)/T(ȳ|x̄)]` over proposals from a fixed `x̄`, with `h` the indicator
//!   of a set of paths (the moved vertex in a patch `A` of the floor or the wall, everything else
//!   unchanged), equals the measure of the set (`area(A)`) — which holds exactly when `T` is the
//!   density the sampler really draws from. z-tests with fixed seeds, |z| < 4.5; each also shows
//!   that a deliberately wrong density (scaled by 1.15; the bidirectional density with one split's
//!   term instead of the sum, or without the pinhole's lens-remaking move; the new-path density
//!   with one strategy instead of the sum) is rejected.
//!
//! * **(b') the combined rule**: the library's mixture of every mutation under the combined rule
//!   reports `ln[I(f(ȳ)) Σ_k P_k T_k(x̄|ȳ) / (I(f(x̄)) Σ_k P_k T_k(ȳ|x̄))]`, the sums over every
//!   mutation that makes the same change (the record the candidate carries); checked against this
//!   file's densities, and a sum missing the bidirectional mutation's term is caught.
//!
//! Measured (release build, ~5 s for the whole file, on the smooth-shaded floor below): largest
//! |Δ ln ratio| 6.2e-15 for every mutation, 5.6e-15 for the combined rule (1645 of 2000 proposals
//! with several mutations making their change; the sums without the bidirectional term disagree
//! on 1332); numerical |z| ≤ 1.5 for the correct densities, |z| ≥ 12 for the wrong ones. With the
//! library's adjoint correction switched off (`Scene::adjoint_correction`, tried by hand), every
//! pointwise check fails: 740–1776 of 2000 ratios disagree, by up to 0.24–6.4 in the log.
//!
//! The scene: a diffuse floor (y = 0), ceiling (y = 2) and back wall (z = −2), a small emitter
//! facing down just below the ceiling, a pinhole camera between floor and ceiling; everything
//! Lambertian, so every path has an ordinary density in the area-product measure. The floor is
//! smooth-shaded: a 6 × 6 grid of the plane whose interpolated vertex normals lean up to ~20° off
//! its geometric normal, so `f` carries the shading-normal factor `|ω_l·n_s| / |ω_l·n_g|` at floor
//! vertices (`ω_l` toward the light end; Veach 1997 §5.3), written here from its definition, while
//! densities stay solid-angle BSDF densities converted with geometric cosines.

mod common;

use common::vmf_pdf;
use light_transport::Rgb;
use light_transport::bsdf::TransportMode;
use light_transport::geometry::{Ray, SurfaceEnd};
use light_transport::math::DVec3;
use light_transport::metropolis::ImportanceKind;
use light_transport::path::{Vertex, VertexKind};
use light_transport::pathspace::{
    Bidirectional, Change, Deletion, FullPath, MutationProbabilities, Mutations, NewPath,
    PathState, PerturbationSettings, PhotonProposals, UserPathRule, UserPaths,
};
use light_transport::sampler::IndependentStream;
use light_transport::scene::Scene;
use light_transport::scene::builtin::SceneBuilder;
use mcmc_core::rng::stream;
use mcmc_core::{ChainRng, Failure};
use std::collections::BTreeMap;
use std::f64::consts::{PI, TAU};
use std::sync::OnceLock;

/// The mutations under test, by their registered names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum MutationKind {
    Bidirectional,
    LensSubpath,
    Lens,
    Caustic,
    MultiChain,
    NewPath,
    ManifoldLight,
    ManifoldEye,
    PhotonMap,
}

impl MutationKind {
    fn name(&self) -> &'static str {
        match self {
            MutationKind::Bidirectional => "bidirectional",
            MutationKind::LensSubpath => "lens-subpath",
            MutationKind::Lens => "lens",
            MutationKind::Caustic => "caustic",
            MutationKind::MultiChain => "multi-chain",
            MutationKind::NewPath => "new-path",
            MutationKind::ManifoldLight => "manifold-light",
            MutationKind::ManifoldEye => "manifold-eye",
            MutationKind::PhotonMap => "photon-map",
        }
    }
}

/// Propose with the registered mutation `kind` (new paths of lengths `np`): its reported log
/// acceptance ratio.
fn propose(
    kind: MutationKind,
    np: &NewPath,
    x: &PathState,
    rng: &mut ChainRng,
    y: &mut PathState,
) -> Result<f64, Failure> {
    let f = fx();
    let settings = mutations().settings(np.clone());
    let mutation = Mutations::mutation(&f.scene, &settings, kind.name()).expect("registered");
    mutation.propose_ratio(x, rng, y)
}

// ---------------------------------------------------------------------------------------------
// The scene and an independent model of its camera and emitter.
// ---------------------------------------------------------------------------------------------

const W: usize = 64;
const H: usize = 48;
const FOV_DEGREES: f64 = 60.0;
const EYE: DVec3 = DVec3::new(0.0, 1.0, 3.0);
const TARGET: DVec3 = DVec3::new(0.0, 0.8, -2.0);
const LIGHT_CORNER: DVec3 = DVec3::new(-0.25, 1.99, -0.75);
const LIGHT_SIDE: f64 = 0.5;
/// Longest path of the mutations under test.
const MAX_EDGES: usize = 5;
const IMPORTANCE: ImportanceKind = ImportanceKind::Luminance;
/// |z| below this passes: two-sided false-positive rate P(|Z| > 4.5) ≈ 6.8e-6 per check (the
/// seeds are fixed, so the outcome is deterministic; this is the rate over seeds).
const Z_LIMIT: f64 = 4.5;

/// The pinhole camera as this file understands it: `look_at` frame, image rectangle at distance 1
/// with half-extents `(tx, ty)` (`ty = tan(fov/2)` on the shorter axis), raster x right, y down.
struct Pinhole {
    eye: DVec3,
    right: DVec3,
    up: DVec3,
    forward: DVec3,
    tx: f64,
    ty: f64,
}

impl Pinhole {
    fn new() -> Self {
        let forward = (TARGET - EYE).normalize();
        let right = forward.cross(DVec3::Y).normalize();
        let up = right.cross(forward);
        let t = (FOV_DEGREES.to_radians() / 2.0).tan();
        let aspect = W as f64 / H as f64;
        let (tx, ty) = if aspect >= 1.0 {
            (t * aspect, t)
        } else {
            (t, t / aspect)
        };
        Self {
            eye: EYE,
            right,
            up,
            forward,
            tx,
            ty,
        }
    }

    /// Raster position of the ray from the eye in unit direction `w` (`None` outside the image).
    fn raster_of_direction(&self, w: DVec3) -> Option<[f64; 2]> {
        let z = w.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let x = w.dot(self.right) / z;
        let y = w.dot(self.up) / z;
        let r = [
            (x / self.tx + 1.0) / 2.0 * W as f64,
            (1.0 - y / self.ty) / 2.0 * H as f64,
        ];
        (r[0] >= 0.0 && r[0] < W as f64 && r[1] >= 0.0 && r[1] < H as f64).then_some(r)
    }

    /// Raster position of a world point.
    fn raster(&self, p: DVec3) -> Option<[f64; 2]> {
        self.raster_of_direction((p - self.eye).normalize())
    }

    /// Pixels² per steradian about direction `w`: the image plane at distance 1 has `1/cos³θ` units
    /// of area per steradian, and `W/(2 tx) × H/(2 ty)` pixels per unit of area.
    fn pixels_per_sr(&self, w: DVec3) -> f64 {
        let c = w.dot(self.forward);
        if c <= 0.0 {
            return 0.0;
        }
        (W as f64 / (2.0 * self.tx)) * (H as f64 / (2.0 * self.ty)) / (c * c * c)
    }

    /// Solid-angle density of the direction of a uniformly chosen raster position.
    fn direction_pdf(&self, w: DVec3) -> f64 {
        if self.raster_of_direction(w).is_none() {
            return 0.0;
        }
        self.pixels_per_sr(w) / (W * H) as f64
    }
}

struct Fixture {
    scene: Scene,
    cam: Pinhole,
    /// Area of the (only) emitter: a light endpoint is uniform on it (the two triangles of the quad
    /// have equal power, so choice by power × uniform on the triangle is uniform on the quad).
    light_area: f64,
    settings: PerturbationSettings,
}

fn fx() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let mut b = SceneBuilder::new(W, H, EYE, TARGET, FOV_DEGREES);
        let floor = b.matte(0.7, 0.6, 0.5);
        let ceiling = b.matte(0.6, 0.6, 0.6);
        let wall = b.matte(0.3, 0.6, 0.45);
        let black = b.matte(0.0, 0.0, 0.0);
        // floor, normal +y: a 6 × 6 grid with interpolated vertex normals up to ~20° off +y
        b.mesh(
            shaded_floor_positions(),
            Some(shaded_floor_normals()),
            shaded_floor_indices(),
            floor,
        );
        // ceiling, normal −y
        b.quad(
            DVec3::new(-2.0, 2.0, -2.0),
            DVec3::X * 4.0,
            DVec3::Z * 4.0,
            ceiling,
            None,
        );
        // back wall, normal +z
        b.quad(
            DVec3::new(-2.0, 0.0, -2.0),
            DVec3::X * 4.0,
            DVec3::Y * 2.0,
            wall,
            None,
        );
        // emitter facing down (normal −y)
        b.quad(
            LIGHT_CORNER,
            DVec3::X * LIGHT_SIDE,
            DVec3::Z * LIGHT_SIDE,
            black,
            Some(Rgb::new(24.0, 20.0, 14.0)),
        );
        let scene = Scene::new(&b.finish(), None).expect("scene");
        Fixture {
            scene,
            cam: Pinhole::new(),
            light_area: LIGHT_SIDE * LIGHT_SIDE,
            settings: PerturbationSettings::default(),
        }
    })
}

const FLOOR_CELLS: usize = 6;

/// The floor's vertices: the plane `y = 0` over `[−2, 2]²`.
fn shaded_floor_positions() -> Vec<DVec3> {
    let d = 4.0 / FLOOR_CELLS as f64;
    (0..=FLOOR_CELLS)
        .flat_map(|j| {
            (0..=FLOOR_CELLS)
                .map(move |i| DVec3::new(-2.0 + i as f64 * d, 0.0, -2.0 + j as f64 * d))
        })
        .collect()
}

/// The floor's vertex normals, tilted from `+y` by up to ~20°.
fn shaded_floor_normals() -> Vec<DVec3> {
    shaded_floor_positions()
        .into_iter()
        .map(|p| {
            DVec3::new(
                0.35 * (1.3 * p.x + 0.2).sin(),
                1.0,
                0.35 * (1.1 * p.z).cos(),
            )
            .normalize()
        })
        .collect()
}

/// The floor's triangles, wound so that the geometric normal is `+y`.
fn shaded_floor_indices() -> Vec<[u32; 3]> {
    let at = |i: usize, j: usize| (j * (FLOOR_CELLS + 1) + i) as u32;
    let mut v = Vec::new();
    for j in 0..FLOOR_CELLS {
        for i in 0..FLOOR_CELLS {
            v.push([at(i, j), at(i, j + 1), at(i + 1, j + 1)]);
            v.push([at(i, j), at(i + 1, j + 1), at(i + 1, j)]);
        }
    }
    v
}

fn mutations() -> Mutations {
    Mutations {
        rule: mcmc_core::proposals::MixtureRule::PerComponent,
        selection: mcmc_core::proposals::Selection::Fixed,
        max_edges: MAX_EDGES,
        min_edges: 1,
        importance: IMPORTANCE,
        probabilities: MutationProbabilities::default(),
        perturbation: fx().settings,
        manifold: Default::default(),
        photon: Default::default(),
    }
}

/// A non-uniform length distribution, so that `P_len` matters in the new-path ratio.
fn new_path_lengths() -> NewPath {
    NewPath::from_energies(&[0.5, 3.0, 2.0, 1.0, 0.25], 1)
}

// ---------------------------------------------------------------------------------------------
// The independent evaluator: f, geometry, densities.
// ---------------------------------------------------------------------------------------------

fn dir(a: &Vertex, b: &Vertex) -> DVec3 {
    (b.p() - a.p()).normalize()
}

fn is_lens(v: &Vertex) -> bool {
    v.kind == VertexKind::Camera
}

/// |cos| at `v` of the unit direction `w`: the surface normal, or the viewing axis at the lens.
fn cos_at(f: &Fixture, v: &Vertex, w: DVec3) -> f64 {
    if is_lens(v) {
        f.cam.forward.dot(w).abs()
    } else {
        v.n().dot(w).abs()
    }
}

/// `G(a, b) = |cos_a| |cos_b| / d²`.
fn geometry(f: &Fixture, a: &Vertex, b: &Vertex) -> f64 {
    let d = b.p() - a.p();
    let d2 = d.length_squared();
    let w = d / d2.sqrt();
    cos_at(f, a, w) * cos_at(f, b, w) / d2
}

fn clear(f: &Fixture, a: &Vertex, b: &Vertex) -> bool {
    let na = (!is_lens(a)).then(|| SurfaceEnd::of(&a.point));
    let nb = (!is_lens(b)).then(|| SurfaceEnd::of(&b.point));
    f.scene.visible(a.p(), na, b.p(), nb)
}

/// The measurement contribution
/// `f(x̄) = Le(v0→v1) G(v0,v1) Π_{i=1}^{k−1} f_s(v_{i−1}→v_i→v_{i+1}) G(v_i,v_{i+1}) · W_e(v_{k−1}→v_k)`,
/// zero when an edge is occluded.
fn measurement(f: &Fixture, path: &[Vertex]) -> Rgb {
    let k = path.len() - 1;
    assert!(k >= 1 && is_lens(&path[k]), "not a full path");
    let Some((_, light)) = f.scene.light_at(path[0].point.primitive) else {
        return Rgb::BLACK;
    };
    let mut value =
        light.radiance(path[0].n(), dir(&path[0], &path[1])) * geometry(f, &path[0], &path[1]);
    for i in 1..k {
        let bsdf = f.scene.bsdf(&path[i].point).expect("bsdf");
        let to_light = dir(&path[i], &path[i - 1]);
        let fs = bsdf.eval(
            dir(&path[i], &path[i + 1]),
            to_light,
            TransportMode::Radiance,
        );
        // Shading normals (Veach 1997 §5.3): the BSDF's cosine is the shading one, while the
        // geometry terms carry the geometric cosines, so the light side's cosine is corrected.
        let shading = to_light.dot(path[i].point.ns).abs() / to_light.dot(path[i].n()).abs();
        value = value * fs * shading * geometry(f, &path[i], &path[i + 1]);
    }
    let we = f
        .scene
        .camera
        .importance(path[k].p(), dir(&path[k], &path[k - 1]))
        .0;
    value *= we;
    if (0..k).any(|i| !clear(f, &path[i], &path[i + 1])) {
        return Rgb::BLACK;
    }
    value
}

/// Scalar importance of a colour, written out (Rec. 709 luminance).
fn importance(c: Rgb) -> f64 {
    (0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]).max(0.0)
}

/// Solid-angle density of a walk leaving `path[i]` toward `path[next]` having arrived from
/// `path[prev]` (`None`: `path[i]` is an endpoint — the lens by uniform raster position, the
/// emitter by its cosine distribution).
fn solid_pdf(f: &Fixture, path: &[Vertex], i: usize, prev: Option<usize>, next: usize) -> f64 {
    let w = dir(&path[i], &path[next]);
    match prev {
        None if is_lens(&path[i]) => f.cam.direction_pdf(w),
        None => path[i].n().dot(w).max(0.0) / PI,
        Some(p) => {
            let bsdf = f.scene.bsdf(&path[i].point).expect("bsdf");
            bsdf.pdf(dir(&path[i], &path[p]), w)
        }
    }
}

/// [`solid_pdf`] converted to area at `path[next]`.
fn area_pdf(f: &Fixture, path: &[Vertex], i: usize, prev: Option<usize>, next: usize) -> f64 {
    let d2 = (path[next].p() - path[i].p()).length_squared();
    solid_pdf(f, path, i, prev, next) * cos_at(f, &path[next], dir(&path[i], &path[next])) / d2
}

/// Density of the light-walk vertices `path[from+1 ..= upto]` continuing from `path[from]`.
fn light_walk(f: &Fixture, path: &[Vertex], from: usize, upto: usize) -> f64 {
    (from + 1..=upto)
        .map(|i| area_pdf(f, path, i - 1, (i >= 2).then(|| i - 2), i))
        .product()
}

/// Density of the camera-walk vertices `path[downto .. from]` (descending) continuing from
/// `path[from]`.
fn camera_walk(f: &Fixture, path: &[Vertex], from: usize, downto: usize) -> f64 {
    let k = path.len() - 1;
    (downto..from)
        .map(|i| area_pdf(f, path, i + 1, (i + 2 <= k).then_some(i + 2), i))
        .product()
}

/// Density of a light endpoint at `path[0]`: uniform on the emitter.
fn light_origin(f: &Fixture) -> f64 {
    1.0 / f.light_area
}

/// Full density `p_s` of strategy `s` (light vertices `v_0 … v_{s−1}`, camera `v_s … v_k`; the
/// pinhole lens point has density 1).
fn strategy_density(f: &Fixture, path: &[Vertex], s: usize) -> f64 {
    let k = path.len() - 1;
    let light = if s >= 1 {
        light_origin(f) * light_walk(f, path, 0, s - 1)
    } else {
        1.0
    };
    light * camera_walk(f, path, k, s)
}

/// Radial density `p(r)` of an offset exponentially distributed in `[r1, r2]` (a relative slack
/// `tol` on the support absorbs rounding in recomputed radii).
fn exp_pdf(r: f64, r1: f64, r2: f64, tol: f64) -> f64 {
    if r >= r1 * (1.0 - tol) && r <= r2 * (1.0 + tol) {
        1.0 / (r * (r2 / r1).ln())
    } else {
        0.0
    }
}

fn r2_pixels(f: &Fixture) -> f64 {
    (f.settings.r2_fraction * W as f64).max(f.settings.r1 * 1.000_001)
}

/// Lens perturbation `from → to` (non-specular: only `v_{k−1}` moves, through a pixel offset of
/// density `p(r)/(2π r)` per pixel²): area density at `to[k−1]`.
fn t_lens(f: &Fixture, from: &[Vertex], to: &[Vertex], tol: f64) -> f64 {
    let k = from.len() - 1;
    let (Some(a), Some(b)) = (f.cam.raster(from[k - 1].p()), f.cam.raster(to[k - 1].p())) else {
        return 0.0;
    };
    let r = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
    let per_pixel2 = exp_pdf(r, f.settings.r1, r2_pixels(f), tol) / (TAU * r);
    let w = dir(&to[k], &to[k - 1]);
    let d2 = (to[k - 1].p() - to[k].p()).length_squared();
    per_pixel2 * f.cam.pixels_per_sr(w) * cos_at(f, &to[k - 1], w) / d2
}

/// Caustic perturbation `from → to` (non-specular: the direction at `v_{k−2}` turns by an angle
/// `θ ~ p(θ)` about a uniform axis, density `p(θ)/(2π sin θ)` per steradian): area density at
/// `to[k−1]`.
fn t_caustic(f: &Fixture, from: &[Vertex], to: &[Vertex], tol: f64) -> f64 {
    let k = from.len() - 1;
    let a = &from[k - 2];
    let (wx, wy) = (dir(a, &from[k - 1]), dir(a, &to[k - 1]));
    let theta = wx.cross(wy).length().atan2(wx.dot(wy));
    let per_sr = exp_pdf(theta, f.settings.theta1, f.settings.theta2, tol) / (TAU * theta.sin());
    let d2 = (to[k - 1].p() - a.p()).length_squared();
    per_sr * cos_at(f, &to[k - 1], wy) / d2
}

/// Lens-subpath mutation (non-specular: a new `v_{k−1}` from a uniform raster position):
/// area density at `to[k−1]`.
fn t_lens_subpath(f: &Fixture, to: &[Vertex]) -> f64 {
    let k = to.len() - 1;
    area_pdf(f, to, k, None, k - 1)
}

/// Bidirectional mutation `from → to` by deletion `d` and `n` new vertices (`to[l+1 ..= l+n]`):
/// `P_d P_a / N_split · Σ_a (light-side density) × (camera-side density)` of the new vertices.
fn t_bidirectional(
    f: &Fixture,
    bd: &Bidirectional,
    from: &[Vertex],
    to: &[Vertex],
    d: Deletion,
    n: usize,
    only_split: Option<usize>,
) -> f64 {
    let (k_from, k_to) = (from.len() - 1, to.len() - 1);
    assert_eq!(
        k_to + d.kd(),
        k_from + 1 + n,
        "lengths do not match the move"
    );
    let p = bd.deletion_probability(k_from, d) * bd.addition_probability(k_from, d, n);
    let lens_new = d.m == k_from + 1;
    let splits = n + 1 - lens_new as usize;
    let first_new = (d.l + 1) as usize;
    // The camera walk starts from the kept v_m (index l+1+n in `to`) or from the new lens point
    // (index k_to, density 1 for a pinhole).
    let cam_start = if lens_new { k_to } else { first_new + n };
    let mut sum = 0.0;
    for a in 0..splits {
        if only_split.is_some_and(|o| o != a) {
            continue;
        }
        let s = first_new + a;
        let light = if d.l >= 0 {
            light_walk(f, to, d.l as usize, s - 1)
        } else if a >= 1 {
            light_origin(f) * light_walk(f, to, 0, s - 1)
        } else {
            1.0
        };
        sum += light * camera_walk(f, to, cam_start, s);
    }
    p / splits as f64 * sum
}

/// `λ` of the manifold perturbation (the library's default).
const LAMBDA: f64 = 50.0;

/// Manifold perturbation (non-specular paths: `x_b` is the neighbour of `x_a` and joins `x_c`
/// directly) moving vertex `b` of `from` to make `to`. Toward the light, `x_a` is uniform among the
/// `k − 1` vertices this direction can start from; toward the eye, among those `k − 1` and the
/// light's position move. A direction move draws the new direction from the von Mises–Fisher
/// distribution whose density at the current direction is `λ² p(ω_i → ω_o)`, turned into area at
/// `x'_b` by `G(x_a, x'_b) / |cos θ_a|`; the position move (`b = 0`) offsets the light point by a
/// Gaussian of variance `ρ/(2πλ²)` in the light's plane, `ρ` the area of the light (one of the
/// emitter quad's two triangles).
fn t_manifold(f: &Fixture, from: &[Vertex], to: &[Vertex], b: usize, toward_light: bool) -> f64 {
    let k = from.len() - 1;
    let strategies = if toward_light { k - 1 } else { k } as f64;
    if b == 0 {
        let var = f.light_area / 2.0 / (TAU * LAMBDA * LAMBDA);
        let d2 = (to[0].p() - from[0].p()).length_squared();
        return (-d2 / (2.0 * var)).exp() / (TAU * var) / strategies;
    }
    let a = if toward_light { b + 1 } else { b - 1 };
    let behind = if toward_light {
        (a < k).then_some(a + 1)
    } else {
        a.checked_sub(1)
    };
    let p = solid_pdf(f, from, a, behind, b);
    let (w_from, w_to) = (dir(&from[a], &from[b]), dir(&to[a], &to[b]));
    let d = vmf_pdf(LAMBDA * LAMBDA * p, w_from, w_to);
    d / cos_at(f, &to[a], w_to) * geometry(f, &to[a], &to[b]) / strategies
}

/// The photon-map proposal's cone half-angle (the library's default, 30°).
const GAMMA: f64 = 30.0 * PI / 180.0;

/// Solid-angle density of a direction `w` drawn with its angle to `axis` uniform in `[0, β)` and a
/// uniform azimuth: `1/(2πβ sin θ)` inside the cone.
fn cone_density(axis: DVec3, w: DVec3, beta: f64) -> f64 {
    let theta = axis.cross(w).length().atan2(axis.dot(w));
    if theta < beta && theta > 0.0 {
        1.0 / (TAU * beta * theta.sin())
    } else {
        0.0
    }
}

/// Photon-map proposal `from → to` (non-specular: `x_d = v_{k−1}` keeps its place and the direction
/// back to `v_{k−2}` turns inside the cone of half-angle γ about the current one; the traced hit
/// is the new `v_{k−2}`): area density at `to[k−2]`.
fn t_photon_map(f: &Fixture, from: &[Vertex], to: &[Vertex]) -> f64 {
    let k = from.len() - 1;
    let (d, a) = (&from[k - 1], k - 2);
    let (wx, wy) = (dir(d, &from[a]), dir(&to[k - 1], &to[a]));
    let d2 = (to[a].p() - to[k - 1].p()).length_squared();
    cone_density(wx, wy, GAMMA) * cos_at(f, &to[a], wy) / d2
}

/// New-path mutation: `P_len(k)/(k+1) · Σ_s p_s`.
fn t_new_path(f: &Fixture, np: &NewPath, to: &[Vertex]) -> f64 {
    let k = to.len() - 1;
    let p_len = np.length_probability.get(k - 1).copied().unwrap_or(0.0);
    p_len / (k + 1) as f64 * (0..=k).map(|s| strategy_density(f, to, s)).sum::<f64>()
}

/// `ln[I(f(ȳ)) T(x̄|ȳ) / (I(f(x̄)) T(ȳ|x̄))]` from this file's `f` and the two densities.
fn ln_ratio(f: &Fixture, x: &[Vertex], y: &[Vertex], t_fwd: f64, t_back: f64) -> f64 {
    let (ix, iy) = (importance(measurement(f, x)), importance(measurement(f, y)));
    iy.ln() + t_back.ln() - ix.ln() - t_fwd.ln()
}

// ---------------------------------------------------------------------------------------------
// Paths.
// ---------------------------------------------------------------------------------------------

fn lens_vertex(f: &Fixture) -> Vertex {
    Vertex {
        kind: VertexKind::Camera,
        point: f.scene.camera.lens_point(f.scene.camera.position()),
        wo: DVec3::ZERO,
        bsdf: None,
        beta: Rgb::BLACK,
        delta: false,
        pdf_fwd: 0.0,
        pdf_rev: 0.0,
    }
}

/// The surface point `target`, found by tracing from `origin` (asserting the hit is `target`).
fn vertex_at(f: &Fixture, origin: DVec3, target: DVec3) -> Vertex {
    let hit = f
        .scene
        .intersect(&Ray::new(origin, (target - origin).normalize()))
        .expect("hit");
    assert!(
        (hit.point.p - target).length() < 1e-9,
        "{:?} vs {target:?}",
        hit.point.p
    );
    let kind = match f.scene.light_at(hit.point.primitive) {
        Some((i, _)) => VertexKind::Light { light: i as u32 },
        None => VertexKind::Surface,
    };
    Vertex {
        kind,
        point: hit.point,
        wo: DVec3::ZERO,
        bsdf: f.scene.bsdf(&hit.point).ok(),
        beta: Rgb::BLACK,
        delta: false,
        pdf_fwd: 0.0,
        pdf_rev: 0.0,
    }
}

fn state(f: &Fixture, mut vertices: Vec<Vertex>) -> PathState {
    let n = vertices.len();
    for i in 1..n {
        vertices[i].wo = dir(&vertices[i], &vertices[i - 1]);
    }
    vertices[n - 1].wo = DVec3::ZERO;
    let mut s = PathState {
        path: FullPath { vertices },
        ..Default::default()
    };
    assert!(
        s.evaluate(&f.scene, IMPORTANCE, 1.0),
        "hand-made path carries no light"
    );
    s
}

const P0_K2: DVec3 = DVec3::new(0.05, 1.99, -0.4);
const P1_K2: DVec3 = DVec3::new(0.2, 0.0, 0.3);

/// `x̄ = light → floor → lens` (k = 2).
fn fixed_k2() -> PathState {
    let f = fx();
    let v0 = vertex_at(f, P0_K2 - DVec3::Y * 0.5, P0_K2);
    let v1 = vertex_at(f, P1_K2 + DVec3::Y * 0.5, P1_K2);
    state(f, vec![v0, v1, lens_vertex(f)])
}

const P0_K3: DVec3 = DVec3::new(0.1, 1.99, -0.6);
const P1_K3: DVec3 = DVec3::new(-0.2, 0.0, -1.0);
const P2_K3: DVec3 = DVec3::new(0.3, 1.0, -2.0);

/// `x̄ = light → floor → back wall → lens` (k = 3).
fn fixed_k3() -> PathState {
    let f = fx();
    let v0 = vertex_at(f, P0_K3 - DVec3::Y * 0.5, P0_K3);
    let v1 = vertex_at(f, P1_K3 + DVec3::Y * 0.5, P1_K3);
    let v2 = vertex_at(f, P2_K3 + DVec3::Z * 0.5, P2_K3);
    state(f, vec![v0, v1, v2, lens_vertex(f)])
}

/// Current paths for the pointwise checks: the two hand-made paths and paths of 1 … MAX_EDGES
/// edges sampled by the library's bootstrap sampler (kept when they carry light).
fn current_paths() -> &'static Vec<PathState> {
    static P: OnceLock<Vec<PathState>> = OnceLock::new();
    P.get_or_init(|| {
        let f = fx();
        let mut out = vec![fixed_k2(), fixed_k3()];
        for k in 1..=MAX_EDGES {
            let (mut found, mut tries) = (0, 0u64);
            while found < 3 && tries < 20_000 {
                let mut s = IndependentStream::new(stream(0x5eed_0000 + k as u64, tries));
                tries += 1;
                let mut st = PathState::default();
                if NewPath::sample(&f.scene, IMPORTANCE, k, &mut s, &mut st)
                    && st.contribution.importance > 0.0
                    && importance(measurement(f, &st.path.vertices)) > 0.0
                {
                    out.push(st);
                    found += 1;
                }
            }
        }
        out
    })
}

fn same_point(a: &Vertex, b: &Vertex) -> bool {
    (a.p() - b.p()).length() <= 1e-12 * (1.0 + a.p().length())
}

// ---------------------------------------------------------------------------------------------
// The model of the scene against the library (what the independent evaluator assumes).
// ---------------------------------------------------------------------------------------------

/// The camera model, the emitter density and `I(f)/p_s = I(C*_s)` on every current path: the
/// evaluator's building blocks agree with the library where they overlap.
#[test]
fn independent_model_matches_the_scene() {
    let f = fx();
    // Raster map.
    for p in [
        DVec3::new(0.2, 0.0, 0.3),
        DVec3::new(-1.0, 0.0, -1.5),
        DVec3::new(0.3, 1.0, -2.0),
        DVec3::new(1.5, 1.8, -2.0),
    ] {
        let mine = f.cam.raster(p).expect("in image");
        let lib = f.scene.camera.raster_of(p).expect("in image");
        assert!(
            (mine[0] - lib[0]).abs() < 1e-9 && (mine[1] - lib[1]).abs() < 1e-9,
            "{mine:?} {lib:?}"
        );
    }
    // Pixels per steradian against finite differences of the library's raster → ray map.
    let lens = f.scene.camera.position();
    for r in [[32.0, 24.0], [5.5, 40.2], [60.1, 3.3]] {
        let h = 1e-4;
        let d = |r: [f64; 2]| f.scene.camera.ray_through(lens, r).expect("ray").ray.d;
        let w = d(r);
        let dx = (d([r[0] + h, r[1]]) - d([r[0] - h, r[1]])) / (2.0 * h);
        let dy = (d([r[0], r[1] + h]) - d([r[0], r[1] - h])) / (2.0 * h);
        let sr_per_pixel2 = dx.cross(dy).length();
        let rel = (f.cam.pixels_per_sr(w) * sr_per_pixel2 - 1.0).abs();
        assert!(rel < 1e-6, "pixels per sr off by {rel} at {r:?}");
    }
    // Emitter: a uniform point on the quad.
    for (i, light) in f.scene.lights.iter().enumerate() {
        let lib = f.scene.light_distribution.pdf(i) * light.pdf_position();
        assert!((lib * f.light_area - 1.0).abs() < 1e-9, "light {i}: {lib}");
    }
    // I(f)/p_s against the library's I(C*_s) on every strategy of every current path.
    let mut checked = 0;
    for x in current_paths() {
        let v = &x.path.vertices;
        let i_f = importance(measurement(f, v));
        for s in 0..v.len() {
            let mine = i_f / strategy_density(f, v, s);
            let lib = x.strategy_importance(s);
            assert!(
                (mine / lib - 1.0).abs() < 1e-9,
                "k = {}, s = {s}: I(f)/p_s = {mine}, library I(C*_s) = {lib}",
                v.len() - 1
            );
            checked += 1;
        }
    }
    println!(
        "model: {checked} strategies of {} paths agree",
        current_paths().len()
    );
}

// ---------------------------------------------------------------------------------------------
// (b) Pointwise: the reported log ratios against this file's f and T.
// ---------------------------------------------------------------------------------------------

#[derive(Debug, Default)]
struct Tally {
    proposals: usize,
    errors: usize,
    neg_inf: usize,
    /// −∞ reported although this file's `f(ȳ) T(x̄|ȳ)` is positive.
    neg_inf_disputed: usize,
    compared: usize,
    /// Compared proposals with `ȳ ≠ x̄`.
    moved: usize,
    max_abs: f64,
    /// Compared proposals whose ratios differ by more than 1e-6 (relative).
    bad: usize,
    examples: Vec<String>,
    /// Compared proposals with `ȳ ≠ x̄` by class of move (current length, or for the
    /// bidirectional mutation which endpoints it remade).
    coverage: BTreeMap<String, usize>,
}

/// The densities `(T(ȳ|x̄), T(x̄|ȳ))` of `kind`, after checking that `ȳ` has the structure the
/// mutation promises (unchanged vertices unchanged). `replay`: the bidirectional move's deletion
/// and number of new vertices.
fn densities(
    kind: MutationKind,
    x: &[Vertex],
    y: &[Vertex],
    replay: Option<(Deletion, usize)>,
    np: &NewPath,
) -> (f64, f64) {
    let f = fx();
    let k = x.len() - 1;
    let tol = 1e-9;
    match kind {
        MutationKind::Lens | MutationKind::MultiChain | MutationKind::Caustic => {
            assert_eq!(y.len(), x.len());
            for i in (0..=k).filter(|&i| i != k - 1) {
                assert!(same_point(&x[i], &y[i]), "{kind:?} moved vertex {i}");
            }
            if kind == MutationKind::Caustic {
                (t_caustic(f, x, y, tol), t_caustic(f, y, x, tol))
            } else {
                (t_lens(f, x, y, tol), t_lens(f, y, x, tol))
            }
        }
        MutationKind::LensSubpath => {
            assert_eq!(y.len(), x.len());
            for i in (0..=k).filter(|&i| i != k - 1) {
                assert!(same_point(&x[i], &y[i]), "lens subpath moved vertex {i}");
            }
            (t_lens_subpath(f, y), t_lens_subpath(f, x))
        }
        MutationKind::Bidirectional => {
            let (d, n) = replay.expect("replayed move");
            let bd = Bidirectional {
                max_edges: MAX_EDGES,
            };
            let ky = y.len() - 1;
            assert_eq!(
                ky + d.kd(),
                k + 1 + n,
                "replayed move does not match ȳ's length"
            );
            if d.l >= 0 {
                for i in 0..=d.l as usize {
                    assert!(same_point(&x[i], &y[i]), "kept light vertex {i} moved");
                }
            }
            for j in d.m..=k {
                let iy = j + ky - k;
                assert!(same_point(&x[j], &y[iy]), "kept camera vertex {j} moved");
            }
            let back = Deletion {
                l: d.l,
                m: (d.l + 1) as usize + n,
            };
            (
                t_bidirectional(f, &bd, x, y, d, n, None),
                t_bidirectional(f, &bd, y, x, back, d.kd() - 1, None),
            )
        }
        MutationKind::NewPath => (t_new_path(f, np, y), t_new_path(f, np, x)),
        MutationKind::PhotonMap => {
            assert_eq!(y.len(), x.len());
            for i in (0..=k).filter(|&i| i != k - 2) {
                assert!(same_point(&x[i], &y[i]), "photon map moved vertex {i}");
            }
            (t_photon_map(f, x, y), t_photon_map(f, y, x))
        }
        MutationKind::ManifoldLight | MutationKind::ManifoldEye => {
            assert_eq!(y.len(), x.len());
            let moved: Vec<usize> = (0..=k).filter(|&i| !same_point(&x[i], &y[i])).collect();
            assert_eq!(moved.len(), 1, "{kind:?} moved {moved:?}");
            let light = kind == MutationKind::ManifoldLight;
            (
                t_manifold(f, x, y, moved[0], light),
                t_manifold(f, y, x, moved[0], light),
            )
        }
    }
}

/// Propose from the current paths (cycling) until `want` finite ratios were compared or
/// `max_proposals` were made.
fn pointwise(kind: MutationKind, want: usize, max_proposals: usize, seed: u64) -> Tally {
    let f = fx();
    let np = new_path_lengths();
    let bd = Bidirectional {
        max_edges: MAX_EDGES,
    };
    let paths = current_paths();
    let mut t = Tally::default();
    let mut y = PathState::default();
    while t.compared < want && t.proposals < max_proposals {
        let x = &paths[t.proposals % paths.len()];
        let mut rng = stream(seed, t.proposals as u64);
        t.proposals += 1;
        // The bidirectional move's discrete choices are the first numbers it draws
        // (`sample_deletion`, then `sample_addition`): replay them on a copy of the generator.
        let replay = (kind == MutationKind::Bidirectional).then(|| {
            let mut r = rng.clone();
            let k = x.path.edges();
            let d = bd.sample_deletion(k, &mut r);
            (d, bd.sample_addition(k, d, &mut r))
        });
        y.path.vertices.clear();
        y.strategy.clear();
        let reported = match propose(kind, &np, x, &mut rng, &mut y) {
            Err(_) => {
                t.errors += 1;
                continue;
            }
            Ok(v) => v,
        };
        let replay = replay.map(|(d, n)| (d, n.expect("a move was made, so n exists")));
        let (xv, yv) = (&x.path.vertices, &y.path.vertices);
        let complete = yv.len() >= 2 && is_lens(&yv[yv.len() - 1]);
        if reported == f64::NEG_INFINITY {
            t.neg_inf += 1;
            if complete {
                let (fwd, back) = densities(kind, xv, yv, replay, &np);
                let mine = ln_ratio(f, xv, yv, fwd, back);
                if mine.is_finite() {
                    t.neg_inf_disputed += 1;
                    if t.examples.len() < 5 {
                        t.examples.push(format!(
                            "reported −∞, independent {mine} (k {} → {})",
                            xv.len() - 1,
                            yv.len() - 1
                        ));
                    }
                }
            }
            continue;
        }
        assert!(complete, "{kind:?}: finite ratio without a path");
        let (fwd, back) = densities(kind, xv, yv, replay, &np);
        let mine = ln_ratio(f, xv, yv, fwd, back);
        t.compared += 1;
        if yv.len() != xv.len() || (0..xv.len()).any(|i| !same_point(&xv[i], &yv[i])) {
            t.moved += 1;
            let k = xv.len() - 1;
            let class = match replay {
                Some((d, _)) => match (d.l == -1, d.m == k + 1) {
                    (true, true) => "whole path".to_string(),
                    (true, false) => "light endpoint".to_string(),
                    (false, true) => "lens point".to_string(),
                    (false, false) => "inner vertices".to_string(),
                },
                None => format!("k={k}"),
            };
            *t.coverage.entry(class).or_default() += 1;
        }
        let diff = (mine - reported).abs();
        if mine.is_finite() {
            t.max_abs = t.max_abs.max(diff);
        }
        if !(diff <= 1e-6 * reported.abs().max(1.0)) {
            t.bad += 1;
            if t.examples.len() < 5 {
                t.examples.push(format!(
                    "proposal {}: reported {reported}, independent {mine} (k {} → {}, replay {replay:?})",
                    t.proposals - 1,
                    xv.len() - 1,
                    yv.len() - 1
                ));
            }
        }
    }
    t
}

/// Finite ratios compared per mutation.
const WANT: usize = 2000;

fn check_pointwise(kind: MutationKind, seed: u64, min_finite_share: f64, classes: &[&str]) {
    let t = pointwise(kind, WANT, 100 * WANT, seed);
    println!(
        "{:<14} proposals {:>5}  Err {:>5}  −∞ {:>5} (disputed {})  compared {:>4} (moved {:>4})  \
         mismatches {}  max |Δ ln ratio| {:.2e}\n{:<14} moved, by class: {:?}{}",
        kind.name(),
        t.proposals,
        t.errors,
        t.neg_inf,
        t.neg_inf_disputed,
        t.compared,
        t.moved,
        t.bad,
        t.max_abs,
        "",
        t.coverage,
        t.examples
            .iter()
            .map(|m| format!("\n  {m}"))
            .collect::<String>()
    );
    assert!(
        t.compared >= WANT,
        "{}: only {} compared",
        kind.name(),
        t.compared
    );
    assert_eq!(t.bad, 0, "{}: reported ratios differ", kind.name());
    assert_eq!(t.neg_inf_disputed, 0, "{}: −∞ where f T > 0", kind.name());
    let ok = t.compared + t.neg_inf;
    assert!(
        t.compared as f64 >= min_finite_share * ok as f64,
        "{}: {} finite of {ok}",
        kind.name(),
        t.compared
    );
    for c in classes {
        let n = t.coverage.get(*c).copied().unwrap_or(0);
        assert!(
            n >= 20,
            "{}: only {n} moved proposals of class {c}",
            kind.name()
        );
    }
}

const ALL_K: [&str; 5] = ["k=1", "k=2", "k=3", "k=4", "k=5"];
const K_FROM_2: [&str; 4] = ["k=2", "k=3", "k=4", "k=5"];

#[test]
fn pointwise_bidirectional() {
    check_pointwise(
        MutationKind::Bidirectional,
        101,
        0.5,
        &[
            "whole path",
            "light endpoint",
            "lens point",
            "inner vertices",
        ],
    );
}

#[test]
fn pointwise_lens_subpath() {
    check_pointwise(MutationKind::LensSubpath, 102, 0.5, &K_FROM_2);
}

#[test]
fn pointwise_lens() {
    check_pointwise(MutationKind::Lens, 103, 0.5, &ALL_K);
}

#[test]
fn pointwise_caustic() {
    check_pointwise(MutationKind::Caustic, 104, 0.5, &K_FROM_2);
}

#[test]
fn pointwise_multi_chain() {
    check_pointwise(MutationKind::MultiChain, 105, 0.5, &ALL_K);
}

#[test]
fn pointwise_new_path() {
    check_pointwise(MutationKind::NewPath, 106, 0.1, &ALL_K[1..]);
}

#[test]
fn pointwise_photon_map() {
    check_pointwise(MutationKind::PhotonMap, 109, 0.5, &["k=3", "k=4", "k=5"]);
}

#[test]
fn pointwise_manifold_toward_the_light() {
    check_pointwise(MutationKind::ManifoldLight, 107, 0.5, &K_FROM_2);
}

#[test]
fn pointwise_manifold_toward_the_eye() {
    check_pointwise(MutationKind::ManifoldEye, 108, 0.5, &K_FROM_2);
}

// ---------------------------------------------------------------------------------------------
// (b') Pointwise, the combined rule: Σ_k P_k T_k over every mutation making the same change.
// ---------------------------------------------------------------------------------------------

/// `Σ_k P_k T_k(to|from)` of this file's densities, over every mutation that makes the change
/// `c` from `from` (all paths here are non-specular: the camera-side perturbations regenerate
/// `v_{k−1}`, and so does the caustic perturbation; the lens subpath regenerates `v_{k−1}` and the
/// lens point), and the number of mutations that contribute.
fn t_combined(
    from: &[Vertex],
    to: &[Vertex],
    c: Change,
    np: &NewPath,
    p: &MutationProbabilities,
) -> (f64, usize) {
    t_combined_but(from, to, c, np, p, "")
}

/// [`t_combined`] leaving out the mutation `skip` (a deliberately wrong sum).
fn t_combined_but(
    from: &[Vertex],
    to: &[Vertex],
    c: Change,
    np: &NewPath,
    p: &MutationProbabilities,
    skip: &str,
) -> (f64, usize) {
    let p = |name: &str| {
        if name == skip {
            0.0
        } else {
            p.probability(name)
        }
    };
    let f = fx();
    let (k, kt) = (from.len() - 1, to.len() - 1);
    let tol = 1e-9;
    let bd = Bidirectional {
        max_edges: MAX_EDGES,
    };
    let mut terms: Vec<f64> = Vec::new();
    let d = Deletion { l: c.l, m: c.m };
    if d.allowed(k) && c.result_edges(k) == Some(kt) {
        terms.push(p("bidirectional") * t_bidirectional(f, &bd, from, to, d, c.added, None));
    }
    let last = Change {
        l: k as isize - 2,
        m: k,
        added: 1,
        pivot: 0,
    };
    if c == last && kt == k {
        let pl = p("lens") + p("multi-chain");
        terms.push(pl * t_lens(f, from, to, tol));
        if k >= 2 {
            terms.push(p("caustic") * t_caustic(f, from, to, tol));
        }
    }
    let lens_tail = Change {
        l: k as isize - 2,
        m: k + 1,
        added: 2,
        pivot: 0,
    };
    if k >= 2 && c == lens_tail && kt == k {
        terms.push(p("lens-subpath") * t_lens_subpath(f, to));
    }
    let whole = Change {
        l: -1,
        m: k + 1,
        added: kt + 1,
        pivot: 0,
    };
    if c == whole {
        terms.push(p("new-path") * t_new_path(f, np, to));
    }
    (
        terms.iter().sum(),
        terms.iter().filter(|t| **t > 0.0).count(),
    )
}

/// The library's mixture of every mutation under the combined rule reports, for each proposal,
/// `ln[I(f(ȳ)) Σ_k P_k T_k(x̄|ȳ) / (I(f(x̄)) Σ_k P_k T_k(ȳ|x̄))]` with the sums over every mutation
/// that makes the same change: checked against this file's densities on 2000 finite proposals
/// (1e-6 relative), of which many have more than one mutation contributing to a sum. The same
/// comparison with the bidirectional mutation's term left out of the sums (the per-component
/// habit applied where the combined rule is claimed) disagrees on most of those.
#[test]
fn pointwise_combined_rule() {
    use mcmc_core::Proposal;
    let f = fx();
    let np = new_path_lengths();
    let m = Mutations {
        rule: mcmc_core::proposals::MixtureRule::Combined,
        ..mutations()
    };
    let probabilities = m.probabilities.clone();
    let mixture = m.proposal(&f.scene, np.clone()).expect("mixture");
    let paths = current_paths();
    let (mut compared, mut shared, mut bad, mut proposals, mut worst) = (0, 0, 0, 0, 0.0f64);
    let mut caught = 0;
    let mut by_kind = BTreeMap::new();
    let mut y = PathState::default();
    while compared < WANT && proposals < 100 * WANT {
        let x = &paths[proposals % paths.len()];
        let mut rng = stream(107, proposals as u64);
        proposals += 1;
        let p = mixture.propose(x, &mut y, &mut rng);
        if p.failure.is_some() || p.ln_ratio == f64::NEG_INFINITY {
            continue;
        }
        let c = y.change.expect("a record");
        let (xv, yv) = (&x.path.vertices, &y.path.vertices);
        let (fwd, n_fwd) = t_combined(xv, yv, c, &np, &probabilities);
        let (back, _) = t_combined(yv, xv, c.reverse(), &np, &probabilities);
        let mine = ln_ratio(f, xv, yv, fwd, back);
        let diff = (mine - p.ln_ratio).abs();
        compared += 1;
        let (fwd_b, _) = t_combined_but(xv, yv, c, &np, &probabilities, "bidirectional");
        let (back_b, _) = t_combined_but(yv, xv, c.reverse(), &np, &probabilities, "bidirectional");
        let wrong = ln_ratio(f, xv, yv, fwd_b, back_b);
        if !((wrong - p.ln_ratio).abs() <= 1e-6 * p.ln_ratio.abs().max(1.0)) {
            caught += 1;
        }
        *by_kind.entry(p.kind).or_insert(0) += 1;
        if n_fwd > 1 {
            shared += 1;
        }
        if mine.is_finite() {
            worst = worst.max(diff);
        }
        if !(diff <= 1e-6 * p.ln_ratio.abs().max(1.0)) {
            bad += 1;
            println!(
                "kind {} change {c:?}: reported {}, independent {mine}",
                p.kind, p.ln_ratio
            );
        }
    }
    println!(
        "combined rule: {proposals} proposals, {compared} compared ({shared} with several mutations making the change; by kind {by_kind:?}), {bad} mismatches, max |Δ ln ratio| {worst:.2e}; without the bidirectional term {caught} mismatches"
    );
    assert!(
        caught >= 200,
        "leaving out a term went unnoticed ({caught} mismatches)"
    );
    assert!(compared >= WANT);
    assert_eq!(bad, 0, "combined ratios differ");
    assert!(shared >= 200, "only {shared} proposals share their change");
}

// ---------------------------------------------------------------------------------------------
// (b'') The user-path proposal and its hybrid with the bidirectional mutation (Fan et al. eq. 7).
// ---------------------------------------------------------------------------------------------

/// Two user paths: light → floor (β = 15°), and light → floor → back wall (β = 10°).
const USER_PATHS: &str = "# test paths\npath beta=15\n0.05 1.99 -0.55\n0.3 0.0 0.2\npath beta=10\n-0.1 1.99 -0.65\n-0.5 0.0 -0.8\n0.2 1.0 -2.0\n";

/// The same paths as this file reads them: points and cone half-angles (radians).
fn user_paths_here() -> Vec<(Vec<DVec3>, Vec<f64>)> {
    vec![
        (
            vec![DVec3::new(0.05, 1.99, -0.55), DVec3::new(0.3, 0.0, 0.2)],
            vec![15f64.to_radians()],
        ),
        (
            vec![
                DVec3::new(-0.1, 1.99, -0.65),
                DVec3::new(-0.5, 0.0, -0.8),
                DVec3::new(0.2, 1.0, -2.0),
            ],
            vec![10f64.to_radians(); 2],
        ),
    ]
}

/// Which of the emitter quad's two triangles (`p, p+a, p+a+b` and `p, p+a+b, p+b`) holds `q`.
fn light_triangle(q: DVec3) -> usize {
    let s = (q.x - LIGHT_CORNER.x) / LIGHT_SIDE;
    let t = (q.z - LIGHT_CORNER.z) / LIGHT_SIDE;
    (t > s) as usize
}

/// User-path proposal `from → to` with record `c`: the light part `to[0 ..= m]` is new, drawn
/// uniformly on the triangle of the light holding `u_0`, then by cones about the directions toward
/// the next user point; `(1/N_UP) Σ_i C_i Π` (eq. 6) in area measure, 0 when the record is not a
/// user-path move (light part replaced, `x_d = v_{k−1}` and the lens kept).
fn t_user_path(f: &Fixture, from: &[Vertex], to: &[Vertex], c: Change) -> f64 {
    let k = from.len() - 1;
    if c.l != -1 || c.m + 1 != k || c.added < 2 || to.len() != c.added + 2 {
        return 0.0;
    }
    let m = c.added - 1;
    let paths = user_paths_here();
    let mut sum = 0.0;
    for (u, beta) in &paths {
        if u.len() != m + 1 || light_triangle(u[0]) != light_triangle(to[0].p()) {
            continue;
        }
        let mut t = 2.0 / (LIGHT_SIDE * LIGHT_SIDE);
        for j in 0..m {
            let w = dir(&to[j], &to[j + 1]);
            let d2 = (to[j + 1].p() - to[j].p()).length_squared();
            t *= cone_density((u[j + 1] - to[j].p()).normalize(), w, beta[j])
                * cos_at(f, &to[j + 1], w)
                / d2;
        }
        sum += t;
    }
    sum / paths.len() as f64
}

/// The hybrid of eq. 7 with `P_UP = P_BD`: `(T_BD + T_UP)/2` for the change `c`.
fn t_hybrid(f: &Fixture, from: &[Vertex], to: &[Vertex], c: Change) -> f64 {
    let (k, kt) = (from.len() - 1, to.len() - 1);
    let bd = Bidirectional {
        max_edges: MAX_EDGES,
    };
    let d = Deletion { l: c.l, m: c.m };
    let t_bd = if d.allowed(k) && c.result_edges(k) == Some(kt) {
        t_bidirectional(f, &bd, from, to, d, c.added, None)
    } else {
        0.0
    };
    0.5 * t_bd + 0.5 * t_user_path(f, from, to, c)
}

/// The library's user-path proposal mixed with the bidirectional mutation (half each) reports
/// `ln[I(f(ȳ)) T(x̄|ȳ) / (I(f(x̄)) T(ȳ|x̄))]` with `T = (T_BD + T_UP)/2` (eq. 7), checked against this
/// file's densities on 2000 finite proposals, several hundred of them user-path moves. Mixed by the
/// per-component rule instead, the user-path moves report their own ratio, which is −∞ from every
/// path away from the user paths: those disagree with eq. 7 (caught), and none is ever accepted.
#[test]
fn pointwise_user_path_hybrid() {
    use mcmc_core::Proposal;
    let f = fx();
    let np = new_path_lengths();
    let paths = UserPaths::parse(USER_PATHS, "test", &f.scene).expect("user paths");
    assert_eq!(paths.len(), 2);
    for rule in [UserPathRule::Hybrid, UserPathRule::PerComponent] {
        let m = Mutations {
            probabilities: MutationProbabilities::of(&[("bidirectional", 0.5), ("user-path", 0.5)])
                .expect("probabilities"),
            photon: PhotonProposals {
                user_paths: std::sync::Arc::new(paths.clone()),
                user_path_rule: rule,
                ..Default::default()
            },
            ..mutations()
        };
        m.validate().expect("valid");
        let mixture = m.proposal(&f.scene, np.clone()).expect("mixture");
        let currents = current_paths();
        let (mut compared, mut bad, mut up_compared, mut up_finite, mut up_proposed) =
            (0, 0, 0, 0, 0);
        let (mut proposals, mut worst) = (0usize, 0.0f64);
        let mut y = PathState::default();
        while compared < WANT && proposals < 100 * WANT {
            let x = &currents[proposals % currents.len()];
            let mut rng = stream(110, proposals as u64);
            proposals += 1;
            let p = mixture.propose(x, &mut y, &mut rng);
            if p.failure.is_some() || !y.carries_light() {
                continue;
            }
            let c = y.change.expect("a record");
            let (xv, yv) = (&x.path.vertices, &y.path.vertices);
            let mine = ln_ratio(
                f,
                xv,
                yv,
                t_hybrid(f, xv, yv, c),
                t_hybrid(f, yv, xv, c.reverse()),
            );
            let up = p.kind == 1;
            up_proposed += up as usize;
            up_finite += (up && p.ln_ratio.is_finite()) as usize;
            if !mine.is_finite() && !p.ln_ratio.is_finite() {
                continue;
            }
            compared += 1;
            up_compared += up as usize;
            let diff = (mine - p.ln_ratio).abs();
            if diff.is_finite() {
                worst = worst.max(diff);
            }
            let agree = mine.is_finite() == p.ln_ratio.is_finite()
                && (!mine.is_finite() || diff <= 1e-6 * p.ln_ratio.abs().max(1.0));
            if !agree {
                bad += 1;
                if bad <= 3 {
                    println!(
                        "  kind {} {c:?} k {}→{}: reported {}, eq. 7 {mine} (T_UP fwd {:.3e} back {:.3e})",
                        p.kind,
                        xv.len() - 1,
                        yv.len() - 1,
                        p.ln_ratio,
                        t_user_path(f, xv, yv, c),
                        t_user_path(f, yv, xv, c.reverse())
                    );
                }
            }
        }
        println!(
            "{rule:?}: {proposals} proposals, {compared} compared ({up_compared} user-path moves), {bad} disagree with eq. 7 (max |Δ| {worst:.2e} where finite); user-path moves with a finite ratio: {up_finite} of {up_proposed}"
        );
        assert!(
            compared >= WANT && up_compared >= 200,
            "too few comparisons"
        );
        match rule {
            UserPathRule::Hybrid => assert_eq!(bad, 0, "the hybrid's ratios differ from eq. 7"),
            UserPathRule::PerComponent => {
                assert!(bad >= 200, "the per-component rule was not caught ({bad})");
                assert_eq!(up_finite, 0, "a user-path move reversed itself");
            }
            UserPathRule::BidirectionalRatio => unreachable!("not run here"),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// (a) Numerical: E[h/T] = area(A).
// ---------------------------------------------------------------------------------------------

/// An axis-aligned rectangle `[lo, hi]` (flat along one axis) of a surface facing `normal`.
#[derive(Clone, Copy, Debug)]
struct Patch {
    lo: DVec3,
    hi: DVec3,
    normal: DVec3,
}

impl Patch {
    /// `[x0, x1] × [z0, z1]` of the floor.
    fn floor(x: [f64; 2], z: [f64; 2]) -> Self {
        Self {
            lo: DVec3::new(x[0], 0.0, z[0]),
            hi: DVec3::new(x[1], 0.0, z[1]),
            normal: DVec3::Y,
        }
    }
    /// `[x0, x1] × [y0, y1]` of the back wall.
    fn wall(x: [f64; 2], y: [f64; 2]) -> Self {
        Self {
            lo: DVec3::new(x[0], y[0], -2.0),
            hi: DVec3::new(x[1], y[1], -2.0),
            normal: DVec3::Z,
        }
    }
    fn area(&self) -> f64 {
        let e = self.hi - self.lo;
        e.x * e.y + e.y * e.z + e.z * e.x
    }
    fn contains(&self, v: &Vertex) -> bool {
        let p = v.p();
        let eps = 1e-9;
        v.kind == VertexKind::Surface
            && v.n().dot(self.normal) > 0.5
            && (0..3).all(|i| p[i] >= self.lo[i] - eps && p[i] <= self.hi[i] + eps)
    }
    fn corners(&self) -> Vec<DVec3> {
        (0..8)
            .map(|c| {
                DVec3::new(
                    if c & 1 == 0 { self.lo.x } else { self.hi.x },
                    if c & 2 == 0 { self.lo.y } else { self.hi.y },
                    if c & 4 == 0 { self.lo.z } else { self.hi.z },
                )
            })
            .collect()
    }
}

#[derive(Debug)]
struct Estimate {
    proposals: usize,
    hits: usize,
    area: f64,
    /// `(mean, standard error, z)` with the density under test.
    correct: (f64, f64, f64),
    /// The same with the deliberately wrong density.
    broken: (f64, f64, f64),
}

/// Mean of `h/T` over `n` proposals; `sample` returns `Some((1/T, 1/T_broken))` when `h = 1`.
fn estimate(
    name: &str,
    area: f64,
    n: usize,
    seed: u64,
    mut sample: impl FnMut(&mut ChainRng) -> Option<(f64, f64)>,
) -> Estimate {
    let mut rng = stream(seed, 0);
    let (mut s, mut s2, mut b, mut b2, mut hits) = (0.0, 0.0, 0.0, 0.0, 0);
    for _ in 0..n {
        if let Some((v, w)) = sample(&mut rng) {
            hits += 1;
            s += v;
            s2 += v * v;
            b += w;
            b2 += w * w;
        }
    }
    let stats = |s: f64, s2: f64| {
        let mean = s / n as f64;
        let var = (s2 / n as f64 - mean * mean) * n as f64 / (n - 1) as f64;
        let se = (var / n as f64).sqrt();
        (mean, se, (mean - area) / se)
    };
    let e = Estimate {
        proposals: n,
        hits,
        area,
        correct: stats(s, s2),
        broken: stats(b, b2),
    };
    println!(
        "{name:<34} N = {n}, hits {hits:>6}, measure {area:.5}: E[h/T] = {:.5} ± {:.5} \
         (z = {:+.2}); broken: {:.5} ± {:.5} (z = {:+.2})",
        e.correct.0, e.correct.1, e.correct.2, e.broken.0, e.broken.1, e.broken.2
    );
    e
}

const BROKEN_SCALE: f64 = 1.15;

/// Lens or multi-chain perturbation of the fixed `k = 2` path: `v_1` moves into a floor patch
/// `A` to the right of it; `T` = offset density × raster-to-area Jacobian.
fn camera_side_estimate(kind: MutationKind, seed: u64) -> Estimate {
    let f = fx();
    let x = fixed_k2();
    let xv = x.path.vertices.clone();
    let patch = Patch::floor(
        [P1_K2.x + 0.05, P1_K2.x + 0.25],
        [P1_K2.z - 0.2, P1_K2.z + 0.2],
    );
    // The patch's image lies inside the offset annulus r1 ≤ r ≤ r2 (its raster image is a convex
    // quad; all of it is ≥ 0.3 px to the right of x̄'s raster position, the corners within r2).
    let rx = f.cam.raster(P1_K2).expect("in image");
    for c in patch.corners() {
        let r = f.cam.raster(c).expect("patch corner in image");
        let dist = ((r[0] - rx[0]).powi(2) + (r[1] - rx[1]).powi(2)).sqrt();
        assert!(
            r[0] - rx[0] > 0.3 && dist < 0.95 * r2_pixels(f),
            "{r:?} {rx:?}"
        );
    }
    let np = new_path_lengths();
    let mut y = PathState::default();
    let name = format!("{} perturbation", kind.name());
    estimate(&name, patch.area(), 200_000, seed, |rng| {
        y.path.vertices.clear();
        propose(kind, &np, &x, rng, &mut y).ok()?;
        let yv = &y.path.vertices;
        (yv.len() == 3 && patch.contains(&yv[1])).then(|| {
            let t = t_lens(f, &xv, yv, 0.0);
            (1.0 / t, 1.0 / (BROKEN_SCALE * t))
        })
    })
}

fn lens_estimate() -> &'static Estimate {
    static E: OnceLock<Estimate> = OnceLock::new();
    E.get_or_init(|| camera_side_estimate(MutationKind::Lens, 201))
}

fn multi_chain_estimate() -> &'static Estimate {
    static E: OnceLock<Estimate> = OnceLock::new();
    E.get_or_init(|| camera_side_estimate(MutationKind::MultiChain, 202))
}

/// Caustic perturbation of the fixed `k = 2` path: the direction leaving the light turns, `v_1`
/// moves into a floor patch near it; `T` = angular offset density × solid-angle-to-area.
fn caustic_estimate() -> &'static Estimate {
    static E: OnceLock<Estimate> = OnceLock::new();
    E.get_or_init(|| {
        let f = fx();
        let x = fixed_k2();
        let xv = x.path.vertices.clone();
        let patch = Patch::floor(
            [P1_K2.x + 0.02, P1_K2.x + 0.1],
            [P1_K2.z - 0.05, P1_K2.z + 0.05],
        );
        // Every direction from v0 into the patch turns by θ1 < θ < θ2 (the cone θ ≤ c meets the
        // floor in a convex set: corners suffice for the upper bound; the patch keeps ≥ 2 cm
        // from v1, far outside the cone θ < θ1).
        for c in patch.corners() {
            let (a, b) = ((P1_K2 - P0_K2).normalize(), (c - P0_K2).normalize());
            let theta = a.cross(b).length().atan2(a.dot(b));
            assert!(
                theta < 0.95 * f.settings.theta2 && theta > 10.0 * f.settings.theta1,
                "{theta}"
            );
        }
        let np = new_path_lengths();
        let mut y = PathState::default();
        estimate("caustic perturbation", patch.area(), 200_000, 203, |rng| {
            y.path.vertices.clear();
            propose(MutationKind::Caustic, &np, &x, rng, &mut y).ok()?;
            let yv = &y.path.vertices;
            (yv.len() == 3 && patch.contains(&yv[1])).then(|| {
                let t = t_caustic(f, &xv, yv, 0.0);
                (1.0 / t, 1.0 / (BROKEN_SCALE * t))
            })
        })
    })
}

/// Lens subpath of the fixed `k = 2` path: a new `v_1` through a uniform raster position into a
/// floor patch in view.
fn lens_subpath_estimate() -> &'static Estimate {
    static E: OnceLock<Estimate> = OnceLock::new();
    E.get_or_init(|| {
        let f = fx();
        let x = fixed_k2();
        let patch = Patch::floor([-0.6, 0.6], [0.0, 1.0]);
        for c in patch.corners() {
            assert!(
                f.cam.raster(c).is_some(),
                "patch corner {c:?} outside the image"
            );
        }
        let np = new_path_lengths();
        let mut y = PathState::default();
        estimate("lens subpath", patch.area(), 200_000, 204, |rng| {
            y.path.vertices.clear();
            propose(MutationKind::LensSubpath, &np, &x, rng, &mut y).ok()?;
            let yv = &y.path.vertices;
            (yv.len() == 3 && patch.contains(&yv[1])).then(|| {
                let t = t_lens_subpath(f, yv);
                (1.0 / t, 1.0 / (BROKEN_SCALE * t))
            })
        })
    })
}

/// Bidirectional, `k = 3` (light → floor → wall → lens): the set is "same length, same
/// `v_0, v_2, v_3`, new `v_1` in a floor patch", reached only by deleting exactly `v_1`
/// (`l = 0, m = 2`) and adding one vertex — by the light walk from `v_0` (split `a = 1`) or by the
/// camera walk from `v_2` (split `a = 0`). The broken density keeps only the light split's term.
fn bidirectional_estimate() -> &'static Estimate {
    static E: OnceLock<Estimate> = OnceLock::new();
    E.get_or_init(|| {
        let f = fx();
        let x = fixed_k3();
        let xv = x.path.vertices.clone();
        let patch = Patch::floor([-1.0, 1.0], [-1.8, 0.0]);
        // A shorter limit than the pointwise checks, so that the move under study is common.
        let bd = Bidirectional { max_edges: 3 };
        let d = Deletion { l: 0, m: 2 };
        let mut y = PathState::default();
        estimate(
            "bidirectional (replace v1)",
            patch.area(),
            400_000,
            205,
            |rng| {
                y.path.vertices.clear();
                bd.propose(&f.scene, IMPORTANCE, &x, rng, &mut y).ok()?;
                let yv = &y.path.vertices;
                let hit = yv.len() == 4
                    && [0, 2, 3].iter().all(|&i| same_point(&xv[i], &yv[i]))
                    && !same_point(&xv[1], &yv[1])
                    && patch.contains(&yv[1]);
                hit.then(|| {
                    let t = t_bidirectional(f, &bd, &xv, yv, d, 1, None);
                    let one = t_bidirectional(f, &bd, &xv, yv, d, 1, Some(1));
                    (1.0 / t, 1.0 / one)
                })
            },
        )
    })
}

/// Bidirectional, `k = 2` (light → floor → lens), a new vertex between `v_1` and the lens in a
/// back-wall patch. With a pinhole the regenerated lens point is the old one, so the same `ȳ`
/// comes from two moves: inserting one vertex (`l = 1, m = 2, n = 1`) and deleting and remaking
/// the lens (`l = 1, m = 3, n = 2`); each has both splits (light walk from `v_1`, camera walk from
/// the lens). The total density is their sum; the broken one forgets the lens-remaking move.
fn bidirectional_lens_estimate() -> &'static Estimate {
    static E: OnceLock<Estimate> = OnceLock::new();
    E.get_or_init(|| {
        let f = fx();
        let x = fixed_k2();
        let xv = x.path.vertices.clone();
        let patch = Patch::wall([-1.8, 1.8], [0.1, 1.9]);
        for c in patch.corners() {
            assert!(
                f.cam.raster(c).is_some(),
                "patch corner {c:?} outside the image"
            );
        }
        let bd = Bidirectional { max_edges: 3 };
        let insert = Deletion { l: 1, m: 2 };
        let remake = Deletion { l: 1, m: 3 };
        let mut y = PathState::default();
        estimate(
            "bidirectional (insert before lens)",
            patch.area(),
            300_000,
            206,
            |rng| {
                y.path.vertices.clear();
                bd.propose(&f.scene, IMPORTANCE, &x, rng, &mut y).ok()?;
                let yv = &y.path.vertices;
                let hit = yv.len() == 4
                    && same_point(&xv[0], &yv[0])
                    && same_point(&xv[1], &yv[1])
                    && same_point(&xv[2], &yv[3])
                    && patch.contains(&yv[2]);
                hit.then(|| {
                    let a = t_bidirectional(f, &bd, &xv, yv, insert, 1, None);
                    let b = t_bidirectional(f, &bd, &xv, yv, remake, 2, None);
                    (1.0 / (a + b), 1.0 / b)
                })
            },
        )
    })
}

/// New path, `k = 2`: the set "v_0 anywhere on the emitter, v_1 in a floor patch in view" has
/// measure `area(light) × area(patch)`; `T = P_len(2)/3 · (p_0 + p_1 + p_2)`. The broken density
/// keeps only the light-tracing strategy's term (`s = 2`).
fn new_path_estimate() -> &'static Estimate {
    static E: OnceLock<Estimate> = OnceLock::new();
    E.get_or_init(|| {
        let f = fx();
        let x = fixed_k2();
        let patch = Patch::floor([-0.8, 0.8], [-1.5, 1.0]);
        for c in patch.corners() {
            assert!(
                f.cam.raster(c).is_some(),
                "patch corner {c:?} outside the image"
            );
        }
        let np = new_path_lengths();
        let mut y = PathState::default();
        estimate(
            "new path (k = 2)",
            f.light_area * patch.area(),
            300_000,
            207,
            |rng| {
                y.path.vertices.clear();
                propose(MutationKind::NewPath, &np, &x, rng, &mut y).ok()?;
                let yv = &y.path.vertices;
                let hit = yv.len() == 3
                    && f.scene.light_at(yv[0].point.primitive).is_some()
                    && patch.contains(&yv[1]);
                hit.then(|| {
                    let t = t_new_path(f, &np, yv);
                    let p_len = np.length_probability[1];
                    let only_s2 = p_len / 3.0 * strategy_density(f, yv, 2);
                    (1.0 / t, 1.0 / only_s2)
                })
            },
        )
    })
}

/// Manifold perturbation of the fixed `k = 2` path, from the lens (toward the light) or from the
/// light (toward the eye): `v_1` moves into a small floor patch beside it (the perturbation is
/// concentrated: at λ = 50 its directions spread by about 0.01 rad).
fn manifold_estimate(kind: MutationKind, seed: u64) -> Estimate {
    let f = fx();
    let x = fixed_k2();
    let xv = x.path.vertices.clone();
    let patch = Patch::floor(
        [P1_K2.x + 0.004, P1_K2.x + 0.03],
        [P1_K2.z - 0.015, P1_K2.z + 0.01],
    );
    let np = new_path_lengths();
    let mut y = PathState::default();
    let light = kind == MutationKind::ManifoldLight;
    estimate(kind.name(), patch.area(), 200_000, seed, |rng| {
        y.path.vertices.clear();
        propose(kind, &np, &x, rng, &mut y).ok()?;
        let yv = &y.path.vertices;
        (yv.len() == 3 && patch.contains(&yv[1])).then(|| {
            let t = t_manifold(f, &xv, yv, 1, light);
            (1.0 / t, 1.0 / (BROKEN_SCALE * t))
        })
    })
}

fn manifold_light_estimate() -> &'static Estimate {
    static E: OnceLock<Estimate> = OnceLock::new();
    E.get_or_init(|| manifold_estimate(MutationKind::ManifoldLight, 209))
}

fn manifold_eye_estimate() -> &'static Estimate {
    static E: OnceLock<Estimate> = OnceLock::new();
    E.get_or_init(|| manifold_estimate(MutationKind::ManifoldEye, 210))
}

fn assert_accepted(name: &str, e: &Estimate) {
    assert!(e.hits >= 1000, "{name}: only {} hits", e.hits);
    assert!(
        e.correct.2.abs() < Z_LIMIT,
        "{name}: E[h/T] = {} ± {} vs measure {} (z = {}, {} of {} proposals hit)",
        e.correct.0,
        e.correct.1,
        e.area,
        e.correct.2,
        e.hits,
        e.proposals
    );
}

fn assert_rejected(name: &str, e: &Estimate) {
    assert!(
        e.broken.2.abs() >= Z_LIMIT,
        "{name}: the broken density passes: {} ± {} vs measure {} (z = {})",
        e.broken.0,
        e.broken.1,
        e.area,
        e.broken.2
    );
}

#[test]
fn numerical_lens_perturbation() {
    assert_accepted("lens perturbation", lens_estimate());
}

#[test]
fn numerical_multi_chain_perturbation() {
    assert_accepted("multi-chain perturbation", multi_chain_estimate());
}

#[test]
fn numerical_caustic_perturbation() {
    assert_accepted("caustic perturbation", caustic_estimate());
}

#[test]
fn numerical_lens_subpath() {
    assert_accepted("lens subpath", lens_subpath_estimate());
}

#[test]
fn numerical_bidirectional_replace_one_vertex() {
    assert_accepted("bidirectional, replace v1", bidirectional_estimate());
}

#[test]
fn numerical_bidirectional_insert_before_lens() {
    assert_accepted(
        "bidirectional, insert before lens",
        bidirectional_lens_estimate(),
    );
}

#[test]
fn numerical_manifold_perturbation() {
    assert_accepted(
        "manifold perturbation from the lens",
        manifold_light_estimate(),
    );
    assert_accepted(
        "manifold perturbation from the light",
        manifold_eye_estimate(),
    );
}

/// Photon-map proposal of the fixed `k = 3` path: from the wall vertex `v_2` the direction back to
/// `v_1` turns inside the 30° cone, and the new `v_1` lands in a floor patch around the old one;
/// `T` = cone density × solid-angle-to-area. The broken density is the one the paper prints,
/// `1/(2πγ)` per steradian, without the `sin θ` of the cone's area element.
fn photon_map_estimate() -> &'static Estimate {
    static E: OnceLock<Estimate> = OnceLock::new();
    E.get_or_init(|| {
        let f = fx();
        let x = fixed_k3();
        let xv = x.path.vertices.clone();
        let patch = Patch::floor(
            [P1_K3.x - 0.15, P1_K3.x + 0.25],
            [P1_K3.z - 0.2, P1_K3.z + 0.2],
        );
        for c in patch.corners() {
            let (a, b) = ((P1_K3 - P2_K3).normalize(), (c - P2_K3).normalize());
            let theta = a.cross(b).length().atan2(a.dot(b));
            assert!(theta < 0.95 * GAMMA, "{theta}");
        }
        let np = new_path_lengths();
        let mut y = PathState::default();
        estimate("photon map", patch.area(), 200_000, 206, |rng| {
            y.path.vertices.clear();
            propose(MutationKind::PhotonMap, &np, &x, rng, &mut y).ok()?;
            let yv = &y.path.vertices;
            (yv.len() == 4 && patch.contains(&yv[1])).then(|| {
                let t = t_photon_map(f, &xv, yv);
                let (wx, wy) = (dir(&xv[2], &xv[1]), dir(&yv[2], &yv[1]));
                let sin = wx.cross(wy).length();
                (1.0 / t, 1.0 / (t * sin))
            })
        })
    })
}

#[test]
fn numerical_photon_map() {
    assert_accepted("photon map", photon_map_estimate());
}

#[test]
fn numerical_new_path() {
    assert_accepted("new path", new_path_estimate());
}

/// The numerical checks have the power to see a wrong density: `T × 1.15` for the perturbations
/// and the lens subpath; for the bidirectional move one split's term instead of the sum, and
/// (pinhole) forgetting the lens-remaking move; for the new path one strategy instead of the sum.
#[test]
fn numerical_checks_reject_wrong_densities() {
    assert_rejected("lens perturbation × 1.15", lens_estimate());
    assert_rejected("multi-chain perturbation × 1.15", multi_chain_estimate());
    assert_rejected("caustic perturbation × 1.15", caustic_estimate());
    assert_rejected("lens subpath × 1.15", lens_subpath_estimate());
    assert_rejected("bidirectional, one split", bidirectional_estimate());
    assert_rejected(
        "bidirectional, lens-remaking move forgotten",
        bidirectional_lens_estimate(),
    );
    assert_rejected("new path, one strategy", new_path_estimate());
    assert_rejected("manifold from the lens × 1.15", manifold_light_estimate());
    assert_rejected("manifold from the light × 1.15", manifold_eye_estimate());
    assert_rejected("photon map, the paper's 1/(2πγ)", photon_map_estimate());
}
