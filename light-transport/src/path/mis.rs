//! Multiple importance sampling weights of the bidirectional strategies (Veach 1997 §10.2; the
//! ratio formulation of pbrt-v3's BDPT): the weight of `(s, t)` is
//! `p_{s,t}^β / Σ_i p_{i, k+1−i}^β`, computed from ratios of the forward and reverse area densities
//! stored in the vertices, after recomputing the reverse densities at the connection. Delta
//! densities are remapped to 1 and no strategy connects at a delta vertex or a point light's
//! position.

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
    use crate::path::{Subpath, camera_subpath, connect_unoccluded, light_subpath};
    use crate::sampler::IndependentStream;
    use crate::scene::builtin::{BUILTIN, builtin};
    use mcmc_core::rng::stream;

    /// A connection's own pairs of directions in its ends' BSDF frames
    /// (`Connection::ends`) give the MIS weight that the weight computes without them, bit for
    /// bit: on every built-in scene, every strategy with a contribution of 40 pairs of subpaths
    /// of up to 6 vertices each, both heuristics (3 150 weights; 791 strategies have both ends'
    /// pairs). Given each end's pair reversed (a deliberately wrong pair), all 3 150 weights
    /// differ: the comparison can fail.
    #[test]
    fn connection_pairs_give_the_weight_bit_for_bit() {
        let (mut cam, mut light) = (Subpath::new(), Subpath::new());
        let (mut compared, mut both_ends, mut wrong_differs) = (0, 0, 0);
        for name in BUILTIN {
            let desc = builtin(name).expect("a built-in scene");
            let scene = Scene::new(&desc, Some((32, 24))).expect("a valid scene");
            for seed in 0..40 {
                let mut a = IndependentStream::new(stream(seed, 3));
                camera_subpath(&scene, &mut a, 6, None, &mut cam);
                light_subpath(&scene, &mut a, 6, &mut light);
                for t in 1..=cam.len() {
                    for s in 0..=light.len() {
                        if s + t < 3 {
                            continue;
                        }
                        let Some(c) = connect_unoccluded(&scene, &light, &cam, s, t) else {
                            continue;
                        };
                        for heuristic in [MisHeuristic::Power, MisHeuristic::Balance] {
                            let own = mis_weight(&scene, &light, &cam, s, t, heuristic, c.ends);
                            let computed = mis_weight(
                                &scene,
                                &light,
                                &cam,
                                s,
                                t,
                                heuristic,
                                EndPairs::default(),
                            );
                            assert_eq!(own.to_bits(), computed.to_bits(), "{name} s={s} t={t}");
                            let reversed = EndPairs {
                                light: c.ends.light.map(|l| l.reversed()),
                                camera: c.ends.camera.map(|l| l.reversed()),
                            };
                            let wrong = mis_weight(&scene, &light, &cam, s, t, heuristic, reversed);
                            wrong_differs += usize::from(wrong.to_bits() != own.to_bits());
                            compared += 1;
                        }
                        both_ends += usize::from(c.ends.light.is_some() && c.ends.camera.is_some());
                    }
                }
            }
        }
        assert!(compared > 2000, "{compared} weights compared");
        assert!(both_ends > 500, "{both_ends} strategies with both pairs");
        assert!(
            wrong_differs * 4 > compared,
            "{wrong_differs} of {compared} differ when wrong"
        );
    }
}
