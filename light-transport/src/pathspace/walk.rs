//! Geometric walks for path-space mutations: tracing one edge, sampling the direction that leaves
//! a subpath's last vertex, new endpoints, and the random offsets of the perturbations (pixel
//! offsets and angular offsets exponentially distributed between two radii — practical-MLT paper,
//! appendices B and C — here with exact rotations, so that the offset density depends only on the
//! angle between the two directions and is symmetric).
//!
//! Walks here only place vertices (position, BSDF, delta flag); throughputs and densities are
//! recomputed by [`super::path::retrace`] when the path is evaluated.

use super::state::PathState;
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, SurfacePoint};
use crate::math::{DVec3, Frame, turn};
use crate::path::{
    Subpath, Vertex, VertexKind, connect, technique_subpaths, technique_subpaths_every_length,
};
use crate::sampler::SampleStream;
use crate::scene::Scene;
use crate::spectrum::Rgb;
use mcmc_core::ChainRng;
use mcmc_core::rng::uniform;
use std::f64::consts::TAU;

/// Trace the ray leaving vertex `from` in unit direction `w`; the first hit as a scattering vertex
/// (`wo = −w`, its BSDF, not delta).
pub fn trace(scene: &Scene, from: &Vertex, w: DVec3) -> Option<Vertex> {
    let found = scene.intersect(&leaving(scene, from, w));
    let hit = found.as_ref()?;
    // The BSDF is built inside the vertex (a BSDF returned by value was copied twice more).
    let mut v = Vertex::surface(&hit.point, -w, Rgb::BLACK);
    scene.bsdf_into(&hit.point, &mut v.bsdf);
    Some(v)
}

/// [`trace`] into the slot `out` (its BSDF rebuilt in the storage it has): a mutation that walks
/// in its candidate's own vertices saves copying each new vertex out of the walk and into place.
/// `false`, with `out` unchanged, when the ray escapes.
pub fn trace_into(scene: &Scene, from: &Vertex, w: DVec3, out: &mut Vertex) -> bool {
    let found = scene.intersect(&leaving(scene, from, w));
    let Some(hit) = found.as_ref() else {
        return false;
    };
    out.set_surface(&hit.point, -w, Rgb::BLACK);
    scene.bsdf_into(&hit.point, &mut out.bsdf);
    true
}

/// [`trace_into`] within one path: from its vertex `from` into its slot `to` (`from ≠ to`).
pub fn trace_between(scene: &Scene, path: &mut [Vertex], from: usize, to: usize, w: DVec3) -> bool {
    let (end, slot) = if from < to {
        let (head, tail) = path.split_at_mut(to);
        (&head[from], &mut tail[0])
    } else {
        let (head, tail) = path.split_at_mut(from);
        (&tail[0], &mut head[to])
    };
    trace_into(scene, end, w, slot)
}

/// The ray leaving vertex `from` in direction `w` (off its surface, if it has one).
fn leaving(scene: &Scene, from: &Vertex, w: DVec3) -> Ray {
    if from.on_surface(scene) {
        Ray::leaving(&from.point, w)
    } else {
        Ray::new(from.p(), w)
    }
}

/// Point `wo` of the last vertex of `sub` (a subpath in walk order) at its predecessor.
fn orient_last(sub: &mut [Vertex]) {
    let n = sub.len();
    if n >= 2 {
        sub[n - 1].wo = (sub[n - 2].p() - sub[n - 1].p()).normalize_or_zero();
    }
}

/// Sample the direction leaving the last vertex of `sub` as a random walk in `mode` would: the
/// emission distribution of a light endpoint, a uniform image position for a lens endpoint, the
/// BSDF otherwise (recording in the vertex whether a delta lobe was chosen).
pub fn sample_direction(
    scene: &Scene,
    sub: &mut [Vertex],
    mode: TransportMode,
    rng: &mut ChainRng,
) -> Option<DVec3> {
    orient_last(sub);
    sample_direction_at(scene, sub.last_mut()?, mode, rng)
}

/// [`sample_direction`] from `v`, whose `wo` is already set.
fn sample_direction_at(
    scene: &Scene,
    v: &mut Vertex,
    mode: TransportMode,
    rng: &mut ChainRng,
) -> Option<DVec3> {
    match v.kind {
        VertexKind::Light { light } => {
            let u = [uniform(rng), uniform(rng)];
            let (w, _) = scene.lights[light as usize].sample_direction(v.n(), u)?;
            Some(w)
        }
        VertexKind::Camera => {
            let raster = [
                uniform(rng) * scene.camera.width as f64,
                uniform(rng) * scene.camera.height as f64,
            ];
            Some(scene.camera.ray_through(v.p(), raster)?.ray.d)
        }
        VertexKind::Surface => {
            let b = v.bsdf.as_ref()?;
            let u_lobe = uniform(rng);
            let u = [uniform(rng), uniform(rng)];
            let s = b.sample(v.wo, u_lobe, u, mode)?;
            if !(s.pdf > 0.0) || s.f.is_black() {
                return None;
            }
            v.delta = s.delta;
            Some(s.wi)
        }
    }
}

/// Which way a subpath walked inside a path's vertices runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Toward {
    /// Up the indices: a light subpath `v_0 …`.
    Camera,
    /// Down the indices: a camera subpath `… v_k`.
    Light,
}

/// Extend a subpath walked inside `path`'s own slots by `n` vertices, traced into the `n` slots
/// beyond its end `from`: the subpath is `path[..=from]` walking [`Toward::Camera`], or
/// `path[from..]` walking [`Toward::Light`] (so the candidate's new vertices are never copied out
/// of a walk). Each step points the end's `wo` at its predecessor, samples the direction leaving it
/// ([`sample_direction`]) and traces it; the new end is pointed likewise. `false` when the walk
/// ends early (the ray escapes, or a BSDF cannot be sampled); the slots beyond are then stale.
pub fn extend_in_place(
    scene: &Scene,
    path: &mut [Vertex],
    from: usize,
    n: usize,
    toward: Toward,
    mode: TransportMode,
    rng: &mut ChainRng,
) -> bool {
    let len = path.len();
    let fits = match toward {
        Toward::Camera => from + n < len,
        Toward::Light => from < len && n <= from,
    };
    if !fits {
        return false;
    }
    let orient = |path: &mut [Vertex], i: usize| {
        let prev = match toward {
            Toward::Camera => i.checked_sub(1),
            Toward::Light => (i + 1 < len).then_some(i + 1),
        };
        if let Some(p) = prev {
            path[i].wo = (path[p].p() - path[i].p()).normalize_or_zero();
        }
    };
    let mut i = from;
    for _ in 0..n {
        orient(path, i);
        let Some(w) = sample_direction_at(scene, &mut path[i], mode, rng) else {
            return false;
        };
        let next = match toward {
            Toward::Camera => i + 1,
            Toward::Light => i - 1,
        };
        if !trace_between(scene, path, i, next, w) {
            return false;
        }
        i = next;
    }
    orient(path, i);
    true
}

/// A new light endpoint: a light chosen by power and a uniform point on it.
pub fn light_endpoint(scene: &Scene, rng: &mut ChainRng) -> Option<Vertex> {
    let (li, _) = scene.light_distribution.sample(uniform(rng))?;
    let u = [uniform(rng), uniform(rng)];
    let (point, _) = scene.lights[li].sample_point(&scene.bvh, u)?;
    Some(endpoint(VertexKind::Light { light: li as u32 }, point))
}

/// A new lens endpoint: a uniform point on the lens.
pub fn lens_endpoint(scene: &Scene, rng: &mut ChainRng) -> Option<Vertex> {
    let u = [uniform(rng), uniform(rng)];
    let cs = scene.camera.sample_ray([0.5, 0.5], u);
    Some(endpoint(
        VertexKind::Camera,
        scene.camera.lens_point(cs.ray.o),
    ))
}

/// An endpoint vertex of `kind` at `point` (no BSDF, not delta).
pub fn endpoint(kind: VertexKind, point: SurfacePoint) -> Vertex {
    Vertex {
        kind,
        point,
        wo: DVec3::ZERO,
        bsdf: None,
        beta: Rgb::BLACK,
        delta: false,
        pdf_fwd: 0.0,
        pdf_rev: 0.0,
    }
}

/// A radius exponentially distributed between `r1` and `r2` (`ln r` uniform): the pixel and
/// angular offsets of the practical-MLT paper.
pub fn exponential_radius(r1: f64, r2: f64, rng: &mut ChainRng) -> f64 {
    r2 * (-(r2 / r1).ln() * uniform(rng)).exp()
}

/// Density of [`exponential_radius`] at `r` (0 outside `[r1, r2]`).
pub fn exponential_radius_pdf(r: f64, r1: f64, r2: f64) -> f64 {
    if r >= r1 && r <= r2 {
        1.0 / (r * (r2 / r1).ln())
    } else {
        0.0
    }
}

/// Move a raster position by a distance exponentially distributed in `[r1, r2]` pixels in a
/// uniform direction (density in the image plane `p(r) / (2π r)`, symmetric).
pub fn pixel_offset(raster: [f64; 2], r1: f64, r2: f64, rng: &mut ChainRng) -> [f64; 2] {
    let (cos_p, sin_p) = turn(uniform(rng));
    let r = exponential_radius(r1, r2, rng);
    [raster[0] + r * cos_p, raster[1] + r * sin_p]
}

/// Rotate unit direction `w` by an angle exponentially distributed in `[θ1, θ2]` about a uniform
/// axis perpendicular to it. The density in solid angle, `p(θ) / (2π sin θ)`, depends only on the
/// angle between the two directions, so the move is symmetric.
pub fn angular_offset(w: DVec3, theta1: f64, theta2: f64, rng: &mut ChainRng) -> DVec3 {
    let (cos_p, sin_p) = turn(uniform(rng));
    let theta = exponential_radius(theta1, theta2, rng);
    let (sin_t, cos_t) = theta.sin_cos();
    let local = DVec3::new(sin_t * cos_p, sin_t * sin_p, cos_t);
    Frame::from_normal(w).to_world(local).normalize()
}

/// Solid-angle density of [`angular_offset`] moving `a` to `b`.
pub fn angular_offset_pdf(a: DVec3, b: DVec3, theta1: f64, theta2: f64) -> f64 {
    let theta = a.cross(b).length().atan2(a.dot(b));
    let s = theta.sin();
    if s > 0.0 {
        exponential_radius_pdf(theta, theta1, theta2) / (TAU * s)
    } else {
        0.0
    }
}

/// A direction in the cone of half-angle `beta` about unit `axis`, with the angle `θ` to the axis
/// uniform in `[0, β)` and the azimuth uniform (Fan, Chenney & Lai 2005, §5.1 and §5.3). Its
/// density in solid angle is [`cone_pdf`].
pub fn cone_direction(axis: DVec3, beta: f64, rng: &mut ChainRng) -> DVec3 {
    let (cos_p, sin_p) = turn(uniform(rng));
    let theta = beta * uniform(rng);
    let (sin_t, cos_t) = theta.sin_cos();
    let local = DVec3::new(sin_t * cos_p, sin_t * sin_p, cos_t);
    Frame::from_normal(axis).to_world(local).normalize()
}

/// Solid-angle density of [`cone_direction`] about `axis` producing `w`: `1 / (2π β sin θ)` for
/// `θ < β`, 0 outside. (The paper prints `1/(2πβ)`, the density of `(θ, φ)`; per steradian the
/// `sin θ` of the area element belongs in it.)
pub fn cone_pdf(axis: DVec3, w: DVec3, beta: f64) -> f64 {
    let theta = axis.cross(w).length().atan2(axis.dot(w));
    let s = theta.sin();
    if theta < beta && s > 0.0 {
        1.0 / (TAU * beta * s)
    } else {
        0.0
    }
}

/// Run `f` with two empty vertex lists whose storage is kept per thread: a mutation that builds
/// a candidate's new vertices in a list of its own (the lens-subpath mutation, whose walk stops
/// where it finds a non-specular surface, so its length is not known before) would otherwise
/// allocate it at every proposal; mutations that know their new vertices' count walk in the
/// candidate itself ([`extend_in_place`]). The lists are taken out of the thread's slot for the
/// call, so a nested call gets fresh ones instead of failing.
pub fn with_vertex_buffers<R>(f: impl FnOnce(&mut Vec<Vertex>, &mut Vec<Vertex>) -> R) -> R {
    thread_local! {
        static LISTS: std::cell::Cell<(Vec<Vertex>, Vec<Vertex>)> =
            const { std::cell::Cell::new((Vec::new(), Vec::new())) };
    }
    let (mut a, mut b) = LISTS.take();
    a.clear();
    b.clear();
    let r = f(&mut a, &mut b);
    LISTS.set((a, b));
    r
}

thread_local! {
    /// The light and camera subpaths of [`sample_path`] and [`sample_paths_every_length`], per
    /// thread (a path is sampled per bootstrap sample, new-path proposal and technique-chart
    /// map, and a walk reserves a whole subpath of vertices).
    static BUFFERS: std::cell::RefCell<(Subpath, Subpath)> =
        const { std::cell::RefCell::new((Subpath::new(), Subpath::new())) };
}

/// Sample a whole path of `k` edges by strategy `s` (light vertices) from `stream`, as BDPT would
/// (the connection is tested for visibility); `None` when the subpaths fall short or the
/// connection carries nothing. The path is not evaluated.
pub fn sample_path<S: SampleStream>(
    scene: &Scene,
    k: usize,
    s: usize,
    stream: &mut S,
    out: &mut PathState,
) -> Option<()> {
    BUFFERS.with_borrow_mut(|(light, cam)| {
        let t = k + 1 - s;
        if !technique_subpaths(scene, stream, s, t, cam, light) {
            return None;
        }
        connect(scene, light, cam, s, t)?;
        out.path.set_from_subpaths(scene, light, cam, s, t)
    })
}

/// [`sample_path`] for every length `k = 1 ..= max_edges` at once, by strategy `strategy(k)`
/// (`None`: skip that length), from a stream whose numbers depend on their position alone
/// ([`crate::sampler::KeyedStream`]), the subpaths walked once for all lengths
/// ([`technique_subpaths_every_length`]). `each(k, out)` is called, in order of `k`, for every
/// length whose path [`sample_path`] would have made, with that path in `out`.
pub fn sample_paths_every_length<S: SampleStream>(
    scene: &Scene,
    max_edges: usize,
    strategy: impl Fn(usize) -> Option<usize>,
    stream: &mut S,
    out: &mut PathState,
    mut each: impl FnMut(usize, &mut PathState),
) {
    BUFFERS.with_borrow_mut(|(light, cam)| {
        technique_subpaths_every_length(
            scene,
            stream,
            max_edges,
            strategy,
            cam,
            light,
            |k, s, t, cam, light| {
                if connect(scene, light, cam, s, t).is_some()
                    && out
                        .path
                        .set_from_subpaths(scene, light, cam, s, t)
                        .is_some()
                {
                    each(k, out);
                }
            },
        );
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin;
    use mcmc_core::rng::stream;

    /// A walk in a list of its own, in walk order: the way the bidirectional mutation walked its
    /// subpaths before it walked them in the candidate ([`extend_in_place`] must match it).
    fn extend_in_list(
        scene: &Scene,
        sub: &mut Vec<Vertex>,
        n: usize,
        mode: TransportMode,
        rng: &mut ChainRng,
    ) -> bool {
        for _ in 0..n {
            let Some(w) = sample_direction(scene, sub, mode, rng) else {
                return false;
            };
            let Some(v) = sub.last().and_then(|last| trace(scene, last, w)) else {
                return false;
            };
            sub.push(v);
        }
        orient_last(sub);
        true
    }

    fn same_vertex(a: &Vertex, b: &Vertex) -> bool {
        a.kind == b.kind
            && a.point == b.point
            && a.wo == b.wo
            && a.bsdf == b.bsdf
            && a.delta == b.delta
            && a.beta == b.beta
    }

    /// Subpaths walked inside a path's slots, both ways, from endpoints alone and from ends with
    /// a predecessor, are the walks of a list of their own vertex for vertex (bit for bit, and
    /// with the same random numbers drawn). Fails when the in-place walk points an end's `wo` at
    /// the wrong neighbour.
    #[test]
    fn a_walk_in_a_path_is_the_walk_in_a_list() {
        let (mut compared, mut walked) = (0, 0);
        for name in builtin::all() {
            let scene = Scene::new(&builtin::builtin(name).unwrap(), Some((32, 24))).unwrap();
            for trial in 0..300u64 {
                for toward in [Toward::Camera, Toward::Light] {
                    let (mode, start): (_, fn(&Scene, &mut ChainRng) -> Option<Vertex>) =
                        match toward {
                            Toward::Camera => (TransportMode::Importance, light_endpoint),
                            Toward::Light => (TransportMode::Radiance, lens_endpoint),
                        };
                    let (first, more) = (trial as usize % 3, 1 + trial as usize % 4);
                    let mut rng = stream(trial, 7);
                    let Some(end) = start(&scene, &mut rng) else {
                        continue;
                    };
                    // The first part in a list, then the rest in the list and in place.
                    let mut list = vec![end];
                    if !extend_in_list(&scene, &mut list, first, mode, &mut rng) {
                        continue;
                    }
                    let len = list.len() + more + 2;
                    let stale = list[0].clone();
                    let mut path = vec![stale; len];
                    let from = match toward {
                        Toward::Camera => {
                            path[..list.len()].clone_from_slice(&list);
                            list.len() - 1
                        }
                        Toward::Light => {
                            for (slot, v) in path.iter_mut().rev().zip(&list) {
                                slot.clone_from(v);
                            }
                            len - list.len()
                        }
                    };
                    let mut rng_list = rng.clone();
                    let in_list = extend_in_list(&scene, &mut list, more, mode, &mut rng_list);
                    let in_place =
                        extend_in_place(&scene, &mut path, from, more, toward, mode, &mut rng);
                    assert_eq!(in_list, in_place, "{name}, trial {trial}, {toward:?}");
                    compared += 1;
                    if !in_list {
                        continue;
                    }
                    walked += 1;
                    assert_eq!(uniform(&mut rng), uniform(&mut rng_list));
                    let walk: Vec<&Vertex> = match toward {
                        Toward::Camera => path[..list.len()].iter().collect(),
                        Toward::Light => path[len - list.len()..].iter().rev().collect(),
                    };
                    for (i, (a, b)) in walk.iter().zip(&list).enumerate() {
                        assert!(
                            same_vertex(a, b),
                            "{name}, trial {trial}, {toward:?}, vertex {i}"
                        );
                    }
                }
            }
        }
        assert!(
            compared > 3000 && walked > 1000,
            "{compared} compared, {walked} walked"
        );
    }

    /// The walk refuses slots it does not have.
    #[test]
    fn a_walk_in_a_path_stays_inside_it() {
        let scene = Scene::new(&builtin::builtin("cornell").unwrap(), Some((8, 8))).unwrap();
        let mut rng = stream(1, 1);
        let lens = lens_endpoint(&scene, &mut rng).unwrap();
        let mut path = vec![lens; 3];
        let mut refused = |from, n, toward, mode| {
            !extend_in_place(&scene, &mut path, from, n, toward, mode, &mut rng)
        };
        assert!(refused(1, 2, Toward::Light, TransportMode::Radiance));
        assert!(refused(1, 2, Toward::Camera, TransportMode::Importance));
        assert!(refused(3, 0, Toward::Light, TransportMode::Radiance));
    }

    /// The lists come empty, keep their storage from one call to the next on a thread, and a
    /// nested call gets lists of its own rather than a borrow failure.
    #[test]
    fn vertex_buffers_are_empty_kept_and_nestable() {
        let v = endpoint(
            VertexKind::Camera,
            SurfacePoint::flat(DVec3::ZERO, DVec3::Z, 0),
        );
        let storage = with_vertex_buffers(|a, b| {
            a.extend(std::iter::repeat_n(v.clone(), 5));
            b.push(v.clone());
            let inner = with_vertex_buffers(|c, d| {
                assert!(c.is_empty() && d.is_empty());
                c.push(v.clone());
                c.as_ptr()
            });
            assert_ne!(inner, a.as_ptr());
            a.as_ptr()
        });
        with_vertex_buffers(|a, b| {
            assert!(a.is_empty() && b.is_empty());
            assert_eq!(a.as_ptr(), storage);
        });
    }
}
