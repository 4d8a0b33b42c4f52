//! Manifold walks per second (criterion) on the built-in `pool`: chains from the light through the
//! water surface (one refraction at a smooth-shaded triangle) to the floor or a wall, each walked
//! to a target 2 cm away on the same surface — the size of move a manifold perturbation asks for.
//! Before measuring, prints the walks' statistics: success rate, mean iterations, failures by cause.
//!
//! `cargo bench --bench manifold`

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use light_transport::geometry::{Ray, SurfacePoint};
use light_transport::manifold::{
    ChainVertex, Interaction, ManifoldSettings, NO_MATERIAL, WalkFailure, WalkStats, trace_chain,
    walk_manifold,
};
use light_transport::math::DVec3;
use light_transport::scene::{Scene, builtin};
use mcmc_core::rng::{stream, uniform};
use std::hint::black_box;

/// `(chain, target)` pairs: chains traced from just below the pool's light through the water,
/// targets on the end's surface displaced tangentially by a Gaussian of σ = 2 cm.
fn cases(scene: &Scene, n: usize) -> Vec<(Vec<ChainVertex>, ChainVertex)> {
    let mut rng = stream(5, 0);
    let light = DVec3::new(-0.775, 3.6 - 1e-6, -0.775);
    let start = ChainVertex {
        point: SurfacePoint::flat(light, -DVec3::Y, u32::MAX),
        material: NO_MATERIAL,
        interaction: Interaction::Reflect,
        offset: [0.0; 2],
    };
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        // A direction in the downward cone that reaches the water.
        let (a, b) = (uniform(&mut rng), uniform(&mut rng));
        let c = 1.0 - 0.4 * a;
        let s = (1.0 - c * c).sqrt();
        let dir = DVec3::new(
            s * (std::f64::consts::TAU * b).cos(),
            -c,
            s * (std::f64::consts::TAU * b).sin(),
        );
        let Ok(chain) = trace_chain(scene, &start, dir, &[Interaction::Refract { eta: 1.33 }])
        else {
            continue;
        };
        let end = chain[2];
        let (e1, e2) = end.tangent_basis();
        let g = |rng: &mut _| {
            // Box–Muller.
            let (u1, u2): (f64, f64) = (uniform(rng), uniform(rng));
            (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        };
        let p = end.p() + (e1 * g(&mut rng) + e2 * g(&mut rng)) * 0.02;
        let n = end.point.n;
        let Some(hit) = scene.intersect(&Ray::new(p + n * 1e-3, -n)) else {
            continue;
        };
        let material = scene.primitive_material[hit.point.primitive as usize];
        if material != end.material || (hit.point.p - p).length() > 1e-6 {
            continue;
        }
        let target = ChainVertex {
            point: hit.point,
            material,
            ..end
        };
        out.push((chain, target));
    }
    out
}

fn manifold_benches(c: &mut Criterion) {
    let scene = Scene::new(&builtin::builtin("pool").unwrap(), None).unwrap();
    let cases = cases(&scene, 2000);
    let settings = ManifoldSettings::default();
    let mut stats = WalkStats::default();
    for (chain, target) in &cases {
        stats.record(1, &walk_manifold(&scene, chain, target, &settings));
    }
    println!(
        "pool, {} walks: {:.1}% converged, {:.2} iterations on average; failures: {}",
        stats.walks,
        100.0 * stats.success_rate(),
        stats.mean_iterations(),
        WalkFailure::ALL
            .iter()
            .zip(stats.failures)
            .map(|(f, n)| format!("{} {n}", f.name()))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut g = c.benchmark_group("manifold");
    g.throughput(Throughput::Elements(cases.len() as u64));
    g.bench_function("pool walks", |b| {
        b.iter(|| {
            for (chain, target) in &cases {
                let _ = black_box(walk_manifold(&scene, chain, target, &settings));
            }
        })
    });
    g.finish();
}

criterion_group!(benches, manifold_benches);
criterion_main!(benches);
