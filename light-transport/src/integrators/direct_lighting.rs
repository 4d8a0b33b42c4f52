//! Direct lighting alone: every path of one edge (an emitter seen directly) and of two edges, the
//! pass that renders them apart from a Metropolis method's chains
//! ([`crate::metropolis::SeparateDirect`]).
//!
//! At a surface with a non-delta lobe, next-event estimation and BSDF sampling combined by MIS
//! (Veach & Guibas 1995), as in path tracing. At a surface with delta lobes only (mirror, glass,
//! water) every lobe is followed (splitting) instead of one chosen at random: the expected value
//! over the lobe choice, so an emitter seen in such a surface costs no lobe-choice noise. (Chosen
//! at random, the reflection of a lamp in water is found once in `1/F` samples, `F` ≈ 0.02, with
//! weight `1/F`: at 16 samples per pixel a handful of fireflies on `pool`.)

use super::direct::{emitted, next_event};
use super::{Estimator, Splat};
use crate::bsdf::TransportMode;
use crate::geometry::Ray;
use crate::path::{MisHeuristic, camera_ray};
use crate::sampler::{CAMERA_STREAM, PixelStream, SampleStream, TECHNIQUE_STREAM, layout};
use crate::scene::Scene;
use crate::spectrum::Rgb;

/// The direct-lighting estimator (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectLighting {
    /// MIS heuristic between light and BSDF sampling.
    pub heuristic: MisHeuristic,
}

impl Estimator for DirectLighting {
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
        let Some(hit) = scene.intersect(&cs.ray) else {
            return Rgb::BLACK;
        };
        let p = &hit.point;
        let wo = -cs.ray.d;
        // One edge: the emitter seen directly.
        let mut l = emitted(scene, &hit, wo, None, self.heuristic);
        let mut slot = None;
        scene.bsdf_into(p, &mut slot);
        let Some(bsdf) = slot.as_ref() else {
            return l;
        };
        let mode = TransportMode::Radiance;
        // Two edges.
        if bsdf.is_delta_only() {
            for transmit in [false, true] {
                let Some(s) = bsdf
                    .delta_direction(wo, transmit, mode)
                    .and_then(|wi| bsdf.eval_delta(wo, wi, mode))
                else {
                    continue;
                };
                // The lobe's probability times its sample's weight `f |cos| / probability`.
                let ray = Ray::leaving(p, s.wi);
                if let Some(next) = scene.intersect(&ray) {
                    let le = emitted(scene, &next, -s.wi, None, self.heuristic);
                    l += s.f * le * s.wi.dot(p.ns).abs();
                }
            }
            return l;
        }
        stream.start_stream(TECHNIQUE_STREAM);
        let choice = stream.next_1d();
        let u_light = stream.next_2d();
        l += next_event(
            scene,
            p,
            wo,
            bsdf,
            choice,
            u_light,
            self.heuristic,
            1.0,
            |_| Some(1.0),
        );
        let block = layout::camera_vertex(1);
        stream.start_stream(CAMERA_STREAM);
        stream.seek(block + layout::LOBE);
        let u_lobe = stream.next_1d();
        stream.seek(block + layout::DIRECTION);
        let u = stream.next_2d();
        let Some(bs) = bsdf.sample(wo, u_lobe, u, mode) else {
            return l;
        };
        if bs.pdf == 0.0 || bs.f.is_black() {
            return l;
        }
        let ray = Ray::leaving(p, bs.wi);
        if let Some(next) = scene.intersect(&ray) {
            let le = emitted(
                scene,
                &next,
                -bs.wi,
                (!bs.delta).then_some(bs.pdf),
                self.heuristic,
            );
            l += bs.f * le * (bs.wi.dot(p.ns).abs() / bs.pdf);
        }
        l
    }
    fn splats(&self) -> bool {
        false
    }
}
