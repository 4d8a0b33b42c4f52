//! Renderer throughput (criterion): rays/s of closest-hit and occlusion queries on the built-in
//! scenes, on `veach-bidir` (when `../shared/scenes` is there) and on a generated terrain of
//! 1 057 058 triangles — ours, and obvhs's own traversal with its own f32 triangles on the same rays
//! (`obvhs_closest_hit`, `obvhs_occlusion`; scenes without spheres) — samples/s of path tracing
//! and BDPT, and the scaling of a render pass from 1 to 2 threads.
//!
//! `cargo bench --bench render` (add `-- bvh` etc. to filter).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use light_transport::accel::{Bvh, Primitive};
use light_transport::geometry::{NO_SHADING, Triangle};
use light_transport::integrators::{Bdpt, Budget, PathTracer, render};
use light_transport::math::DVec3;
use light_transport::path::{MisHeuristic, WalkSettings};
use light_transport::scene::{Scene, builtin};
use mcmc_core::rng::{stream, uniform};
use std::hint::black_box;

/// Ray origins and directions.
type Rays = Vec<(DVec3, DVec3)>;

#[path = "../examples/terrain/height.rs"]
mod height;

/// The terrain's height field: `2 n²` triangles over `[0, 1]²`.
fn terrain(n: usize) -> Vec<Primitive> {
    let p = |(i, j)| DVec3::from(height::vertex(n, i, j));
    let mut out = Vec::with_capacity(2 * n * n);
    for i in 0..n {
        for j in 0..n {
            for t in height::cell_triangles(i, j) {
                out.push(Primitive::Triangle(Triangle {
                    p: t.map(p),
                    uv: [[0.0; 2]; 3],
                    flip: false,
                    shading: NO_SHADING,
                }));
            }
        }
    }
    out
}

/// Camera rays of a scene's camera (random film positions).
fn camera_rays(scene: &Scene, n: usize) -> Vec<(DVec3, DVec3)> {
    let mut rng = stream(1, 0);
    (0..n)
        .map(|_| {
            let s = scene
                .camera
                .sample_ray([uniform(&mut rng), uniform(&mut rng)], [0.5, 0.5]);
            (s.ray.o, s.ray.d)
        })
        .collect()
}

fn vec3(v: DVec3) -> glam::Vec3A {
    glam::Vec3A::new(v.x as f32, v.y as f32, v.z as f32)
}

/// obvhs's own CWBVH (same build preset as ours, no split references) over f32 copies of the
/// triangles; `None` when there are spheres (obvhs alone would see different geometry).
fn obvhs_alone(
    primitives: &[Primitive],
) -> Option<(obvhs::cwbvh::CwBvh, Vec<obvhs::triangle::Triangle>)> {
    let tris = primitives
        .iter()
        .map(|p| match p {
            Primitive::Triangle(t) => Some(obvhs::triangle::Triangle {
                v0: vec3(t.p[0]),
                v1: vec3(t.p[1]),
                v2: vec3(t.p[2]),
            }),
            Primitive::Sphere(_) => None,
        })
        .collect::<Option<Vec<_>>>()?;
    let cw = obvhs::cwbvh::builder::build_cwbvh_from_tris(
        &tris,
        obvhs::BvhBuildParams::medium_build(),
        &mut std::time::Duration::default(),
    );
    Some((cw, tris))
}

fn bvh_benches(c: &mut Criterion) {
    let mut g = c.benchmark_group("bvh");
    const N: usize = 4096;
    let mut cases: Vec<(String, Bvh, Rays)> = Vec::new();
    for name in builtin::BUILTIN {
        let s = Scene::new(&builtin::builtin(name).unwrap(), None).unwrap();
        let rays = camera_rays(&s, N);
        cases.push((name.to_string(), Bvh::new(s.bvh.primitives.clone()), rays));
    }
    let veach = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/scenes/veach-bidir/scene.pbrt");
    if let Ok(desc) = light_transport::scene::pbrt::load(&veach) {
        let s = Scene::new(&desc, None).unwrap();
        let rays = camera_rays(&s, N);
        cases.push((
            "veach-bidir".into(),
            Bvh::new(s.bvh.primitives.clone()),
            rays,
        ));
    }
    let t = std::time::Instant::now();
    let tris = terrain(727);
    let count = tris.len();
    let big = Bvh::new(tris);
    eprintln!(
        "terrain: {count} triangles, BVH built in {:.2} s",
        t.elapsed().as_secs_f64()
    );
    let mut rng = stream(2, 0);
    let rays: Vec<(DVec3, DVec3)> = (0..N)
        .map(|_| {
            let o = DVec3::new(uniform(&mut rng), 0.5, uniform(&mut rng));
            let d = DVec3::new(uniform(&mut rng) - 0.5, -1.0, uniform(&mut rng) - 0.5).normalize();
            (o, d)
        })
        .collect();
    cases.push((format!("terrain_{count}"), big, rays));
    g.throughput(Throughput::Elements(N as u64));
    for (name, bvh, rays) in &cases {
        g.bench_with_input(BenchmarkId::new("closest_hit", name), rays, |b, rays| {
            b.iter(|| {
                rays.iter()
                    .filter(|(o, d)| bvh.closest_hit(*o, *d, f64::INFINITY).is_some())
                    .count()
            })
        });
        g.bench_with_input(BenchmarkId::new("occlusion", name), rays, |b, rays| {
            b.iter(|| {
                rays.iter()
                    .filter(|(o, d)| bvh.occluded(*o, *d, 5.0))
                    .count()
            })
        });
        if let Some((cw, tris)) = obvhs_alone(&bvh.primitives) {
            let f32_rays: Vec<obvhs::ray::Ray> = rays
                .iter()
                .map(|(o, d)| obvhs::ray::Ray::new(vec3(*o), vec3(*d), 0.0, f32::INFINITY))
                .collect();
            g.bench_with_input(
                BenchmarkId::new("obvhs_closest_hit", name),
                &f32_rays,
                |b, rays| {
                    b.iter(|| {
                        rays.iter()
                            .filter(|r| {
                                let mut hit = obvhs::ray::RayHit::none();
                                cw.ray_traverse(**r, &mut hit, |ray, id| {
                                    tris[cw.primitive_indices[id] as usize].intersect(ray)
                                })
                            })
                            .count()
                    })
                },
            );
            g.bench_with_input(
                BenchmarkId::new("obvhs_occlusion", name),
                &f32_rays,
                |b, rays| {
                    b.iter(|| {
                        rays.iter()
                            .filter(|r| {
                                let r = obvhs::ray::Ray::new(r.origin, r.direction, 0.0, 5.0);
                                !cw.ray_traverse_miss(r, |ray, id| {
                                    tris[cw.primitive_indices[id] as usize].intersect(ray)
                                })
                            })
                            .count()
                    })
                },
            );
        }
    }
    g.finish();
}

fn integrator_benches(c: &mut Criterion) {
    let mut g = c.benchmark_group("integrator");
    g.sample_size(10);
    let walk = WalkSettings { max_edges: 9 };
    let pt = PathTracer {
        max_edges: 9,
        heuristic: MisHeuristic::Power,
        roulette_from: None,
        shadow_roulette: None,
    };
    let bdpt = Bdpt {
        walk,
        heuristic: MisHeuristic::Power,
        roulette: None,
        shadow_roulette: None,
    };
    for name in builtin::BUILTIN {
        let s = Scene::new(&builtin::builtin(name).unwrap(), Some((64, 64))).unwrap();
        g.throughput(Throughput::Elements(64 * 64));
        g.bench_function(BenchmarkId::new("pt_pass", name), |b| {
            b.iter(|| {
                black_box(render(&s, &pt, Budget::SamplesPerPixel(1.0), 1, |_, _| {
                    true
                }))
            })
        });
        g.bench_function(BenchmarkId::new("bdpt_pass", name), |b| {
            b.iter(|| {
                black_box(render(
                    &s,
                    &bdpt,
                    Budget::SamplesPerPixel(1.0),
                    1,
                    |_, _| true,
                ))
            })
        });
    }
    g.finish();
}

fn scaling_benches(c: &mut Criterion) {
    let mut g = c.benchmark_group("threads");
    g.sample_size(10);
    let s = Scene::new(&builtin::builtin("cornell").unwrap(), Some((128, 128))).unwrap();
    let bdpt = Bdpt {
        walk: WalkSettings { max_edges: 9 },
        heuristic: MisHeuristic::Power,
        roulette: None,
        shadow_roulette: None,
    };
    g.throughput(Throughput::Elements(128 * 128));
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        g.bench_function(BenchmarkId::new("bdpt_pass_cornell", threads), |b| {
            b.iter(|| {
                pool.install(|| {
                    black_box(render(
                        &s,
                        &bdpt,
                        Budget::SamplesPerPixel(1.0),
                        1,
                        |_, _| true,
                    ))
                })
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bvh_benches, integrator_benches, scaling_benches);
criterion_main!(benches);
