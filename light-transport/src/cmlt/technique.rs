//! Technique charts (charted-MLT paper §5 and appendix): for a path length `k` and a
//! bidirectional strategy `(s, t)`, `s + t = k + 1`, the chart whose primary space is the fixed
//! per-vertex layout of the sample streams ([`crate::sampler`]), whose forward map traces `t`
//! camera and `s` light vertices from those numbers and connects them, and whose stochastic right
//! inverse writes back the numbers of every vertex of a given path, drawn from their exact
//! conditional law (DESIGN §3): camera film and lens numbers, light choice within the light's
//! interval, position on the light, emitted direction, and at every scattering vertex a lobe
//! chosen in proportion to its share of the density followed by that lobe's inverse. Numbers the
//! forward map does not read (Russian roulette, the film position of a `t = 1` camera vertex, the
//! emitted direction of an `s = 1` light vertex, the lens of a pinhole) are free and drawn
//! uniformly.
//!
//! **Densities.** Paths through specular vertices have no density with respect to area measure,
//! but every charted acceptance rule only compares densities of charts, or targets, at the same
//! path. The chart therefore reports densities with respect to the measure `I(f) dμ` (`I` the
//! scalar importance of the measurement contribution): `p_s / I(f) = 1 / I(C*_s)`, with
//! `C*_s = f/p_s` the unweighted contribution the bidirectional machinery computes exactly, delta
//! factors included. Relative to that measure the integrand is `1` ([`unit_integrand`]).

use crate::metropolis::ImportanceKind;
use crate::path::{Vertex, VertexKind};
use crate::pathspace::PathState;
use crate::pathspace::walk::sample_path;
use crate::sampler::{
    CAMERA_STREAM, KeyedStream, LIGHT_STREAM, ReplayStream, SampleStream, SliceStream,
    VERTEX_BLOCK, WritableStream, layout,
};
use crate::scene::Scene;
use mcmc_charts::Chart;
use mcmc_core::ChainRng;
use mcmc_core::rng::uniform;

/// The integrand relative to the measure `I(f) dμ` the technique charts report densities in: 1
/// on paths that carry light.
pub fn unit_integrand(x: &PathState) -> f64 {
    if x.carries_light() { 1.0 } else { 0.0 }
}

/// The chart of strategy `s` (light vertices) for paths of `k` edges.
#[derive(Clone, Copy)]
pub struct TechniqueChart<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Path length (edges).
    pub k: usize,
    /// Light vertices.
    pub s: usize,
    /// Colour to scalar.
    pub importance: ImportanceKind,
}

pub use crate::sampler::layout::{camera_numbers, light_numbers};

/// The numbers of another chart of the same path, for the partial inverse: its camera and light
/// vertex counts and its numbers (camera part, light part).
struct Old<'a> {
    t: usize,
    s: usize,
    numbers: ReplayStream<'a>,
}

impl Old<'_> {
    /// Copy `n` numbers from position `at` of substream `stream` of the old chart into `w`.
    fn copy(&mut self, w: &mut SliceStream<'_>, stream: usize, at: usize, n: usize) {
        self.numbers.start_stream(stream);
        self.numbers.seek(at);
        w.start_stream(stream);
        w.seek(at);
        for _ in 0..n {
            w.put(self.numbers.next_1d());
        }
    }
}

impl<'a> TechniqueChart<'a> {
    /// The chart of `(s, k + 1 − s)`; `None` when `s > k`.
    pub fn new(scene: &'a Scene, k: usize, s: usize, importance: ImportanceKind) -> Option<Self> {
        (k >= 1 && s <= k).then_some(Self {
            scene,
            k,
            s,
            importance,
        })
    }

    /// Camera vertices `t`.
    pub fn t(&self) -> usize {
        self.k + 1 - self.s
    }

    /// The coordinates holding the numbers of key `seed` ([`KeyedStream`]) where the forward map
    /// reads them: the camera substream's first numbers, then the light substream's. The forward
    /// map of these coordinates walks the first vertices of the subpaths a [`KeyedStream`] of
    /// `seed` walks, so one pair of walks serves every chart and length
    /// ([`crate::pathspace::walk::sample_paths_every_length`]).
    pub fn keyed_coordinates(&self, seed: u64) -> impl Iterator<Item = f64> {
        let (keyed, light_keyed) = (KeyedStream::new(seed), KeyedStream::new(seed));
        let camera = (0..camera_numbers(self.t())).map(move |i| keyed.number(CAMERA_STREAM, i));
        let light = (0..light_numbers(self.s)).map(move |i| light_keyed.number(LIGHT_STREAM, i));
        camera.chain(light)
    }

    /// Whether the path the forward map made from this chart's subpaths is a point of the
    /// chart, evaluating it: it carries light and this strategy could have made it.
    pub fn evaluate_path(&self, x: &mut PathState) -> bool {
        x.evaluate(self.scene, self.importance, 1.0) && x.strategy_importance(self.s) > 0.0
    }

    /// Write the numbers of the scattering vertex `v` (reached from `prev`, leaving toward
    /// `next`) into its block, which starts at `block` of `w`'s current substream.
    fn invert_scattering(
        v: &Vertex,
        prev: &Vertex,
        next: &Vertex,
        w: &mut SliceStream<'_>,
        block: usize,
        rng: &mut ChainRng,
    ) -> bool {
        let Some(b) = v.bsdf.as_ref() else {
            return false;
        };
        let wo = (prev.p() - v.p()).normalize_or_zero();
        let wi = (next.p() - v.p()).normalize_or_zero();
        let Some([l, u0, u1]) = b.invert(wo, wi, v.delta, rng) else {
            return false;
        };
        w.seek(block + layout::LOBE);
        w.put(l);
        w.seek(block + layout::DIRECTION);
        w.put_2d([u0, u1]);
        w.seek(block + layout::ROULETTE);
        w.put(uniform(rng));
        true
    }

    /// Write the camera numbers of path `x` (camera vertices `v_k, v_{k−1}, …`). With `old`
    /// (another chart at the same path), numbers whose conditional law is the same in both
    /// charts are kept and only the others are drawn.
    fn invert_camera(
        &self,
        x: &PathState,
        w: &mut SliceStream<'_>,
        rng: &mut ChainRng,
        mut old: Option<&mut Old<'_>>,
    ) -> bool {
        let v = &x.path.vertices;
        let (k, t) = (self.k, self.t());
        let lens = &v[k];
        let cam = &self.scene.camera;
        let free = [uniform(rng), uniform(rng)];
        let keep_endpoint = old.as_ref().is_some_and(|o| o.t >= 2 && t >= 2);
        if let (true, Some(o)) = (keep_endpoint, old.as_deref_mut()) {
            o.copy(w, CAMERA_STREAM, layout::FILM, 4);
        } else {
            let (film, lens_u) = if t >= 2 {
                let d = (v[k - 1].p() - lens.p()).normalize_or_zero();
                match cam.invert(lens.p(), d, free) {
                    Some(r) => r,
                    None => return false,
                }
            } else {
                (
                    [uniform(rng), uniform(rng)],
                    cam.invert_lens(lens.p(), free),
                )
            };
            w.start_stream(CAMERA_STREAM);
            w.seek(layout::FILM);
            w.put_2d(film);
            w.seek(layout::LENS);
            w.put_2d(lens_u);
        }
        // Camera vertex b (1 ≤ b ≤ t − 2) is path vertex k − b.
        for b in 1..t.saturating_sub(1) {
            let block = layout::camera_vertex(b);
            if let Some(o) = old.as_deref_mut()
                && b + 2 <= o.t
            {
                o.copy(w, CAMERA_STREAM, block, VERTEX_BLOCK);
                continue;
            }
            let i = k - b;
            w.start_stream(CAMERA_STREAM);
            if !Self::invert_scattering(&v[i], &v[i + 1], &v[i - 1], w, block, rng) {
                return false;
            }
        }
        true
    }

    /// Write the light numbers of path `x` (light vertices `v_0, v_1, …`); `old` as for
    /// [`TechniqueChart::invert_camera`].
    fn invert_light(
        &self,
        x: &PathState,
        w: &mut SliceStream<'_>,
        rng: &mut ChainRng,
        old: Option<&mut Old<'_>>,
    ) -> bool {
        let s = self.s;
        if s == 0 {
            return true;
        }
        let mut old = old.filter(|o| o.s >= 1);
        let v = &x.path.vertices;
        let VertexKind::Light { light } = v[0].kind else {
            return false;
        };
        let li = light as usize;
        let scene = self.scene;
        let free = [uniform(rng), uniform(rng), uniform(rng), uniform(rng)];
        // Light choice and position have the same conditional law in every chart with s ≥ 1; the
        // emitted direction is determined for s ≥ 2 and free for s = 1.
        let keep_dir = old.as_ref().is_some_and(|o| (o.s >= 2) == (s >= 2));
        if let Some(o) = old.as_deref_mut() {
            o.copy(w, LIGHT_STREAM, layout::LIGHT_CHOICE, 1);
            o.copy(w, LIGHT_STREAM, layout::LIGHT_POSITION, 2);
            if keep_dir {
                o.copy(w, LIGHT_STREAM, layout::LIGHT_DIRECTION, 2);
            }
        }
        if !keep_dir {
            w.start_stream(LIGHT_STREAM);
            if old.is_none() {
                w.seek(layout::LIGHT_CHOICE);
                w.put(scene.light_distribution.invert(li, uniform(rng)));
            }
            let l = &scene.lights[li];
            let d = if s >= 2 {
                (v[1].p() - v[0].p()).normalize_or_zero()
            } else {
                v[0].n()
            };
            let Some((u_pos, u_dir)) = l.invert_emission(&scene.bvh.primitives, v[0].p(), d, free)
            else {
                return false;
            };
            if old.is_none() {
                w.seek(layout::LIGHT_POSITION);
                w.put_2d(u_pos);
            }
            w.seek(layout::LIGHT_DIRECTION);
            w.put_2d(if s >= 2 { u_dir } else { [free[2], free[3]] });
        }
        for b in 1..s.saturating_sub(1) {
            let block = layout::light_vertex(b);
            if let Some(o) = old.as_deref_mut()
                && b + 2 <= o.s
            {
                o.copy(w, LIGHT_STREAM, block, VERTEX_BLOCK);
                continue;
            }
            w.start_stream(LIGHT_STREAM);
            if !Self::invert_scattering(&v[b], &v[b - 1], &v[b + 1], w, block, rng) {
                return false;
            }
        }
        true
    }

    /// Invert `x` into `u` (camera numbers, then light numbers), keeping what `old` shares.
    fn invert_into(
        &self,
        x: &PathState,
        u: &mut [f64],
        rng: &mut ChainRng,
        mut old: Option<Old<'_>>,
    ) -> bool {
        if !(self.ln_density(x) > f64::NEG_INFINITY) || u.len() < self.dim() {
            return false;
        }
        let (cam, light) = u.split_at_mut(camera_numbers(self.t()));
        let mut w = SliceStream::new(cam, light);
        self.invert_camera(x, &mut w, rng, old.as_mut())
            && self.invert_light(x, &mut w, rng, old.as_mut())
            && !w.overflowed()
    }
}

impl Chart<PathState> for TechniqueChart<'_> {
    fn dim(&self) -> usize {
        camera_numbers(self.t()) + light_numbers(self.s)
    }

    fn forward(&self, u: &[f64], x: &mut PathState) -> bool {
        let nc = camera_numbers(self.t());
        if u.len() < nc + light_numbers(self.s) {
            return false;
        }
        let mut stream = ReplayStream::new(&u[..nc], &u[nc..], &[]);
        if sample_path(self.scene, self.k, self.s, &mut stream, x).is_none() {
            // The candidate of a failed large step counts in this chart's length.
            x.fail_walk(self.k);
            return false;
        }
        self.evaluate_path(x)
    }

    fn ln_density(&self, x: &PathState) -> f64 {
        let i = x.strategy_importance(self.s);
        if x.path.edges() == self.k && i > 0.0 {
            -i.ln()
        } else {
            f64::NEG_INFINITY
        }
    }

    fn invert(&self, x: &PathState, u: &mut [f64], rng: &mut ChainRng) -> bool {
        self.invert_into(x, u, rng, None)
    }

    /// The numbers `u` of path `x` in this chart, given its numbers `u_from` in chart `from` (same
    /// path length): only the vertices whose numbers differ between the two charts are inverted
    /// (charted-MLT paper §6.1); the others keep their numbers, whose conditional law given `x` is
    /// the same in both charts, so `u` has the law of [`Chart::invert`] when `u_from` has the law
    /// of `from`'s inverse.
    fn partial_inverse(
        &self,
        x: &PathState,
        from: &Self,
        u_from: &[f64],
        u: &mut [f64],
        rng: &mut ChainRng,
    ) -> bool {
        if from.k != self.k || u_from.len() < from.dim() {
            return false;
        }
        let (cam, light) = u_from.split_at(camera_numbers(from.t()));
        let old = Old {
            t: from.t(),
            s: from.s,
            numbers: ReplayStream::new(cam, light, &[]),
        };
        self.invert_into(x, u, rng, Some(old))
    }

    fn name(&self) -> String {
        format!("k={} (s={}, t={})", self.k, self.s, self.t())
    }
}

/// All technique charts of paths of `1 … max_edges` edges, in order of `k` then `s`.
pub fn technique_charts(
    scene: &Scene,
    max_edges: usize,
    importance: ImportanceKind,
) -> Vec<TechniqueChart<'_>> {
    (1..=max_edges)
        .flat_map(|k| (0..=k).filter_map(move |s| TechniqueChart::new(scene, k, s, importance)))
        .collect()
}
