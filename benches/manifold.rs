//! Manifold walks per second (criterion) on the built-in `pool`: chains from its light through the
//! water surface (refractions and reflections at smooth-shaded triangles) to the first diffuse
//! surface, each walked to a target displaced by a Gaussian of 0.2% of the scene's diagonal
//! (about 3 cm) — the size of move a manifold perturbation asks for ([`probe_cases`]). Before
//! measuring, prints the walks' statistics.
//!
//! `cargo bench --bench manifold`

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use light_transport::manifold::ManifoldSettings;
use light_transport::manifold::probe::{probe, probe_cases};
use light_transport::manifold::walk_manifold;
use light_transport::scene::{Scene, builtin};
use std::hint::black_box;

fn manifold_benches(c: &mut Criterion) {
    let scene = Scene::new(&builtin::builtin("pool").unwrap(), None).unwrap();
    let cases = probe_cases(&scene, 2000, 4, 0.002, 5);
    let settings = ManifoldSettings::default();
    println!("pool: {}", probe(&scene, &cases, &settings).summary());
    let mut g = c.benchmark_group("manifold");
    g.throughput(Throughput::Elements(cases.len() as u64));
    g.bench_function("pool walks", |b| {
        b.iter(|| {
            for case in &cases {
                let _ = black_box(walk_manifold(&scene, &case.chain, &case.target, &settings));
            }
        })
    });
    g.finish();
}

criterion_group!(benches, manifold_benches);
criterion_main!(benches);
