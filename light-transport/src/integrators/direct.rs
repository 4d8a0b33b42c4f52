//! Next-event estimation (Veach & Guibas 1995): one light sample at a surface point, weighted by
//! MIS against BSDF sampling, and its counterpart, emission reached by a BSDF-sampled ray. Shared
//! by path tracing, the direct-lighting pass and the photon mapper's final gather.

use crate::bsdf::{Bsdf, TransportMode};
use crate::geometry::{Hit, SurfaceEnd, SurfacePoint};
use crate::light::LightKind;
use crate::math::DVec3;
use crate::path::MisHeuristic;
use crate::scene::Scene;
use crate::spectrum::Rgb;

/// The MIS weight of a technique of density `a` against one of density `b` (densities times
/// sample counts).
#[inline]
pub fn mis(a: f64, b: f64, h: MisHeuristic) -> f64 {
    match h {
        MisHeuristic::Balance => a / (a + b),
        MisHeuristic::Power => a * a / (a * a + b * b),
    }
}

/// Light arriving at `p` (seen from `wo`, scattered by `bsdf`) from one point sampled on a light
/// chosen with `choice` at `u_light`: `f L_e |cos| w / p`, with the MIS weight `w` against
/// `bsdf_samples` BSDF samples (1 in a path tracer; a final gather's ray count). Point lights get
/// weight 1. Black when the sample is occluded, behind the light or carries nothing.
///
/// `survive` sees the contribution before its shadow ray is traced and returns the factor to scale
/// it by, or `None` to skip the ray (Russian roulette on shadow rays, [`super::ShadowRoulette`];
/// `|_| Some(1.0)` traces every ray).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn next_event(
    scene: &Scene,
    p: &SurfacePoint,
    wo: DVec3,
    bsdf: &Bsdf,
    choice: f64,
    u_light: [f64; 2],
    heuristic: MisHeuristic,
    bsdf_samples: f64,
    survive: impl FnOnce(Rgb) -> Option<f64>,
) -> Rgb {
    let Some((li, p_choice)) = scene.light_distribution.sample(choice) else {
        return Rgb::BLACK;
    };
    let light = &scene.lights[li];
    let Some((lp, ln, pdf_area)) = light.sample_position(&scene.bvh, u_light) else {
        return Rgb::BLACK;
    };
    let d = lp - p.p;
    let dist2 = d.length_squared();
    if !(dist2 > 0.0) {
        return Rgb::BLACK;
    }
    let wi = d / dist2.sqrt();
    let (le, pdf_solid, delta) = match light {
        LightKind::Point { intensity, .. } => (*intensity, p_choice * dist2, true),
        _ => {
            let cos_l = ln.dot(-wi).abs();
            (
                light.radiance(ln, -wi),
                p_choice * pdf_area * dist2 / cos_l,
                false,
            )
        }
    };
    // A sample that carries nothing (the point behind the light) needs no BSDF evaluation.
    if le.is_black() || !pdf_solid.is_finite() || !(pdf_solid > 0.0) {
        return Rgb::BLACK;
    }
    // Value and density from one change of frame, each lobe evaluated once for both.
    let (f, pdf_bsdf) = bsdf.local_pair(wo, wi).map_or((Rgb::BLACK, 0.0), |l| {
        bsdf.eval_pdf_local(l, TransportMode::Radiance)
    });
    if f.is_black() {
        return Rgb::BLACK;
    }
    let w = if delta {
        1.0
    } else {
        mis(pdf_solid, bsdf_samples * pdf_bsdf, heuristic)
    };
    let value = f * le * (wi.dot(p.ns).abs() * w / pdf_solid);
    if value.is_black() {
        return Rgb::BLACK;
    }
    let Some(boost) = survive(value) else {
        return Rgb::BLACK;
    };
    let light_end = match *light {
        LightKind::Area { primitive, .. } => Some(SurfaceEnd { n: ln, primitive }),
        LightKind::Point { .. } => None,
    };
    if !scene.visible(p.p, Some(SurfaceEnd::of(p)), lp, light_end) {
        return Rgb::BLACK;
    }
    value * boost
}

/// Radiance emitted toward `wo` at `hit`, reached by a ray that BSDF sampling drew with solid-angle
/// density `bsdf_pdf`, weighted by MIS against next-event estimation of the same point (`None`:
/// reached by a camera ray or through a delta lobe, which next-event estimation cannot sample;
/// weight 1). Black where `hit` is not on an emitter.
#[inline]
pub fn emitted(
    scene: &Scene,
    hit: &Hit,
    wo: DVec3,
    bsdf_pdf: Option<f64>,
    heuristic: MisHeuristic,
) -> Rgb {
    let p = &hit.point;
    let Some((li, light)) = scene.light_at(p.primitive) else {
        return Rgb::BLACK;
    };
    let le = light.radiance(p.n, wo);
    if le.is_black() {
        return le;
    }
    match bsdf_pdf {
        None => le,
        Some(pdf) => {
            let pdf_light = scene.light_distribution.pdf(li) * light.pdf_position() * hit.t * hit.t
                / p.n.dot(wo).abs();
            le * mis(pdf, pdf_light, heuristic)
        }
    }
}
