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
use crate::sampler::{CAMERA_BLOCK, LIGHT_BLOCK, ReplayStream, VERTEX_BLOCK};
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

/// Numbers of a camera subpath of `t` vertices.
pub fn camera_numbers(t: usize) -> usize {
    CAMERA_BLOCK + VERTEX_BLOCK * t.saturating_sub(2)
}

/// Numbers of a light subpath of `s` vertices.
pub fn light_numbers(s: usize) -> usize {
    if s == 0 {
        0
    } else {
        LIGHT_BLOCK + VERTEX_BLOCK * s.saturating_sub(2)
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

    /// Write the numbers of the scattering vertex `v` (reached from `prev`, leaving toward
    /// `next`) into `out` (one vertex block).
    fn invert_scattering(
        v: &Vertex,
        prev: &Vertex,
        next: &Vertex,
        out: &mut [f64],
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
        out[0] = l;
        out[1] = u0;
        out[2] = u1;
        out[3] = uniform(rng);
        true
    }

    /// The camera numbers of path `x` (camera vertices `v_k, v_{k−1}, …`). With `old` (the camera
    /// vertex count and camera numbers of another chart at the same path), numbers whose
    /// conditional law is the same in both charts are kept and only the others are drawn.
    fn invert_camera(
        &self,
        x: &PathState,
        out: &mut [f64],
        rng: &mut ChainRng,
        old: Option<(usize, &[f64])>,
    ) -> bool {
        let v = &x.path.vertices;
        let (k, t) = (self.k, self.t());
        let lens = &v[k];
        let cam = &self.scene.camera;
        let free = [uniform(rng), uniform(rng)];
        let keep_endpoint = old.is_some_and(|(t_old, _)| t_old >= 2 && t >= 2);
        let (film, lens_u) = if let (true, Some((_, o))) = (keep_endpoint, old) {
            ([o[0], o[1]], [o[2], o[3]])
        } else if t >= 2 {
            let w = (v[k - 1].p() - lens.p()).normalize_or_zero();
            match cam.invert(lens.p(), w, free) {
                Some(r) => r,
                None => return false,
            }
        } else {
            (
                [uniform(rng), uniform(rng)],
                cam.invert_lens(lens.p(), free),
            )
        };
        out[..4].copy_from_slice(&[film[0], film[1], lens_u[0], lens_u[1]]);
        // Camera vertex b (1 ≤ b ≤ t − 2) is path vertex k − b.
        for b in 1..t.saturating_sub(1) {
            let at = CAMERA_BLOCK + (b - 1) * VERTEX_BLOCK;
            if let Some((t_old, o)) = old
                && b + 2 <= t_old
            {
                out[at..at + VERTEX_BLOCK].copy_from_slice(&o[at..at + VERTEX_BLOCK]);
                continue;
            }
            let i = k - b;
            if !Self::invert_scattering(
                &v[i],
                &v[i + 1],
                &v[i - 1],
                &mut out[at..at + VERTEX_BLOCK],
                rng,
            ) {
                return false;
            }
        }
        true
    }

    /// The light numbers of path `x` (light vertices `v_0, v_1, …`); `old` as for
    /// [`TechniqueChart::invert_camera`], with the light vertex count and light numbers.
    fn invert_light(
        &self,
        x: &PathState,
        out: &mut [f64],
        rng: &mut ChainRng,
        old: Option<(usize, &[f64])>,
    ) -> bool {
        let s = self.s;
        if s == 0 {
            return true;
        }
        let old = old.filter(|(s_old, _)| *s_old >= 1);
        let v = &x.path.vertices;
        let VertexKind::Light { light } = v[0].kind else {
            return false;
        };
        let li = light as usize;
        let scene = self.scene;
        let free = [uniform(rng), uniform(rng), uniform(rng), uniform(rng)];
        // Light choice and position have the same conditional law in every chart with s ≥ 1; the
        // emitted direction is determined for s ≥ 2 and free for s = 1.
        let keep_dir = old.is_some_and(|(s_old, _)| (s_old >= 2) == (s >= 2));
        if let Some((_, o)) = old {
            out[..3].copy_from_slice(&o[..3]);
            if keep_dir {
                out[3..5].copy_from_slice(&o[3..5]);
            }
        }
        if !keep_dir {
            if old.is_none() {
                out[0] = scene.light_distribution.invert(li, uniform(rng));
            }
            let l = &scene.lights[li];
            let w = if s >= 2 {
                (v[1].p() - v[0].p()).normalize_or_zero()
            } else {
                v[0].n()
            };
            let Some((u_pos, u_dir)) = l.invert_emission(&scene.bvh.primitives, v[0].p(), w, free)
            else {
                return false;
            };
            if old.is_none() {
                out[1] = u_pos[0];
                out[2] = u_pos[1];
            }
            let u_dir = if s >= 2 { u_dir } else { [free[2], free[3]] };
            out[3] = u_dir[0];
            out[4] = u_dir[1];
        }
        for b in 1..s.saturating_sub(1) {
            let at = LIGHT_BLOCK + (b - 1) * VERTEX_BLOCK;
            if let Some((s_old, o)) = old
                && b + 2 <= s_old
            {
                out[at..at + VERTEX_BLOCK].copy_from_slice(&o[at..at + VERTEX_BLOCK]);
                continue;
            }
            if !Self::invert_scattering(
                &v[b],
                &v[b - 1],
                &v[b + 1],
                &mut out[at..at + VERTEX_BLOCK],
                rng,
            ) {
                return false;
            }
        }
        true
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
        let mut buffers = (Vec::new(), Vec::new());
        if sample_path(self.scene, self.k, self.s, &mut stream, &mut buffers, x).is_none() {
            return false;
        }
        x.evaluate(self.scene, self.importance, 1.0) && x.strategy_importance(self.s) > 0.0
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
        if !(self.ln_density(x) > f64::NEG_INFINITY) || u.len() < self.dim() {
            return false;
        }
        let nc = camera_numbers(self.t());
        let (cam, light) = u.split_at_mut(nc);
        self.invert_camera(x, cam, rng, None) && self.invert_light(x, light, rng, None)
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
        if from.k != self.k
            || u_from.len() < from.dim()
            || u.len() < self.dim()
            || !(self.ln_density(x) > f64::NEG_INFINITY)
        {
            return false;
        }
        let (nc_old, nc) = (camera_numbers(from.t()), camera_numbers(self.t()));
        let (cam, light) = u.split_at_mut(nc);
        self.invert_camera(x, cam, rng, Some((from.t(), &u_from[..nc_old])))
            && self.invert_light(x, light, rng, Some((from.s, &u_from[nc_old..])))
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
