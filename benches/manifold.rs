//! Manifold walks per second (criterion) on the built-in `pool`: chains from its light through the
//! water surface (refractions and reflections at smooth-shaded triangles) to the first diffuse
//! surface, each walked to a target displaced by a Gaussian of 0.2% of the scene's diagonal
//! (about 3 cm) — the size of move a manifold perturbation asks for ([`probe_cases`]). Before
//! measuring, prints the walks' statistics. Then whole manifold perturbations per second (each
//! direction: strategy, von Mises–Fisher direction, first chain traced, second chain walked there
//! and back, both densities) from 256 light-carrying paths of the pool that the perturbation can
//! move.
//!
//! `cargo bench --bench manifold`

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use light_transport::manifold::ManifoldSettings;
use light_transport::manifold::probe::{probe, probe_cases};
use light_transport::manifold::walk_manifold;
use light_transport::metropolis::ImportanceKind;
use light_transport::pathspace::{Mutations, NewPath, PathState};
use light_transport::sampler::IndependentStream;
use light_transport::scene::{Scene, builtin};
use mcmc_core::rng::stream;
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
    for name in ["manifold-light", "manifold-eye"] {
        let mutations = Mutations::new(8);
        let settings = mutations.settings(NewPath::uniform(8));
        let Some(m) = Mutations::mutation(&scene, &settings, name) else {
            continue;
        };
        let mut states = Vec::new();
        for i in 0..200_000u64 {
            if states.len() >= 256 {
                break;
            }
            let mut s = IndependentStream::new(stream(77, i));
            let mut state = PathState::default();
            let k = 2 + (i as usize % 5);
            if NewPath::sample(&scene, ImportanceKind::Luminance, k, &mut s, &mut state)
                && state.carries_light()
                && m.suitability(&state) > 0.0
            {
                states.push(state);
            }
        }
        g.throughput(Throughput::Elements(states.len() as u64));
        let mut y = PathState::default();
        g.bench_function(format!("pool {name} perturbations"), |b| {
            b.iter(|| {
                for (i, x) in states.iter().enumerate() {
                    let mut rng = stream(5, i as u64);
                    let _ = black_box(m.propose_ratio(x, &mut rng, &mut y));
                }
            })
        });
    }
    g.finish();
}

criterion_group!(benches, manifold_benches);
criterion_main!(benches);
