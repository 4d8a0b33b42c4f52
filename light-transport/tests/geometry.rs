//! The differential geometry of surface points: the derivatives of position and of the
//! normalised shading normal against finite differences on random triangles with random vertex
//! normals, and the analytic sphere against a finely tessellated mesh sphere with vertex normals.

use light_transport::Rgb;
use light_transport::geometry::Ray;
use light_transport::geometry::{NO_SHADING, Sphere, SurfacePoint, Triangle, TriangleShading};
use light_transport::math::DVec3;
use light_transport::scene::builtin::SceneBuilder;
use light_transport::scene::{MaterialDesc, RgbTexture, Scene, SceneDescription};
use mcmc_core::rng::{stream, uniform};

fn rel(a: DVec3, b: DVec3) -> f64 {
    (a - b).length() / a.length().max(b.length()).max(1e-12)
}

/// The barycentrics of texture coordinates `uv` on triangle `t`.
fn barycentrics_of_uv(t: &Triangle, uv: [f64; 2]) -> (f64, f64) {
    let c = t.uv.map(|[u, v]| [f64::from(u), f64::from(v)]);
    let (du1, dv1) = (c[1][0] - c[0][0], c[1][1] - c[0][1]);
    let (du2, dv2) = (c[2][0] - c[0][0], c[2][1] - c[0][1]);
    let (a, b) = (uv[0] - c[0][0], uv[1] - c[0][1]);
    let det = du1 * dv2 - dv1 * du2;
    ((a * dv2 - b * du2) / det, (b * du1 - a * dv1) / det)
}

/// `∂p/∂u`, `∂p/∂v`, `∂n_s/∂u`, `∂n_s/∂v` on random triangles with random vertex normals and
/// texture coordinates, against central differences in `(u, v)` with steps that move the point
/// by 1e-5 of the triangle's size: worst relative error over 2000 points.
#[test]
fn triangle_derivatives_match_finite_differences() {
    let mut rng = stream(31, 0);
    let mut r = || uniform(&mut rng);
    let mut worst = [0.0f64; 4];
    for _ in 0..2000 {
        let p = [0, 1, 2].map(|_| DVec3::new(r(), r(), r()) * 2.0 - 1.0);
        let uv = [0, 1, 2].map(|_| [r() as f32 * 3.0, r() as f32 * 3.0]);
        let t = Triangle {
            p,
            uv,
            flip: false,
            shading: NO_SHADING,
        };
        let ng = t.normal();
        // Vertex normals within 60° of the geometric normal.
        let normals =
            [0, 1, 2].map(|_| (ng + (DVec3::new(r(), r(), r()) * 2.0 - 1.0) * 0.8).normalize());
        let sh = TriangleShading {
            n: normals,
            s: None,
        };
        let (b1, b2) = (r() * 0.8 + 0.05, r() * 0.1 + 0.05);
        let at = |b1: f64, b2: f64| t.point_shaded(b1, b2, 0, Some(&sh));
        let x = at(b1, b2);
        let dx = t.derivatives(b1, b2, Some(&sh));
        // The point's texture coordinates (computed from its barycentrics on demand).
        let uv0 = t.texture_coordinates(x.local[0], x.local[1]);
        assert_eq!(x.local, [b1, b2]);
        let size = (p[1] - p[0]).length().max((p[2] - p[0]).length());
        let (hu, hv) = (
            1e-5 * size / dx.dpdu.length(),
            1e-5 * size / dx.dpdv.length(),
        );
        let d = |du: f64, dv: f64| -> SurfacePoint {
            let (c1, c2) = barycentrics_of_uv(&t, [uv0[0] + du, uv0[1] + dv]);
            at(c1, c2)
        };
        let (up, um, vp, vm) = (d(hu, 0.0), d(-hu, 0.0), d(0.0, hv), d(0.0, -hv));
        let fd = [
            (up.p - um.p) / (2.0 * hu),
            (vp.p - vm.p) / (2.0 * hv),
            (up.ns - um.ns) / (2.0 * hu),
            (vp.ns - vm.ns) / (2.0 * hv),
        ];
        let an = [dx.dpdu, dx.dpdv, dx.dndu, dx.dndv];
        for k in 0..4 {
            // Relative to the derivatives' scale (a vanishing derivative is compared absolutely).
            let e = (an[k] - fd[k]).length() / an[k].length().max(fd[k].length()).max(1e-3);
            worst[k] = worst[k].max(e);
        }
        assert!((x.ns.length() - 1.0).abs() < 1e-12 && x.ns.dot(x.n) > 0.0);
    }
    println!(
        "worst relative error: dp/du {:.1e}, dp/dv {:.1e}, dn/du {:.1e}, dn/dv {:.1e}",
        worst[0], worst[1], worst[2], worst[3]
    );
    assert!(worst.iter().all(|&e| e < 1e-6), "{worst:?}");
}

/// A triangle without vertex normals is flat: shading normal = geometric, zero normal derivatives.
#[test]
fn flat_triangles_have_no_curvature() {
    let t = Triangle {
        p: [DVec3::ZERO, DVec3::X, DVec3::Y],
        uv: [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]],
        flip: true,
        shading: NO_SHADING,
    };
    let x = t.point(0.2, 0.3, 0);
    assert_eq!(x.ns, x.n);
    assert_eq!(x.n, -DVec3::Z);
    let dx = t.derivatives(0.2, 0.3, None);
    assert_eq!((dx.dndu, dx.dndv), (DVec3::ZERO, DVec3::ZERO));
    // pbrt's default parameterisation, (0,0), (1,0), (1,1) at the vertices: p = p0 + (u − v) e1 +
    // v e2.
    assert!(rel(dx.dpdu, DVec3::X) < 1e-15 && rel(dx.dpdv, DVec3::Y - DVec3::X) < 1e-15);
}

/// A sphere's analytic geometry against a 512 × 256 mesh sphere with the sphere's normals and
/// texture coordinates at its vertices, at the same points (rays toward the centre from random
/// directions away from the poles): the shading normals agree to rounding (the interpolated
/// normal `Σ b_i (p_i − c)/r` of a mesh sphere is exactly radial), the derivatives of position and
/// normal to first order in the tessellation's angular step (0.012 rad; measured worst 2.0e-2).
#[test]
fn the_analytic_sphere_matches_a_fine_mesh_sphere() {
    let (c, radius) = (DVec3::new(0.3, -0.2, 0.5), 0.8);
    let sphere = Sphere {
        center: c,
        radius,
        flip: false,
    };
    let mut b = SceneBuilder::new(8, 8, DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, 40.0);
    let m = b.material(MaterialDesc::Matte {
        kd: RgbTexture::Constant(Rgb::splat(0.5)),
    });
    b.mesh_sphere(c, radius, 512, 256, m);
    let mut desc: SceneDescription = b.finish();
    desc.lights.push(light_transport::scene::LightDesc::Point {
        position: DVec3::new(0.0, 5.0, 0.0),
        intensity: Rgb::splat(1.0),
    });
    let scene = Scene::new(&desc, None).unwrap();
    let mut rng = stream(32, 0);
    let mut worst = [0.0f64; 5];
    let mut n = 0;
    while n < 2000 {
        let w = DVec3::new(uniform(&mut rng), uniform(&mut rng), uniform(&mut rng)) * 2.0 - 1.0;
        let Some(w) = w.try_normalize() else { continue };
        if w.z.abs() > 0.9 {
            continue;
        }
        let hit = scene
            .intersect(&Ray::new(c + w * 3.0, -w))
            .expect("the ray hits the mesh sphere");
        let mesh = hit.point;
        let exact = sphere.point(mesh.p, 0);
        // The mesh's derivatives as manifold walks get them: computed on demand from the hit.
        let (dm, de) = (
            scene.bvh.derivatives(&mesh),
            sphere.derivatives(exact.n, sphere.local(exact.n)[0]),
        );
        let e = [
            rel(mesh.ns, exact.ns),
            rel(dm.dpdu, de.dpdu),
            rel(dm.dpdv, de.dpdv),
            rel(dm.dndu, de.dndu),
            rel(dm.dndv, de.dndv),
        ];
        for k in 0..5 {
            worst[k] = worst[k].max(e[k]);
        }
        assert!(
            mesh.n.dot(exact.n) > 0.99,
            "the mesh's geometric normal points out"
        );
        n += 1;
    }
    println!(
        "worst relative difference, mesh vs analytic: n_s {:.1e}, dp/du {:.1e}, dp/dv {:.1e}, dn/du {:.1e}, dn/dv {:.1e}",
        worst[0], worst[1], worst[2], worst[3], worst[4]
    );
    assert!(worst[0] < 1e-4, "{worst:?}");
    assert!(worst[1..].iter().all(|&e| e < 0.03), "{worst:?}");
}
