//! Path tracing with next-event estimation, combining BSDF and light sampling of emitters by MIS
//! (Veach & Guibas 1995), with optional Russian roulette on the path (the subpath walks' rule,
//! [`Roulette::continuation`]) and on the shadow rays of next-event estimation
//! ([`super::shadow_roulette`]). Written independently of the bidirectional path machinery so the
//! two check each other.

use super::direct::{emitted, next_event};
use super::shadow_roulette::ShadowRoulette;
use super::{Estimator, Splat};
use crate::bsdf::TransportMode;
use crate::geometry::Ray;
use crate::path::{MisHeuristic, Roulette, camera_ray};
use crate::sampler::{CAMERA_STREAM, PixelStream, SampleStream, TECHNIQUE_STREAM, layout};
use crate::scene::Scene;
use crate::spectrum::Rgb;

/// Path tracing settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathTracer {
    /// Maximum number of edges of a path (pbrt's `maxdepth + 1`).
    pub max_edges: usize,
    /// MIS heuristic for emitters.
    pub heuristic: MisHeuristic,
    /// Russian roulette from this vertex of the path on (1: the first surface vertex; `None`:
    /// every path runs to `max_edges`). At vertex `b` the path continues with the probability
    /// [`Roulette::continuation`] of its throughput without the radiance compression of its
    /// refractions ([`crate::bsdf::Bsdf::radiance_compression`]), read from the vertex block's
    /// roulette number.
    pub roulette_from: Option<usize>,
    /// Russian roulette on the shadow rays of next-event contributions below its threshold
    /// (`None`: every shadow ray is traced).
    pub shadow_roulette: Option<ShadowRoulette>,
}

impl Default for PathTracer {
    /// Paths of up to 9 edges (pbrt's default `maxdepth` 8), power heuristic, no Russian
    /// roulette (as the CLI's default).
    fn default() -> Self {
        Self {
            max_edges: 9,
            heuristic: MisHeuristic::Power,
            roulette_from: None,
            shadow_roulette: None,
        }
    }
}

impl Estimator for PathTracer {
    fn sample(
        &self,
        scene: &Scene,
        pixel: usize,
        stream: &mut PixelStream,
        _splats: &mut Vec<Splat>,
    ) -> Rgb {
        let cs = camera_ray(scene, stream, Some(pixel));
        if cs.we == 0.0 {
            return Rgb::BLACK;
        }
        let mut ray = cs.ray;
        let mut beta = Rgb::WHITE;
        let mut l = Rgb::BLACK;
        let mut last_pdf = 0.0;
        let mut specular = true;
        // The radiance compression of the refractions so far, divided out of the throughput
        // that Russian roulette looks at ([`crate::bsdf::Bsdf::radiance_compression`]).
        let mut compression = 1.0;
        // Each vertex's BSDF is built in this one slot (no BSDF moved per bounce).
        let mut slot = None;
        for bounces in 0..self.max_edges {
            // Bound in place: moving the hit out of its `Option` copied it per bounce.
            let found = scene.intersect(&ray);
            let Some(hit) = &found else {
                break;
            };
            let p = &hit.point;
            let wo = -ray.d;
            // Emission reached by the path: `bounces + 1` edges.
            l += beta
                * emitted(
                    scene,
                    hit,
                    wo,
                    (!specular).then_some(last_pdf),
                    self.heuristic,
                );
            if bounces + 2 > self.max_edges {
                break;
            }
            scene.bsdf_into(p, &mut slot);
            let Some(bsdf) = slot.as_ref() else { break };
            // Next-event estimation: a path of `bounces + 2` edges.
            stream.start_stream(TECHNIQUE_STREAM);
            let choice = stream.next_1d();
            let u_light = stream.next_2d();
            if !bsdf.is_delta_only() {
                let survive = |c: Rgb| match self.shadow_roulette {
                    Some(r) => r.survive((beta * c).luminance(), stream.rng()),
                    None => Some(1.0),
                };
                l += beta
                    * next_event(
                        scene,
                        p,
                        wo,
                        bsdf,
                        choice,
                        u_light,
                        self.heuristic,
                        1.0,
                        survive,
                    );
            }
            // Continue by BSDF sampling from this vertex's block.
            // Vertex `bounces + 1` of the camera subpath.
            let block = layout::camera_vertex(bounces + 1);
            stream.start_stream(CAMERA_STREAM);
            stream.seek(block + layout::LOBE);
            let u_lobe = stream.next_1d();
            stream.seek(block + layout::DIRECTION);
            let u = stream.next_2d();
            if let Some(from) = self.roulette_from
                && bounces + 1 >= from
            {
                stream.seek(block + layout::ROULETTE);
                let q = Roulette::continuation(beta / compression, Rgb::WHITE);
                if !(stream.next_1d() < q) {
                    break;
                }
                beta = beta / q;
            }
            let Some(bs) = bsdf.sample(wo, u_lobe, u, TransportMode::Radiance) else {
                break;
            };
            if bs.pdf == 0.0 || bs.f.is_black() {
                break;
            }
            beta *= bs.f * (bs.wi.dot(p.ns).abs() / bs.pdf);
            if self.roulette_from.is_some() {
                compression *= bsdf.radiance_compression(wo, bs.wi);
            }
            specular = bs.delta;
            last_pdf = bs.pdf;
            if !beta.is_finite() {
                break;
            }
            ray = Ray::leaving(p, bs.wi);
        }
        l
    }
    fn splats(&self) -> bool {
        false
    }
}
