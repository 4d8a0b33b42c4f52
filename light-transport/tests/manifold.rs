//! Specular manifolds (Jakob & Marschner 2012, §3.3–4): the constraint Jacobian against finite
//! differences on random chains of 1–10 specular vertices on curved surfaces (reflective and
//! refractive, spheres with exact geometry and triangles with random vertex normals); the
//! generalised geometry term against the closed form of a planar mirror and against itself computed
//! from the other end; the manifold walk against closed-form specular points (a planar mirror, a
//! flat refracting interface) and its quadratic convergence on a curved mirror.

use light_transport::geometry::{
    Derivatives, NO_SHADING, Ray, Sphere, SurfacePoint, Triangle, TriangleShading,
};
use light_transport::manifold::constraint::constraint;
use light_transport::manifold::geometry_term::generalized_geometry_reverse;
use light_transport::manifold::{
    ChainVertex, Interaction, ManifoldSettings, NO_MATERIAL, chain_jacobian, generalized_geometry,
    trace_chain, walk_manifold,
};
use light_transport::math::DVec3;
use light_transport::scene::builtin::SceneBuilder;
use light_transport::scene::{MaterialDesc, Scene};
use light_transport::spectrum::Rgb;
use mcmc_core::ChainRng;
use mcmc_core::rng::{stream, uniform};

fn r3(rng: &mut ChainRng) -> DVec3 {
    DVec3::new(uniform(rng), uniform(rng), uniform(rng)) * 2.0 - 1.0
}

/// A random surface point with curvature and its derivatives: on a random sphere (exact geometry)
/// or on a random triangle with random vertex normals and texture coordinates.
fn random_point(rng: &mut ChainRng) -> (SurfacePoint, Derivatives) {
    if uniform(rng) < 0.5 {
        let s = Sphere {
            center: r3(rng) * 3.0,
            radius: 0.3 + uniform(rng),
            flip: uniform(rng) < 0.3,
        };
        let dir = r3(rng).normalize();
        let point = s.point(s.center + dir * s.radius, 0);
        (point, s.derivatives(point.n, s.local(point.n)[0]))
    } else {
        let base = r3(rng) * 3.0;
        let p = [0, 1, 2].map(|_| base + r3(rng));
        let t = Triangle {
            p,
            uv: [0, 1, 2].map(|_| [uniform(rng) as f32 * 2.0, uniform(rng) as f32 * 2.0]),
            flip: false,
            shading: NO_SHADING,
        };
        let n = t.normal();
        let sh = TriangleShading {
            n: [0, 1, 2].map(|_| (n + r3(rng) * 0.6).normalize()),
            s: None,
        };
        let (b1, b2) = (0.1 + 0.4 * uniform(rng), 0.1 + 0.4 * uniform(rng));
        (
            t.point_shaded(b1, b2, 0, Some(&sh)),
            t.derivatives(b1, b2, Some(&sh)),
        )
    }
}

/// A random chain; with `offsets`, every vertex gets a random offset `o` (|o| < 0.5) of an offset
/// manifold (§5.2).
fn random_chain(rng: &mut ChainRng, m: usize, offsets: bool) -> Vec<ChainVertex> {
    (0..m + 2)
        .map(|_| {
            let interaction = if uniform(rng) < 0.5 {
                Interaction::Reflect
            } else {
                Interaction::Refract {
                    eta: 1.1 + uniform(rng),
                }
            };
            let (point, derivatives) = random_point(rng);
            ChainVertex {
                point,
                derivatives,
                material: 0,
                interaction,
                offset: if offsets {
                    let (r, phi) = (
                        0.5 * uniform(rng).sqrt(),
                        std::f64::consts::TAU * uniform(rng),
                    );
                    [r * phi.cos(), r * phi.sin()]
                } else {
                    [0.0, 0.0]
                },
            }
        })
        .collect()
}

/// Move `v` by `h` along `e` (position) with its shading normal moved to first order.
fn moved(v: &ChainVertex, e: DVec3, dn: DVec3, h: f64) -> ChainVertex {
    let mut w = *v;
    w.point.p += e * h;
    w.point.ns = (v.point.ns + dn * h).normalize();
    w
}

/// Every Jacobian block against central differences of the constraint (h = 1e-6, each vertex in
/// its own shading frame, which tilts and turns as the point moves), on 300 random chains of 1–10
/// specular vertices, half of them on offset manifolds (|o| < 0.5): worst relative error per
/// column, over columns larger than 1e-3. Measured: 6.7e-8 over 9900 columns; without the term
/// of the frame tilting with the normal, 2.0; without its in-plane turn (felt by offset chains
/// only), 1.97 — both tried by hand.
#[test]
fn jacobian_blocks_match_finite_differences() {
    let mut rng = stream(41, 0);
    let h = 1e-6;
    let mut worst = 0.0f64;
    let mut columns = 0usize;
    for trial in 0..300 {
        let m = 1 + trial % 10;
        let chain = random_chain(&mut rng, m, trial % 2 == 1);
        let n = chain.len();
        let (b0, b1) = (chain[0].tangent_basis(), chain[n - 1].tangent_basis());
        let j = chain_jacobian(&chain, b0, b1).expect("a defined Jacobian");
        for i in 1..=m {
            let c = |prev: &ChainVertex, v: &ChainVertex, next: &ChainVertex| {
                constraint(prev.p(), v, next.p()).expect("defined")
            };
            // (vertex index, block) for the three neighbours.
            let blocks = [
                (
                    i - 1,
                    j.a.lower[i - 1],
                    if i == 1 { Some(j.first) } else { None },
                ),
                (i, j.a.diagonal[i - 1], None),
                (
                    i + 1,
                    j.a.upper[i - 1],
                    if i == m { Some(j.last) } else { None },
                ),
            ];
            for (k, (at, inner, edge)) in blocks.into_iter().enumerate() {
                if k == 0 && i == 1 && edge.is_none() {
                    continue;
                }
                let block = edge.unwrap_or(inner);
                let (e1, e2) = if at == 0 {
                    b0
                } else if at == n - 1 {
                    b1
                } else {
                    chain[at].tangent_basis()
                };
                // Endpoints move without their normal mattering (the constraint of `i` reads
                // only the neighbours' positions).
                let (d1, d2) = if at == i {
                    chain[i].normal_derivatives(e1, e2)
                } else {
                    (DVec3::ZERO, DVec3::ZERO)
                };
                for (col, (e, dn)) in [(e1, d1), (e2, d2)].into_iter().enumerate() {
                    let eval = |s: f64| {
                        let mut local = [chain[i - 1], chain[i], chain[i + 1]];
                        local[at + 1 - i] = moved(&chain[at], e, dn, s * h);
                        c(&local[0], &local[1], &local[2])
                    };
                    let fd = (eval(1.0) - eval(-1.0)) / (2.0 * h);
                    let an = block.column(col).into_owned();
                    let scale = an.norm().max(fd.norm());
                    if scale > 1e-3 {
                        worst = worst.max((an - fd).norm() / scale);
                        columns += 1;
                    }
                }
            }
        }
    }
    println!("{columns} columns compared, worst relative error {worst:.2e}");
    assert!(columns > 5000);
    assert!(worst < 1e-6, "worst relative error {worst:e}");
}

/// A scene with a mirror floor `y = 0` (x, z ∈ [−4, 4]) and a matte wall `x = 3` facing −x; or,
/// with `refract`, a water surface (η = 1.33) at `y = 0` over a matte floor at `y = −1`.
fn flat_scene(refract: bool) -> Scene {
    let mut b = SceneBuilder::new(16, 16, DVec3::new(0.0, 2.0, 6.0), DVec3::ZERO, 40.0);
    let matte = b.matte(0.5, 0.5, 0.5);
    let special = if refract {
        b.material(MaterialDesc::Glass {
            eta: 1.33,
            alpha_u: 0.0,
            alpha_v: 0.0,
            kr: Rgb::WHITE,
            kt: Rgb::WHITE,
        })
    } else {
        b.material(MaterialDesc::Mirror { kr: Rgb::WHITE })
    };
    let black = b.matte(0.0, 0.0, 0.0);
    // The specular plane y = 0, normal +y.
    b.quad(
        DVec3::new(-4.0, 0.0, -4.0),
        DVec3::Z * 8.0,
        DVec3::X * 8.0,
        special,
        None,
    );
    if refract {
        b.quad(
            DVec3::new(-4.0, -1.0, -4.0),
            DVec3::Z * 8.0,
            DVec3::X * 8.0,
            matte,
            None,
        );
    } else {
        b.quad(
            DVec3::new(3.0, -1.0, -4.0),
            DVec3::Z * 8.0,
            DVec3::Y * 5.0,
            matte,
            None,
        );
    }
    b.quad(
        DVec3::new(-0.5, 3.0, -0.5),
        DVec3::X,
        DVec3::Z,
        black,
        Some(Rgb::splat(1.0)),
    );
    Scene::new(&b.finish(), None).unwrap()
}

/// The chain from the point `x0` (no surface) along `dir` through one specular interaction to the
/// next surface.
fn traced_chain(
    scene: &Scene,
    x0: DVec3,
    dir: DVec3,
    interaction: Interaction,
) -> Vec<ChainVertex> {
    let start = ChainVertex::new(
        scene,
        SurfacePoint::flat(x0, DVec3::Y, u32::MAX),
        NO_MATERIAL,
        Interaction::Reflect,
        [0.0; 2],
    );
    trace_chain(scene, &start, dir, &[interaction])
        .expect("a traced chain")
        .into_vec()
}

fn surface_vertex(scene: &Scene, from: DVec3, to: DVec3) -> ChainVertex {
    let hit = scene
        .intersect(&Ray::new(from, (to - from).normalize()))
        .unwrap();
    ChainVertex::new(
        scene,
        hit.point,
        scene.primitive_material[hit.point.primitive as usize],
        Interaction::Reflect,
        [0.0; 2],
    )
}

#[test]
fn the_walk_finds_a_planar_mirrors_reflection_point() {
    let scene = flat_scene(false);
    let x0 = DVec3::new(0.0, 1.0, 0.2);
    let chain = traced_chain(
        &scene,
        x0,
        DVec3::new(1.0, -0.6, 0.1).normalize(),
        Interaction::Reflect,
    );
    assert!(
        (chain[2].p().x - 3.0).abs() < 1e-9,
        "the chain ends on the wall"
    );
    let settings = ManifoldSettings::default();
    for (dy, dz) in [(0.3, 0.2), (-0.2, 0.5), (0.05, -0.4)] {
        let target_p = chain[2].p() + DVec3::new(0.0, dy, dz);
        let target = surface_vertex(&scene, target_p - DVec3::X * 0.5, target_p);
        let walked = walk_manifold(&scene, &chain, &target, &settings).expect("converges");
        // Closed form: the line from x0's mirror image to the target meets the mirror there.
        let image = DVec3::new(x0.x, -x0.y, x0.z);
        let t = image.y / (image.y - target.p().y);
        let exact = image + (target.p() - image) * t;
        let err = (walked.chain[1].p() - exact).length();
        println!(
            "mirror: {} iterations, reflection point error {err:.1e}",
            walked.iterations
        );
        assert!(err < 1e-6, "{err}");
        // The generalised geometry term of a planar mirror: cos θ_0 cos θ_2 / (d₀₁ + d₁₂)², here
        // with x0 a point (cos θ_0 = 1).
        let c = &walked.chain;
        let (d01, d12) = (
            (c[1].p() - c[0].p()).length(),
            (c[2].p() - c[1].p()).length(),
        );
        let cos2 = c[2].point.n.dot((c[1].p() - c[2].p()).normalize()).abs();
        let expected = cos2 / (d01 + d12).powi(2);
        let g = generalized_geometry(c, 1.0);
        // The walk stops within ε L = 1e-7 L of the target: agreement to that order.
        assert!((g / expected - 1.0).abs() < 1e-6, "{g} vs {expected}");
    }
}

#[test]
fn the_walk_finds_a_flat_interfaces_refraction_point() {
    let scene = flat_scene(true);
    let x0 = DVec3::new(0.0, 1.0, 0.0);
    let chain = traced_chain(
        &scene,
        x0,
        DVec3::new(0.5, -1.0, 0.2).normalize(),
        Interaction::Refract { eta: 1.33 },
    );
    assert!(
        (chain[2].p().y + 1.0).abs() < 1e-9,
        "the chain ends on the floor"
    );
    let settings = ManifoldSettings::default();
    for (dx, dz) in [(0.4, 0.1), (-0.3, -0.2), (1.0, 0.6)] {
        let target_p = chain[2].p() + DVec3::new(dx, 0.0, dz);
        let target = surface_vertex(&scene, target_p + DVec3::Y * 0.5, target_p);
        let walked = walk_manifold(&scene, &chain, &target, &settings).expect("converges");
        // Closed form: the refraction point lies on the segment between the projections of x0
        // and the target; Snell's law sin θ₁ = 1.33 sin θ₂ fixes the fraction (bisection).
        let (a, b) = (
            DVec3::new(x0.x, 0.0, x0.z),
            DVec3::new(target.p().x, 0.0, target.p().z),
        );
        let total = (b - a).length();
        let (h1, h2) = (x0.y, -target.p().y);
        let snell = |s: f64| {
            let sin1 = s / (s * s + h1 * h1).sqrt();
            let r = total - s;
            let sin2 = r / (r * r + h2 * h2).sqrt();
            sin1 - 1.33 * sin2
        };
        let (mut lo, mut hi) = (0.0, total);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if snell(mid) < 0.0 { lo = mid } else { hi = mid }
        }
        let exact = a + (b - a) * (0.5 * (lo + hi) / total);
        let err = (walked.chain[1].p() - exact).length();
        println!(
            "refraction: {} iterations, refraction point error {err:.1e}",
            walked.iterations
        );
        assert!(err < 1e-6, "{err}");
    }
}

/// A curved mirror (a sphere): walks toward a target converge quadratically — once the distance is
/// small, each iteration roughly squares it (relative to the scene size). Prints the iteration
/// table.
#[test]
fn the_walk_converges_quadratically_on_a_curved_mirror() {
    let mut b = SceneBuilder::new(16, 16, DVec3::new(0.0, 2.0, 6.0), DVec3::ZERO, 40.0);
    let matte = b.matte(0.5, 0.5, 0.5);
    let mirror = b.material(MaterialDesc::Mirror { kr: Rgb::WHITE });
    let black = b.matte(0.0, 0.0, 0.0);
    b.sphere(DVec3::new(0.0, 1.0, 0.0), 1.0, mirror);
    b.quad(
        DVec3::new(-5.0, 0.0, -5.0),
        DVec3::Z * 10.0,
        DVec3::X * 10.0,
        matte,
        None,
    );
    b.quad(
        DVec3::new(-0.5, 4.0, -0.5),
        DVec3::X,
        DVec3::Z,
        black,
        Some(Rgb::splat(1.0)),
    );
    let scene = Scene::new(&b.finish(), None).unwrap();
    let x0 = DVec3::new(2.5, 1.6, 0.4);
    // From x0 toward the sphere's lower side, reflected down to the floor.
    let chain = traced_chain(
        &scene,
        x0,
        (DVec3::new(0.6, 0.45, 0.2) - x0).normalize(),
        Interaction::Reflect,
    );
    assert!(
        chain[2].p().y.abs() < 1e-9,
        "ends on the floor: {:?}",
        chain[2].p()
    );
    let target_p = chain[2].p() + DVec3::new(0.05, 0.0, -0.08);
    let target = surface_vertex(&scene, target_p + DVec3::Y, target_p);
    let walked =
        walk_manifold(&scene, &chain, &target, &ManifoldSettings::default()).expect("converges");
    let scale = (scene.bounds.1 - scene.bounds.0).length();
    println!("iteration  distance/L");
    for (k, d) in walked.distances.iter().enumerate() {
        println!("{k:9}  {:.3e}", d / scale);
    }
    let rel: Vec<f64> = walked.distances.iter().map(|d| d / scale).collect();
    let mut quadratic = 0;
    for w in rel.windows(2) {
        if w[0] < 1e-3 && w[1] > 1e-15 {
            // log d_{k+1} / log d_k ≥ 1.7: the exponent of the convergence.
            assert!(
                w[1].ln() / w[0].ln() > 1.7,
                "not quadratic: {:.3e} -> {:.3e}",
                w[0],
                w[1]
            );
            quadratic += 1;
        }
    }
    assert!(walked.iterations <= 8, "{} iterations", walked.iterations);
    println!(
        "{} iterations, {quadratic} steps in the quadratic regime",
        walked.iterations
    );
}

/// The generalised geometry term is the same from both ends of a chain traced from the floor
/// through a glass sphere (two refractions) to the ceiling.
#[test]
fn the_generalized_geometry_term_is_symmetric() {
    let mut b = SceneBuilder::new(16, 16, DVec3::new(0.0, 2.0, 6.0), DVec3::ZERO, 40.0);
    let matte = b.matte(0.5, 0.5, 0.5);
    let glass = b.material(MaterialDesc::Glass {
        eta: 1.5,
        alpha_u: 0.0,
        alpha_v: 0.0,
        kr: Rgb::WHITE,
        kt: Rgb::WHITE,
    });
    let black = b.matte(0.0, 0.0, 0.0);
    b.sphere(DVec3::new(0.0, 1.0, 0.0), 0.8, glass);
    b.quad(
        DVec3::new(-5.0, 0.0, -5.0),
        DVec3::Z * 10.0,
        DVec3::X * 10.0,
        matte,
        None,
    );
    // A ceiling (normal −y) to receive the chain.
    b.quad(
        DVec3::new(-5.0, 3.0, -5.0),
        DVec3::X * 10.0,
        DVec3::Z * 10.0,
        matte,
        None,
    );
    b.quad(
        DVec3::new(-0.5, 4.0, -0.5),
        DVec3::X,
        DVec3::Z,
        black,
        Some(Rgb::splat(1.0)),
    );
    let scene = Scene::new(&b.finish(), None).unwrap();
    // A start on the floor, through the glass sphere (in and out), to the floor again.
    let start_p = DVec3::new(-2.0, 0.0, 0.3);
    let start = surface_vertex(&scene, start_p + DVec3::Y, start_p);
    let dir = (DVec3::new(0.1, 1.0, 0.05) - start_p).normalize();
    let chain = trace_chain(&scene, &start, dir, &[Interaction::Refract { eta: 1.5 }; 2])
        .expect("through the sphere to the ceiling");
    let n = chain.len();
    assert!(
        (chain[n - 1].p().y - 3.0).abs() < 1e-9,
        "ends on the ceiling"
    );
    let cos_first = chain[0]
        .point
        .n
        .dot((chain[1].p() - chain[0].p()).normalize())
        .abs();
    let cos_last = chain[n - 1]
        .point
        .n
        .dot((chain[n - 2].p() - chain[n - 1].p()).normalize())
        .abs();
    let g = generalized_geometry(&chain, cos_first);
    let g_rev = generalized_geometry_reverse(&chain, cos_last);
    println!("G forward {g:.6e}, reverse {g_rev:.6e}");
    assert!(g > 0.0 && (g / g_rev - 1.0).abs() < 1e-9, "{g} vs {g_rev}");
}
