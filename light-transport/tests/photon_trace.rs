//! Photon tracing stores photons whose power is unbiased: on a floor lit by a square Lambertian
//! emitter facing down (nothing else in the scene), the summed power of the photons in a floor
//! patch equals the flux the emitter sends onto it, `Φ = L_e ∫∫ cos θ cos θ' / d² dA dA'`,
//! integrated here by the midpoint rule (48 points per axis on both squares; its error is far
//! below the test's resolution). z-test over 400 000 photon paths (at most one floor photon each;
//! their emission is stratified, which only lowers the variance, so the i.i.d. standard error is
//! conservative), |z| < 4.5 (false-positive rate ≤ 6.8e-6); the same estimate against
//! `1.05 Φ` must fail. The caustic map is empty here (no specular surface).

use light_transport::math::DVec3;
use light_transport::photon::trace_photons;
use light_transport::scene::Scene;
use light_transport::scene::builtin::SceneBuilder;
use light_transport::spectrum::Rgb;

const HEIGHT: f64 = 1.0;
const SIDE: f64 = 0.5;
const LE: f64 = 4.0;
const PATHS: u64 = 400_000;
/// The patch: x ∈ [0.1, 0.6], z ∈ [−0.3, 0.2].
const PATCH: [f64; 4] = [0.1, 0.6, -0.3, 0.2];

fn scene() -> Scene {
    let mut b = SceneBuilder::new(32, 32, DVec3::new(0.0, 2.0, 3.0), DVec3::ZERO, 50.0);
    let floor = b.matte(0.5, 0.5, 0.5);
    let black = b.matte(0.0, 0.0, 0.0);
    b.quad(
        DVec3::new(-5.0, 0.0, -5.0),
        DVec3::Z * 10.0,
        DVec3::X * 10.0,
        floor,
        None,
    );
    // The emitter, centred over the origin, facing down.
    b.quad(
        DVec3::new(-SIDE / 2.0, HEIGHT, -SIDE / 2.0),
        DVec3::X * SIDE,
        DVec3::Z * SIDE,
        black,
        Some(Rgb::splat(LE)),
    );
    Scene::new(&b.finish(), None).expect("scene")
}

/// The flux onto the patch, by the midpoint rule on both squares.
fn flux() -> f64 {
    let n = 48;
    let mut sum = 0.0;
    let (da, db) = (
        (SIDE / n as f64).powi(2),
        (PATCH[1] - PATCH[0]) * (PATCH[3] - PATCH[2]) / (n * n) as f64,
    );
    for i in 0..n {
        for j in 0..n {
            let l = DVec3::new(
                -SIDE / 2.0 + SIDE * (i as f64 + 0.5) / n as f64,
                HEIGHT,
                -SIDE / 2.0 + SIDE * (j as f64 + 0.5) / n as f64,
            );
            for u in 0..n {
                for v in 0..n {
                    let f = DVec3::new(
                        PATCH[0] + (PATCH[1] - PATCH[0]) * (u as f64 + 0.5) / n as f64,
                        0.0,
                        PATCH[2] + (PATCH[3] - PATCH[2]) * (v as f64 + 0.5) / n as f64,
                    );
                    let d2 = (l - f).length_squared();
                    sum += HEIGHT * HEIGHT / (d2 * d2);
                }
            }
        }
    }
    LE * sum * da * db
}

#[test]
fn the_photons_in_a_patch_carry_the_flux_that_reaches_it() {
    let scene = scene();
    let (global, caustic) = trace_photons(&scene, PATHS, 6, 17);
    let inside: Vec<f64> = global
        .iter()
        .filter(|p| {
            p.p.y.abs() < 1e-9
                && p.p.x >= PATCH[0]
                && p.p.x <= PATCH[1]
                && p.p.z >= PATCH[2]
                && p.p.z <= PATCH[3]
        })
        .map(|p| p.power.0[1])
        .collect();
    let n = PATHS as f64;
    let mean: f64 = inside.iter().sum();
    let second: f64 = inside.iter().map(|x| (x * n).powi(2)).sum::<f64>() / n;
    let se = ((second - (mean * mean)) / n).sqrt();
    let exact = flux();
    let z = (mean - exact) / se;
    let z_broken = (mean - 1.05 * exact) / se;
    println!(
        "{} photons in the patch of {} global ({} caustic): flux {mean:.5e} ± {se:.1e}, exact {exact:.5e} (z = {z:+.2}); against 1.05 Φ z = {z_broken:+.2}",
        inside.len(),
        global.len(),
        caustic.len()
    );
    assert!(caustic.is_empty());
    assert!(inside.len() > 10_000);
    assert!(z.abs() < 4.5, "photon power biased: z = {z}");
    assert!(z_broken.abs() >= 4.5, "a 5% error goes unseen");
}
