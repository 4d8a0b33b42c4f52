//! Camera and light random walks, reading the sample stream in the fixed layout of
//! [`crate::sampler`]: the camera endpoint from the camera substream's first block, the light
//! endpoint from the light substream's first block, and the direction leaving the `b`-th vertex of
//! a subpath from that subpath's `b`-th vertex block. Subpaths are therefore deterministic
//! functions of the stream, vertex by vertex.

use super::mis::DELTA_DENSITY;
use super::subpath::Subpath;
use super::vertex::{Vertex, VertexKind};
use crate::bsdf::TransportMode;
use crate::camera::CameraSample;
use crate::geometry::Ray;
use crate::sampler::{
    CAMERA_BLOCK, CAMERA_STREAM, LIGHT_BLOCK, LIGHT_STREAM, SampleStream, layout,
};
use crate::scene::Scene;
use crate::spectrum::Rgb;

/// Limits of the walks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WalkSettings {
    /// Maximum number of edges of a complete path (pbrt's `maxdepth + 1`).
    pub max_edges: usize,
}

impl WalkSettings {
    /// Most vertices a camera subpath needs: `max_edges + 1`.
    pub fn max_camera_vertices(&self) -> usize {
        self.max_edges + 1
    }
    /// Most vertices a light subpath needs: `max_edges`.
    pub fn max_light_vertices(&self) -> usize {
        self.max_edges
    }
}

/// The camera ray of a sample: the film numbers (inside `pixel`, or over the whole film) and the
/// lens numbers of the camera substream's endpoint block. Every camera-side estimator starts here.
pub fn camera_ray<S: SampleStream>(
    scene: &Scene,
    stream: &mut S,
    pixel: Option<usize>,
) -> CameraSample {
    stream.start_stream(CAMERA_STREAM);
    stream.seek(layout::FILM);
    let mut film = stream.next_2d();
    stream.seek(layout::LENS);
    let lens = stream.next_2d();
    if let Some(p) = pixel {
        film = scene.camera.film_position(p, film);
    }
    scene.camera.sample_ray(film, lens)
}

/// Smallest continuation probability of [`Roulette`].
pub const ROULETTE_FLOOR: f64 = 0.5;

/// Russian roulette in the subpath walks. At every vertex `b ≥ from` (the lens or light vertex is
/// 0) the walk continues with probability `q = clamp(max_c β_b[c] / β_1[c], 0.5, 0.95)`, decided
/// by the vertex block's roulette number `u < q`, and the later vertices' throughputs are divided
/// by `q`. `β_b / β_1` is the subpath's throughput since its first surface vertex, so a light
/// subpath's emitted power does not enter; in camera walks the radiance compression of
/// refractions is divided out of it ([`crate::bsdf::Bsdf::radiance_compression`], pbrt's
/// `etaScale`), so that a path does not stop more often inside glass or water. The floor bounds
/// a survivor's `1/q` boost: without it, one of four 20 s renders of `veach-bidir` had a firefly
/// (RMSE 1.36 instead of 0.072).
///
/// The decision is a function of the sample stream, so replaying a stream replays it. Estimators
/// stay unbiased whatever their MIS weights, as long as those sum to one over the strategies of a
/// path: the densities in them need not include `q` (pbrt and Mitsuba leave it out too). BDPT and
/// PSSMLT (whose target is BDPT's estimate as a function of the primary sample) use it; MMLT does
/// not (its technique fixes both subpaths' lengths, so a stop would only lose the sample), nor do
/// the path-space methods: the technique charts' inverses and the path-space densities do not
/// model it.
///
/// With `camera: false` only light subpaths stop: camera paths keep the densities their MIS
/// weights assume, which matters where a long camera path through specular surfaces is the one
/// strategy that works (measured in the README).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Roulette {
    /// First vertex index at which the walk may stop.
    pub from: usize,
    /// Whether camera subpaths stop too (light subpaths always do).
    pub camera: bool,
}

impl std::fmt::Display for Roulette {
    /// For render reports: which walks may stop, from which vertex.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let walks = if self.camera {
            "camera and light"
        } else {
            "light"
        };
        write!(f, "{walks} subpaths may stop from vertex {} on", self.from)
    }
}

impl Roulette {
    /// The report line of `roulette` (none when off), as BDPT and PSSMLT print it.
    pub fn report(roulette: Option<Roulette>) -> Vec<String> {
        roulette
            .map(|r| vec![format!("roulette   {r}")])
            .unwrap_or_default()
    }

    /// The roulette of a camera walk under `roulette`.
    pub fn for_camera(roulette: Option<Roulette>) -> Option<Roulette> {
        roulette.filter(|r| r.camera)
    }

    /// The probability that a walk continues past a vertex whose throughput is `beta`, `beta_1`
    /// at its subpath's first surface vertex: `clamp(max_c β[c] / β_1[c], 0.5, 0.95)`, channels
    /// whose ratio is not finite left out. The one rule of the subpath walks and of path
    /// tracing ([`crate::integrators::PathTracer::roulette_from`]).
    pub fn continuation(beta: Rgb, beta_1: Rgb) -> f64 {
        (0..3)
            .map(|c| beta[c] / beta_1[c])
            .filter(|x| x.is_finite())
            .fold(0.0, f64::max)
            .clamp(ROULETTE_FLOOR, 0.95)
    }
}

/// Trace a camera subpath of at most `max_vertices` vertices into `path` (cleared first). With
/// `pixel`, the film numbers place the sample inside that pixel; without, over the whole film.
pub fn camera_subpath<S: SampleStream>(
    scene: &Scene,
    stream: &mut S,
    max_vertices: usize,
    pixel: Option<usize>,
    path: &mut Subpath,
) {
    camera_subpath_with(scene, stream, max_vertices, pixel, None, path);
}

/// [`camera_subpath`] with optional Russian roulette.
pub fn camera_subpath_with<S: SampleStream>(
    scene: &Scene,
    stream: &mut S,
    max_vertices: usize,
    pixel: Option<usize>,
    roulette: Option<Roulette>,
    path: &mut Subpath,
) {
    path.clear();
    if max_vertices == 0 {
        return;
    }
    path.reserve(max_vertices);
    let cs = camera_ray(scene, stream, pixel);
    path.push(Vertex {
        kind: VertexKind::Camera,
        point: scene.camera.lens_point(cs.ray.o),
        wo: crate::math::DVec3::ZERO,
        bsdf: None,
        beta: Rgb::WHITE,
        delta: false,
        pdf_fwd: cs.pdf_pos,
        pdf_rev: 0.0,
    });
    if cs.we == 0.0 {
        return;
    }
    // W_e cos θ / (p_pos p_dir) = 1 by the camera's normalisation.
    random_walk(
        scene,
        cs.ray,
        Rgb::WHITE,
        cs.pdf_dir,
        max_vertices,
        TransportMode::Radiance,
        stream,
        CAMERA_BLOCK,
        roulette,
        path,
    );
}

/// Trace a light subpath of at most `max_vertices` vertices into `path` (cleared first).
pub fn light_subpath<S: SampleStream>(
    scene: &Scene,
    stream: &mut S,
    max_vertices: usize,
    path: &mut Subpath,
) {
    light_subpath_with(scene, stream, max_vertices, None, path);
}

/// [`light_subpath`] with optional Russian roulette.
pub fn light_subpath_with<S: SampleStream>(
    scene: &Scene,
    stream: &mut S,
    max_vertices: usize,
    roulette: Option<Roulette>,
    path: &mut Subpath,
) {
    path.clear();
    if max_vertices == 0 {
        return;
    }
    path.reserve(max_vertices);
    stream.start_stream(LIGHT_STREAM);
    stream.seek(layout::LIGHT_CHOICE);
    let choice = stream.next_1d();
    stream.seek(layout::LIGHT_POSITION);
    let u_pos = stream.next_2d();
    stream.seek(layout::LIGHT_DIRECTION);
    let u_dir = stream.next_2d();
    let Some((li, p_choice)) = scene.light_distribution.sample(choice) else {
        return;
    };
    let light = &scene.lights[li];
    let Some(es) = light.sample_emission(&scene.bvh, u_pos, u_dir) else {
        return;
    };
    let pdf_origin = p_choice * es.pdf_pos;
    path.push(Vertex {
        kind: VertexKind::Light { light: li as u32 },
        point: es.point,
        wo: crate::math::DVec3::ZERO,
        bsdf: None,
        beta: Rgb::splat(1.0 / pdf_origin),
        delta: false,
        pdf_fwd: pdf_origin,
        pdf_rev: 0.0,
    });
    if es.pdf_dir == 0.0 || es.le.is_black() {
        return;
    }
    let cos = if es.delta_pos {
        1.0
    } else {
        es.point.n.dot(es.w).abs()
    };
    let beta = es.le * (cos / (pdf_origin * es.pdf_dir));
    let ray = if es.delta_pos {
        Ray::new(es.point.p, es.w)
    } else {
        Ray::leaving(&es.point, es.w)
    };
    random_walk(
        scene,
        ray,
        beta,
        es.pdf_dir,
        max_vertices,
        TransportMode::Importance,
        stream,
        LIGHT_BLOCK,
        roulette,
        path,
    );
}

/// The two subpaths of the single strategy `(s, t)` (Hachisuka et al. 2014's technique, a
/// technique chart of charted MLT): a camera subpath of `t` vertices into `camera` and a light
/// subpath of `s` vertices into `light`. `false` when the strategy contributes nothing: a walk
/// ended early, the camera end cannot take a connection (a delta-only BSDF, for `s > 0`), or
/// there is no camera vertex (`t = 0`: no strategy connects to the lens by chance).
///
/// The camera subpath is traced first, and the light subpath not at all when the camera subpath
/// has already decided (`light` is then left as it was): a third to a half of MMLT's
/// evaluations, bootstrap included, on `veach-bidir` and the built-in scenes but `door`, whose
/// camera paths stay inside its room (0.25% there). Where the strategy can contribute, both walks
/// read the stream as before. A stopped evaluation only leaves numbers unread, in a candidate that
/// is then rejected (its value is zero) and whose numbers come from its own generator, or in a
/// bootstrap sample of its own seed: chains and images are bit for bit those of tracing both
/// walks every time.
pub fn technique_subpaths<S: SampleStream>(
    scene: &Scene,
    stream: &mut S,
    s: usize,
    t: usize,
    camera: &mut Subpath,
    light: &mut Subpath,
) -> bool {
    camera_subpath(scene, stream, t, None, camera);
    if t == 0 || camera.len() < t || (s > 0 && !camera[t - 1].connectible()) {
        return false;
    }
    light_subpath(scene, stream, s, light);
    light.len() >= s
}

/// [`technique_subpaths`] for every path length `k = 1 ..= max_edges` at once, strategy
/// `strategy(k)` (`None`: skip that length), from a stream whose numbers depend on their position
/// alone ([`crate::sampler::KeyedStream`]): the camera subpath is walked once to `max_edges + 1`
/// vertices and the light subpath (only if some strategy needs it) to `max_edges`, and each
/// length's strategy reads their first `t` and `s` vertices, which are the walks it would make
/// alone, number for number. `each(k, s, t, camera, light)` is called, in order of `k`, for every
/// length whose strategy can contribute, where [`technique_subpaths`] would return `true`.
pub fn technique_subpaths_every_length<S: SampleStream>(
    scene: &Scene,
    stream: &mut S,
    max_edges: usize,
    strategy: impl Fn(usize) -> Option<usize>,
    camera: &mut Subpath,
    light: &mut Subpath,
    mut each: impl FnMut(usize, usize, usize, &Subpath, &Subpath),
) {
    camera_subpath(scene, stream, max_edges + 1, None, camera);
    light.clear();
    let mut light_walked = false;
    for k in 1..=max_edges {
        let Some(s) = strategy(k) else {
            continue;
        };
        let t = k + 1 - s;
        if t == 0 || camera.len() < t || (s > 0 && !camera[t - 1].connectible()) {
            continue;
        }
        if s > 0 && !light_walked {
            light_subpath(scene, stream, max_edges, light);
            light_walked = true;
        }
        if light.len() >= s {
            each(k, s, t, camera, light);
        }
    }
}

/// Continue a subpath whose last vertex emitted `ray` with throughput `beta` and solid-angle
/// density `pdf_dir`, until `max_vertices` vertices or the walk ends.
#[allow(clippy::too_many_arguments)]
fn random_walk<S: SampleStream>(
    scene: &Scene,
    mut ray: Ray,
    mut beta: Rgb,
    mut pdf_dir: f64,
    max_vertices: usize,
    mode: TransportMode,
    stream: &mut S,
    endpoint_block: usize,
    roulette: Option<Roulette>,
    path: &mut Subpath,
) {
    // Throughput of the first surface vertex (the roulette's reference).
    let mut beta_first = None;
    // The radiance compression of the refractions so far (camera walks), divided out of the
    // throughput the roulette looks at ([`crate::bsdf::Bsdf::radiance_compression`]).
    let mut compression = 1.0;
    while path.len() < max_vertices {
        // Bound in place: moving the hit out of its `Option` copied it (224 bytes) per bounce.
        let found = scene.intersect(&ray);
        let Some(hit) = &found else {
            break;
        };
        let prev = path.len() - 1;
        // The vertex and its BSDF are built in place (a vertex is large to copy).
        let vert = path.push_surface(&hit.point, -ray.d, beta);
        scene.bsdf_into(&hit.point, &mut vert.bsdf);
        let b = path.len() - 1;
        path[b].pdf_fwd = path[prev].to_area(pdf_dir, &path[b], scene);
        if path.len() >= max_vertices {
            break;
        }
        let vert = &path[b];
        let Some(bsdf) = vert.bsdf.as_ref() else {
            break;
        };
        let block = layout::vertex(endpoint_block, b);
        let beta_1 = *beta_first.get_or_insert(vert.beta);
        if let Some(r) = roulette
            && b >= r.from
        {
            stream.seek(block + layout::ROULETTE);
            let u = stream.next_1d();
            let q = Roulette::continuation(vert.beta / compression, beta_1);
            if !(u < q) {
                break;
            }
            beta = beta / q;
        }
        stream.seek(block + layout::LOBE);
        let u_lobe = stream.next_1d();
        stream.seek(block + layout::DIRECTION);
        let u = stream.next_2d();
        let Some((bs, pair)) = bsdf.sample_local(vert.wo, u_lobe, u, mode) else {
            break;
        };
        if bs.pdf == 0.0 || bs.f.is_black() {
            break;
        }
        let n = vert.n();
        let shading = vert.shading_factor(scene, vert.wo, bs.wi, mode);
        beta *= bs.f * (shading * bs.wi.dot(n).abs() / bs.pdf);
        if roulette.is_some() && mode == TransportMode::Radiance {
            compression *= bsdf.radiance_compression(vert.wo, bs.wi);
        }
        if !beta.is_finite() {
            break;
        }
        // A delta direction has no density; both directions are given the solid-angle factor
        // [`DELTA_DENSITY`], so that the area densities keep their geometric factors (module
        // docs of [`crate::path::mis`]). The vertex is marked: no strategy connects through it.
        let (pdf_fwd, pdf_rev) = if bs.delta {
            (DELTA_DENSITY, DELTA_DENSITY)
        } else {
            // `bsdf.pdf(bs.wi, vert.wo)`, bit for bit.
            (bs.pdf, bsdf.pdf_local(pair.reversed()))
        };
        pdf_dir = pdf_fwd;
        let rev = vert.to_area(pdf_rev, &path[prev], scene);
        ray = Ray::leaving(&vert.point, bs.wi);
        path[b].delta = bs.delta;
        path[prev].pdf_rev = rev;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::connect;
    use crate::sampler::IndependentStream;
    use crate::scene::builtin::{BUILTIN, builtin};
    use mcmc_core::rng::stream;

    /// A strategy's two subpaths traced together with the early stop are those traced one after
    /// the other from the same numbers whenever the strategy can contribute, and the stop never
    /// drops a strategy that connects: on every built-in Metropolis scene, for every `(s, t)` of
    /// paths of 1 to 5 edges (`t = 0` included), 60 streams each (9 000 cases: 4 269 stopped
    /// before the light subpath, 625 connect). Fails when a full camera subpath is stopped (`<=`
    /// for `<`) or a short light subpath let through (checked by hand).
    #[test]
    fn technique_subpaths_stop_only_where_nothing_connects() {
        let (mut cam, mut light) = (Subpath::new(), Subpath::new());
        let (mut cam_all, mut light_all) = (Subpath::new(), Subpath::new());
        let (mut cases, mut stopped, mut connected) = (0, 0, 0);
        for name in BUILTIN {
            let desc = builtin(name).expect("a built-in scene");
            let scene = Scene::new(&desc, Some((32, 24))).expect("a valid scene");
            for k in 1..=5 {
                for s in 0..=k + 1 {
                    let t = k + 1 - s;
                    for seed in 0..60 {
                        let seed = (k * 1000 + s * 100 + seed) as u64;
                        let mut a = IndependentStream::new(stream(seed, 7));
                        let ok = technique_subpaths(&scene, &mut a, s, t, &mut cam, &mut light);
                        let mut b = IndependentStream::new(stream(seed, 7));
                        camera_subpath(&scene, &mut b, t, None, &mut cam_all);
                        light_subpath(&scene, &mut b, s, &mut light_all);
                        let whole = cam_all.len() >= t && light_all.len() >= s;
                        let connects = whole
                            && connect(&scene, &light_all, &cam_all, s, t)
                                .is_some_and(|c| !c.value.is_black());
                        cases += 1;
                        connected += usize::from(connects);
                        if !ok {
                            stopped +=
                                usize::from(t == 0 || cam.len() < t || !cam[t - 1].connectible());
                            assert!(!connects, "{name} k={k} s={s} seed {seed}: stopped");
                            continue;
                        }
                        assert!(whole, "{name} k={k} s={s} seed {seed}: passed a short walk");
                        for (x, y) in cam
                            .iter()
                            .zip(cam_all.iter())
                            .chain(light.iter().zip(light_all.iter()))
                        {
                            assert_eq!(x.p(), y.p(), "{name} k={k} s={s} seed {seed}");
                            assert_eq!(x.pdf_fwd.to_bits(), y.pdf_fwd.to_bits());
                            assert_eq!(x.pdf_rev.to_bits(), y.pdf_rev.to_bits());
                            assert_eq!(x.beta, y.beta);
                        }
                        assert_eq!((cam.len(), light.len()), (cam_all.len(), light_all.len()));
                    }
                }
            }
        }
        assert!(stopped * 5 > cases, "{stopped} of {cases} stopped");
        assert!(connected * 20 > cases, "{connected} of {cases} connected");
    }
}
