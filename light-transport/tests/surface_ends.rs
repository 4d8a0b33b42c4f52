//! Rays and segments that leave surfaces skip the triangles they leave (`Ray::leaving`,
//! `SurfaceEnd`): the skip must never change an answer. On every built-in scene, points found by
//! random rays are left in random directions (closest hits compared with the same offset ray that
//! skips nothing) and joined in pairs: random pairs, and pairs on one triangle or one plane, where
//! a segment between the offset ends can cross the ends' own triangles (visibility compared with
//! the same ends that skip nothing).

use light_transport::geometry::{NO_PRIMITIVE, Ray, SurfaceEnd, SurfacePoint, offset_origin};
use light_transport::math::DVec3;
use light_transport::scene::Scene;
use light_transport::scene::builtin;
use mcmc_core::rng::{stream, uniform};

fn unit(r: &mut impl FnMut() -> f64) -> DVec3 {
    let z = 2.0 * r() - 1.0;
    let phi = std::f64::consts::TAU * r();
    let s = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(s * phi.cos(), s * phi.sin(), z)
}

/// Surface points hit by rays from random points in the scene's box, in random directions, and
/// next to each a second point hit by a ray turned by at most `1e-2`, mostly on the same triangle
/// or plane.
fn surface_points(scene: &Scene, seed: u64, n: usize) -> Vec<(SurfacePoint, SurfacePoint)> {
    let mut rng = stream(seed, 0);
    let mut r = || uniform(&mut rng);
    let (lo, hi) = scene.bounds;
    let mut out = Vec::new();
    while out.len() < n {
        let o = lo + (hi - lo) * DVec3::new(r(), r(), r());
        let d = unit(&mut r);
        let Some(a) = scene.intersect(&Ray::new(o, d)) else {
            continue;
        };
        let near = (d + unit(&mut r) * 1e-2 * r()).normalize();
        let Some(b) = scene.intersect(&Ray::new(o, near)) else {
            continue;
        };
        out.push((a.point, b.point));
    }
    out
}

/// The same end that skips nothing.
fn skipping_nothing(p: &SurfacePoint) -> SurfaceEnd {
    SurfaceEnd {
        n: p.n,
        primitive: NO_PRIMITIVE,
    }
}

/// Closest hits of rays leaving surface points: the ray that skips the triangle it leaves finds
/// what the same ray finds that skips nothing, at the same distance.
#[test]
fn rays_leaving_a_surface_find_what_they_found() {
    for (k, name) in builtin::BUILTIN.iter().enumerate() {
        let scene = Scene::new(&builtin::builtin(name).unwrap(), Some((64, 64))).unwrap();
        let mut rng = stream(77, k as u64);
        let mut r = || uniform(&mut rng);
        for (p, _) in surface_points(&scene, 5 + k as u64, 2000) {
            for _ in 0..8 {
                let w = unit(&mut r);
                let skipping = scene.intersect(&Ray::leaving(&p, w));
                let plain = scene.intersect(&Ray::new(offset_origin(p.p, p.n, w), w));
                assert_eq!(
                    skipping.map(|h| (h.t, h.point.primitive)),
                    plain.map(|h| (h.t, h.point.primitive)),
                    "{name}: leaving {p:?} toward {w}"
                );
            }
        }
    }
}

/// Visibility between surface points: skipping the ends' triangles changes no answer, for
/// random pairs and for pairs on one triangle or plane (where the offset segment can cross
/// them: `Scene::visible` tests such an end's triangle). Counts how many pairs share a
/// primitive, so that the second kind is known to be exercised.
#[test]
fn segments_between_surfaces_see_what_they_saw() {
    let (mut same, mut pairs) = (0, 0);
    for (k, name) in builtin::BUILTIN.iter().enumerate() {
        let scene = Scene::new(&builtin::builtin(name).unwrap(), Some((64, 64))).unwrap();
        let points = surface_points(&scene, 50 + k as u64, 3000);
        for (i, (a, near)) in points.iter().enumerate() {
            let far = &points[(i * 7 + 3) % points.len()].0;
            for b in [near, far] {
                pairs += 1;
                same += usize::from(a.primitive == b.primitive);
                let skipping =
                    scene.visible(a.p, Some(SurfaceEnd::of(a)), b.p, Some(SurfaceEnd::of(b)));
                let plain = scene.visible(
                    a.p,
                    Some(skipping_nothing(a)),
                    b.p,
                    Some(skipping_nothing(b)),
                );
                assert_eq!(skipping, plain, "{name}: {a:?} to {b:?}");
            }
        }
    }
    assert!(same > pairs / 4, "{same} of {pairs} pairs on one primitive");
}
