//! Multiple importance sampling weights of the bidirectional strategies (Veach 1997 §10.2; the
//! ratio formulation of pbrt-v3's BDPT): the weight of `(s, t)` is
//! `p_{s,t}^β / Σ_i p_{i, k+1−i}^β`, computed from ratios of the forward and reverse area densities
//! stored in the vertices, after recomputing the reverse densities at the connection. No strategy
//! connects at a delta vertex or a point light's position.
//!
//! # Delta directions
//!
//! A direction sampled from a delta lobe has no density, and the strategies that can make a
//! path through a specular vertex `x_m` are those that do not connect at it: each of them has
//! exactly one delta factor from `x_m` in its density, for sampling `x_{m+1}` from the light
//! side or `x_{m−1}` from the camera side, and those factors cancel in every ratio of two such
//! densities (Veach 1997 §10.3.5). What does not cancel is the geometric factor of the edge each
//! sampled: `cos θ_{m+1} / d²(x_m, x_{m+1})` against `cos θ_{m−1} / d²(x_m, x_{m−1})`. So a walk
//! records the solid-angle "density" [`DELTA_DENSITY`] for the direction it took through a delta
//! lobe, and for the reverse direction, and converts both to area densities as any other. pbrt-v3
//! (and this crate until 2026-12) recorded 0 and remapped it to 1 in the ratios, which drops both
//! geometric factors: still unbiased (every strategy computes the same ratios), but the weights
//! then favour the wrong strategy by the ratio of those factors. On `ring` (a reflection caustic
//! seen from close up) that left most of the caustic to camera paths that hit the small light by
//! chance; with the factors, light tracing takes it and BDPT's MSE at equal samples falls 3.9×
//! (`caustic` 2.0×, docs/performance.md). Lobe choice probabilities are left out: a mirror's is
//! 1, and a dielectric's is Fresnel's `F` both ways (the same at both sides of the interface), so
//! for those the factors are exact but for the radiance scaling `η²` of refraction.

use super::connect::EndPairs;
use super::vertex::Vertex;
use crate::scene::Scene;

/// Which heuristic combines the strategies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MisHeuristic {
    /// `β = 1`.
    Balance,
    /// `β = 2` (Veach's recommended default).
    #[default]
    Power,
}

/// The solid-angle "density" a walk records for a direction it took through a delta lobe, and
/// for the reverse direction (module docs, *Delta directions*).
pub const DELTA_DENSITY: f64 = 1.0;

/// pbrt's remapping of a zero density to 1 in the ratios. Since delta directions record
/// [`DELTA_DENSITY`] it no longer meets them; it stays for densities that are 0 otherwise (a
/// direction a BSDF cannot sample back), where it keeps the ratios finite as before.
#[inline]
fn remap(p: f64) -> f64 {
    if p != 0.0 { p } else { 1.0 }
}

/// The MIS weight of strategy `(s, t)` for the path formed by `light[..s]` and `camera[..t]`.
/// Strategies `(0, 2)` and `(1, 1)` alone make paths of one edge; BDPT evaluates only `(0, 2)`
/// there, which then has weight 1 (pbrt's convention). `ends` are the connection's pairs of
/// directions in its ends' BSDF frames ([`crate::path::Connection::ends`]; the default brings
/// them into the frames here): the same weight either way, bit for bit.
pub fn mis_weight(
    scene: &Scene,
    light: &[Vertex],
    camera: &[Vertex],
    s: usize,
    t: usize,
    heuristic: MisHeuristic,
    ends: EndPairs,
) -> f64 {
    if s + t == 2 {
        return 1.0;
    }
    let pow = |r: f64| match heuristic {
        MisHeuristic::Balance => r,
        MisHeuristic::Power => r * r,
    };
    let pt = &camera[t - 1];
    let pt_minus = if t > 1 { Some(&camera[t - 2]) } else { None };
    let qs = if s > 0 { Some(&light[s - 1]) } else { None };
    let qs_minus = if s > 1 { Some(&light[s - 2]) } else { None };
    // Reverse densities at the connection (the other vertices keep the walks' values). Where
    // both densities between the same two neighbours of a vertex are wanted, one call gives
    // both, from the connection's own directions in the BSDF's frame where it has them.
    let (pt_rev, qs_minus_rev) = match (qs, qs_minus) {
        (Some(q), Some(qm)) => {
            let (to_pt, to_qm) = q.pdf_pair(scene, qm, pt, ends.light);
            (to_pt, Some(to_qm))
        }
        (Some(q), None) => (q.pdf(scene, None, pt), None),
        (None, _) => (pt.pdf_light_origin(scene), None),
    };
    let (pt_minus_rev, qs_rev) = match (qs, pt_minus) {
        (Some(q), Some(pm)) => {
            let (to_q, to_pm) = pt.pdf_pair(scene, pm, q, ends.camera);
            (Some(to_pm), Some(to_q))
        }
        (Some(q), None) => (None, Some(pt.pdf(scene, None, q))),
        (None, pm) => (pm.map(|pm| pt.pdf_light(scene, pm)), None),
    };
    // Camera side: vertex i's reverse density (overridden at t−1, t−2) and delta flag (the
    // connection vertex counts as non-delta).
    let cam_rev = |i: usize| {
        if i == t - 1 {
            pt_rev
        } else if i + 2 == t {
            pt_minus_rev.unwrap_or(camera[i].pdf_rev)
        } else {
            camera[i].pdf_rev
        }
    };
    let cam_delta = |i: usize| i + 1 != t && camera[i].delta;
    let light_rev = |i: usize| {
        if i + 1 == s {
            qs_rev.unwrap_or(light[i].pdf_rev)
        } else if i + 2 == s {
            qs_minus_rev.unwrap_or(light[i].pdf_rev)
        } else {
            light[i].pdf_rev
        }
    };
    let light_delta = |i: usize| i + 1 != s && light[i].delta;
    let mut sum = 0.0;
    let mut ri = 1.0;
    for i in (1..t).rev() {
        ri *= remap(cam_rev(i)) / remap(camera[i].pdf_fwd);
        if !cam_delta(i) && !cam_delta(i - 1) {
            sum += pow(ri);
        }
    }
    ri = 1.0;
    let light_is_delta = match light.first().map(|v| v.kind) {
        Some(super::VertexKind::Light { light: l }) => scene.lights[l as usize].is_delta_position(),
        _ => false,
    };
    for i in (0..s).rev() {
        ri *= remap(light_rev(i)) / remap(light[i].pdf_fwd);
        let delta_before = if i > 0 {
            light_delta(i - 1)
        } else {
            light_is_delta
        };
        if !light_delta(i) && !delta_before {
            sum += pow(ri);
        }
    }
    let w = 1.0 / (1.0 + sum);
    if w.is_finite() { w } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::{
        Connection, Subpath, VertexKind, camera_subpath, connect_unoccluded, light_subpath,
    };
    use crate::sampler::IndependentStream;
    use crate::scene::builtin::{BUILTIN, builtin};
    use mcmc_core::rng::stream;

    /// A connection's own pairs of directions in its ends' BSDF frames
    /// (`Connection::ends`) give the MIS weight that the weight computes without them, bit for
    /// bit: on every built-in scene, every strategy with a contribution of 40 pairs of subpaths
    /// of up to 6 vertices each, both heuristics (3 150 weights; 791 strategies have both ends'
    /// pairs). Given each end's pair reversed (a deliberately wrong pair), all 3 150 weights
    /// differ: the comparison can fail.
    /// Every strategy `(s, t)` with a contribution (no visibility test, `s + t ≥ 3`) of `seeds`
    /// pairs of subpaths of up to `vertices` vertices each, drawn from generator stream `key`, on
    /// every built-in scene at 32×24: `visit(scene name, scene, seed, light, camera, s, t,
    /// connection)`.
    fn each_connection(
        seeds: u64,
        key: u64,
        vertices: usize,
        mut visit: impl FnMut(&str, &Scene, u64, &Subpath, &Subpath, usize, usize, &Connection),
    ) {
        let (mut cam, mut light) = (Subpath::new(), Subpath::new());
        for name in BUILTIN {
            let desc = builtin(name).expect("a built-in scene");
            let scene = Scene::new(&desc, Some((32, 24))).expect("a valid scene");
            for seed in 0..seeds {
                let mut a = IndependentStream::new(stream(seed, key));
                camera_subpath(&scene, &mut a, vertices, None, &mut cam);
                light_subpath(&scene, &mut a, vertices, &mut light);
                for t in 1..=cam.len() {
                    for s in 0..=light.len() {
                        if s + t < 3 {
                            continue;
                        }
                        if let Some(c) = connect_unoccluded(&scene, &light, &cam, s, t) {
                            visit(name, &scene, seed, &light, &cam, s, t, &c);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn connection_pairs_give_the_weight_bit_for_bit() {
        let (mut compared, mut both_ends, mut wrong_differs) = (0, 0, 0);
        each_connection(40, 3, 6, |name, scene, _, light, cam, s, t, c| {
            for heuristic in [MisHeuristic::Power, MisHeuristic::Balance] {
                let own = mis_weight(scene, light, cam, s, t, heuristic, c.ends);
                let computed = mis_weight(scene, light, cam, s, t, heuristic, EndPairs::default());
                assert_eq!(own.to_bits(), computed.to_bits(), "{name} s={s} t={t}");
                let reversed = EndPairs {
                    light: c.ends.light.map(|l| l.reversed()),
                    camera: c.ends.camera.map(|l| l.reversed()),
                };
                let wrong = mis_weight(scene, light, cam, s, t, heuristic, reversed);
                wrong_differs += usize::from(wrong.to_bits() != own.to_bits());
                compared += 1;
            }
            both_ends += usize::from(c.ends.light.is_some() && c.ends.camera.is_some());
        });
        assert!(compared > 2000, "{compared} weights compared");
        assert!(both_ends > 500, "{both_ends} strategies with both pairs");
        assert!(
            wrong_differs * 4 > compared,
            "{wrong_differs} of {compared} differ when wrong"
        );
    }

    /// Veach's weight of the strategy with `s` light vertices for the path `x` (light end first),
    /// from scratch: each strategy's density is the product of per-vertex area densities, every
    /// one evaluated afresh from the positions (nothing the walks stored), O(k²). A delta-only
    /// vertex samples its neighbours with [`DELTA_DENSITY`] times their geometric factor
    /// (`geometric = false`: without it, the convention of remapping the densities to 1, to show
    /// that the comparison sees it); no strategy connects at such a vertex, nor at a light of
    /// delta position.
    fn reference_weight(
        scene: &Scene,
        x: &[&Vertex],
        s: usize,
        heuristic: MisHeuristic,
        geometric: bool,
    ) -> f64 {
        let k = x.len() - 1;
        let delta = |j: usize| {
            x[j].bsdf.as_ref().is_some_and(|b| b.is_delta_only())
                && matches!(x[j].kind, VertexKind::Surface)
        };
        let through_delta = |from: usize, to: usize| {
            if geometric {
                x[from].to_area(DELTA_DENSITY, x[to], scene)
            } else {
                1.0
            }
        };
        // Densities of x_j generated from the light side (`fwd`) and from the camera side (`rev`).
        let fwd = |j: usize| match j {
            0 => x[0].pdf_light_origin(scene),
            1 => x[0].pdf_light(scene, x[1]),
            _ if delta(j - 1) => through_delta(j - 1, j),
            _ => x[j - 1].pdf(scene, Some(x[j - 2]), x[j]),
        };
        let rev = |j: usize| {
            if j == k {
                x[k].pdf_fwd
            } else if j + 1 == k {
                x[k].pdf(scene, None, x[j])
            } else if delta(j + 1) {
                through_delta(j + 1, j)
            } else {
                x[j + 1].pdf(scene, Some(x[j + 2]), x[j])
            }
        };
        let delta_light = x[0]
            .emitter(scene)
            .is_some_and(|(_, l)| l.is_delta_position());
        let allowed = |i: usize| {
            if i == 0 {
                !delta_light
            } else {
                !delta(i - 1) && !delta(i)
            }
        };
        let density = |i: usize| -> f64 {
            (0..i).map(fwd).product::<f64>() * (i..=k).map(rev).product::<f64>()
        };
        let pow = |p: f64| match heuristic {
            MisHeuristic::Balance => p,
            MisHeuristic::Power => p * p,
        };
        let sum: f64 = (0..=k)
            .filter(|&i| allowed(i))
            .map(|i| pow(density(i)))
            .sum();
        pow(density(s)) / sum
    }

    /// The weights [`mis_weight`] computes from the walks' stored densities are Veach's, computed
    /// from scratch ([`reference_weight`]), so they sum to one over the strategies of every path,
    /// specular chains included: on every built-in scene, every strategy with a contribution of
    /// 300 pairs of subpaths of up to 7 vertices (paths of 2 to 12 edges whose vertices are
    /// either delta-only or without delta lobes), both heuristics, within 1e-4 relative (the
    /// walks' densities take their directions from the rays, the reference from the positions:
    /// they differ by 1e-9 typically, by up to 5e-5 on `pool`'s interpolated normals): 27 756
    /// weights, 5 858 of paths through mirrors or glass. On those, the weights that drop the
    /// geometric factors of the delta directions (the convention of remapping those densities to
    /// one) differ from these by more than 1e-3 on 2 745: the comparison can fail (and does,
    /// with that convention in the walks: `cornell` 0.0124 against 0.885).
    #[test]
    fn weights_are_veachs_computed_from_scratch() {
        let (mut compared, mut specular, mut remap_differs) = (0, 0, 0);
        each_connection(300, 11, 7, |name, scene, seed, light, cam, s, t, c| {
            let x: Vec<&Vertex> = light[..s].iter().chain(cam[..t].iter().rev()).collect();
            let mixed = x.iter().any(|v| {
                v.bsdf
                    .as_ref()
                    .is_some_and(|b| b.summary().specular && !b.is_delta_only())
            });
            if mixed {
                return;
            }
            let through_specular = x.iter().any(|v| !v.connectible());
            for heuristic in [MisHeuristic::Power, MisHeuristic::Balance] {
                let w = mis_weight(scene, light, cam, s, t, heuristic, c.ends);
                let reference = reference_weight(scene, &x, s, heuristic, true);
                assert!(
                    (w - reference).abs() <= 1e-4 * reference || (w - reference).abs() < 1e-12,
                    "{name} seed {seed} s={s} t={t} {heuristic:?}: {w} against {reference}"
                );
                compared += 1;
                if through_specular {
                    specular += 1;
                    let remapped = reference_weight(scene, &x, s, heuristic, false);
                    remap_differs += usize::from((remapped - reference).abs() > 1e-3 * reference);
                }
            }
        });
        assert!(compared > 20_000, "{compared} weights compared");
        assert!(specular > 500, "{specular} weights of specular paths");
        assert!(
            remap_differs * 4 > specular,
            "{remap_differs} of {specular} differ without the geometric factors"
        );
    }
}
