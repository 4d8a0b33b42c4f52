//! Synthetic manifold walks, for measuring the walk on a scene (the walk columns of Jakob &
//! Marschner 2012, Table 1): chains traced from points on the scene's area lights through ideal
//! specular surfaces to the first non-specular one, each walked to a target displaced on that
//! surface by a small Gaussian offset, then walked back to test reversibility.

use super::chain::{ChainVertex, Interaction, scatter};
use super::walk::{ManifoldSettings, WalkFailure, WalkStats, walk_reversibly};
use crate::geometry::{Ray, offset_origin};
use crate::light::LightKind;
use crate::scene::Scene;
use mcmc_core::rng::{stream, uniform};

/// A chain and the target its end is walked to.
#[derive(Clone, Debug)]
pub struct ProbeCase {
    /// `x_0` on a light, specular vertices, `x_{m+1}` on a non-specular surface.
    pub chain: Vec<ChainVertex>,
    /// A point near `x_{m+1}` on the same material.
    pub target: ChainVertex,
}

/// Up to `n` cases (fewer when the scene has no area light or no specular chain is found in
/// `50 n` attempts): chains of 1 … `max_specular` specular vertices (a dielectric refracts or
/// reflects with probability ½ each), targets displaced tangentially by a Gaussian of standard
/// deviation `sigma` times the scene's diagonal.
pub fn probe_cases(
    scene: &Scene,
    n: usize,
    max_specular: usize,
    sigma: f64,
    seed: u64,
) -> Vec<ProbeCase> {
    let mut rng = stream(seed, 0x3A11);
    let scale = (scene.bounds.1 - scene.bounds.0).length();
    let mut out = Vec::new();
    for _ in 0..50 * n {
        if out.len() >= n {
            break;
        }
        let Some((li, _)) = scene.light_distribution.sample(uniform(&mut rng)) else {
            break;
        };
        let light = &scene.lights[li];
        let LightKind::Area { primitive, .. } = *light else {
            continue;
        };
        let Some((point, _)) =
            light.sample_point(&scene.bvh, [uniform(&mut rng), uniform(&mut rng)])
        else {
            continue;
        };
        let Some((mut dir, _)) =
            light.sample_direction(point.n, [uniform(&mut rng), uniform(&mut rng)])
        else {
            continue;
        };
        let start = ChainVertex::new(
            scene,
            point,
            scene.primitive_material[primitive as usize],
            Interaction::Reflect,
            [0.0; 2],
        );
        let mut chain = vec![start];
        let mut origin = offset_origin(point.p, point.n, dir);
        let end = loop {
            let Some(hit) = scene.intersect(&Ray::new(origin, dir)) else {
                break None;
            };
            let material = scene.primitive_material[hit.point.primitive as usize];
            let Ok(bsdf) = scene.bsdf(&hit.point) else {
                break None;
            };
            let mut v =
                ChainVertex::new(scene, hit.point, material, Interaction::Reflect, [0.0; 2]);
            if !bsdf.is_delta_only() {
                break Some(v);
            }
            if chain.len() > max_specular {
                break None;
            }
            let wi = -dir;
            let refract = bsdf.eta().is_some() && uniform(&mut rng) < 0.5;
            if let (true, Some(eta)) = (refract, bsdf.eta()) {
                v.interaction = Interaction::Refract { eta };
            }
            let Some(h) = v.half_vector(wi) else {
                break None;
            };
            let Some(wo) = scatter(wi, h, v.relative_eta(wi), refract, v.point.n) else {
                break None;
            };
            origin = offset_origin(v.p(), v.point.n, wo);
            dir = wo;
            chain.push(v);
        };
        let Some(end) = end else { continue };
        if chain.len() < 2 {
            continue;
        }
        chain.push(end);
        // The target: a tangential Gaussian offset, projected back onto the surface.
        let (e1, e2) = end.tangent_basis();
        let mut gauss = || {
            let (u1, u2) = (uniform(&mut rng), uniform(&mut rng));
            (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        };
        let p = end.p() + (e1 * gauss() + e2 * gauss()) * (sigma * scale);
        // Cast toward `p` obliquely from above the surface (exactly axis-aligned rays can slip
        // through flat BVH nodes; see the README's note on the manifold probe).
        let from = p + (end.point.n + e1 * 0.3) * (1e-3 * scale);
        let Some(hit) = scene.intersect(&Ray::new(from, (p - from).normalize())) else {
            continue;
        };
        let material = scene.primitive_material[hit.point.primitive as usize];
        if material != end.material || (hit.point.p - p).length() > 1e-6 * scale {
            continue;
        }
        out.push(ProbeCase {
            chain,
            target: ChainVertex::new(scene, hit.point, end.material, end.interaction, end.offset),
        });
    }
    out
}

/// Statistics of walking every case to its target and, when that succeeds, back
/// ([`walk_reversibly`]: `non_reversible` counts converged walks that did not return).
pub fn probe(scene: &Scene, cases: &[ProbeCase], settings: &ManifoldSettings) -> WalkStats {
    let mut stats = WalkStats::default();
    for case in cases {
        walk_reversibly(scene, &case.chain, &case.target, settings, &mut stats);
    }
    stats
}

/// The failure counts of `stats` as `cause n, …`.
pub fn failures(stats: &WalkStats) -> String {
    WalkFailure::ALL
        .iter()
        .zip(stats.failures)
        .map(|(f, n)| format!("{} {n}", f.name()))
        .collect::<Vec<_>>()
        .join(", ")
}
