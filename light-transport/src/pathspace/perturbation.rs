//! What the perturbations of Veach & Guibas (1997, §5.3; practical-MLT paper §3.4 and eqs. 4–5)
//! share: their offset parameters, the structure they follow through a path's specular chains,
//! and their densities. The **lens** and **multi-chain** perturbations ([`super::lens`],
//! [`super::multi_chain`]) move the eye end of the path, the **caustic** perturbation
//! ([`super::caustic`]) the light end. Each offsets one direction by a small random amount,
//! propagates it through the path's specular chain with the same reflection/refraction at every
//! specular vertex, and reconnects to the unchanged rest. The path keeps its structure, so the
//! reverse move is the same perturbation.
//!
//! **Densities.** Write `s` for the strategy whose light subpath is the kept part (`s = j` for the
//! camera-side perturbations, `s = k` — a `t = 1` connection — for the caustic perturbation). The
//! generated vertices have the density `p_s` of that strategy's other subpath, except that (a) the
//! first direction comes from a symmetric offset `g` instead of the endpoint's distribution, (b)
//! specular vertices are followed deterministically, without the probability `P` of choosing their
//! lobe, and (c) every re-perturbed direction (multi-chain, caustic) comes from a symmetric angular
//! offset `g_θ` instead of the BSDF density `p_σ`. In the common measure of [`super::mutation`]
//! this gives
//!
//! `T̃(ȳ|x̄) = g · Π g_θ / (p_first · I(C*_s(ȳ)) Π P(ȳ) Π p_σ(ȳ))`,
//!
//! with `p_first` the density of the first direction in the strategy (`1/(W H)` per pixel² for the
//! image position; `p_σ` of the light or BSDF for the caustic), so that
//! `a(ȳ|x̄) = min(1, [I(C*_s(ȳ)) Π P(ȳ) Π p_σ(ȳ)] / [I(C*_s(x̄)) Π P(x̄) Π p_σ(x̄)])` — the exact form
//! of the practical-MLT paper's ratios (its `cos φ` factors are `p_σ` of a Lambertian surface or
//! emitter; its `d²/cos` factors are inside `C*`).

use super::path::FullPath;
use super::state::PathState;
use super::walk::{angular_offset, exponential_radius_pdf, pixel_offset, trace_between};
use crate::bsdf::TransportMode;
use crate::math::DVec3;
use crate::metropolis::ImportanceKind;
use crate::path::{Vertex, VertexKind};
use crate::scene::Scene;
use mcmc_core::{ChainRng, Failure};
use std::f64::consts::TAU;

/// Offset parameters of the perturbations (defaults: the practical-MLT paper, appendices B–C).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PerturbationSettings {
    /// Smallest pixel offset, in pixels (0.1).
    pub r1: f64,
    /// Largest pixel offset as a fraction of the image width (0.1).
    pub r2_fraction: f64,
    /// Smallest angular offset, radians (1e-4).
    pub theta1: f64,
    /// Largest angular offset, radians (0.1).
    pub theta2: f64,
}

impl Default for PerturbationSettings {
    fn default() -> Self {
        Self {
            r1: 0.1,
            r2_fraction: 0.1,
            theta1: 1e-4,
            theta2: 0.1,
        }
    }
}

impl PerturbationSettings {
    /// `r2` in pixels for `scene`.
    pub fn r2(&self, scene: &Scene) -> f64 {
        (self.r2_fraction * scene.camera.width as f64).max(self.r1 * 1.000_001)
    }

    /// Check the parameters.
    pub fn validate(&self) -> crate::Result<()> {
        let ok = self.r1 > 0.0
            && self.r1.is_finite()
            && self.r2_fraction > 0.0
            && self.r2_fraction.is_finite()
            && self.theta1 > 0.0
            && self.theta2 > self.theta1
            && self.theta2 < std::f64::consts::PI;
        if ok {
            Ok(())
        } else {
            Err(crate::Error::InvalidParameter {
                name: "perturbation radii".into(),
                reason: format!(
                    "need r1 > 0, r2 > 0 and 0 < θ1 < θ2 < π, got r1 = {}, r2 = {} × width, θ1 = {}, θ2 = {}",
                    self.r1, self.r2_fraction, self.theta1, self.theta2
                ),
            })
        }
    }

    /// Density per pixel² of a pixel offset by `r` pixels.
    pub fn pixel_offset_pdf(&self, scene: &Scene, r: f64) -> f64 {
        exponential_radius_pdf(r, self.r1, self.r2(scene)) / (TAU * r)
    }

    /// Density per steradian of an angular offset turning `a` into `b`.
    pub fn angular_offset_pdf(&self, a: DVec3, b: DVec3) -> f64 {
        super::walk::angular_offset_pdf(a, b, self.theta1, self.theta2)
    }
}

/// Unit direction from vertex `a` to vertex `b`.
#[inline]
pub fn direction(a: &Vertex, b: &Vertex) -> DVec3 {
    (b.p() - a.p()).normalize_or_zero()
}

/// Whether the specular vertex `i` of `path` refracts (its neighbours lie on opposite sides).
pub fn refracts(path: &FullPath, i: usize) -> bool {
    let v = &path.vertices[i];
    let n = v.n();
    let a = direction(v, &path.vertices[i - 1]).dot(n);
    let b = direction(v, &path.vertices[i + 1]).dot(n);
    a * b < 0.0
}

/// Probability that vertex `v`'s BSDF picks the delta lobe the path uses, sampling from the side
/// of `from` toward `to` (0 when no delta lobe produces it).
pub fn branch_probability(v: &Vertex, from: &Vertex, to: &Vertex, mode: TransportMode) -> f64 {
    v.bsdf
        .as_ref()
        .and_then(|b| b.eval_delta(direction(v, from), direction(v, to), mode))
        .map_or(0.0, |d| d.pdf)
}

/// BSDF density (solid angle) at `v` of leaving toward `to` having arrived from `from`.
pub fn bsdf_pdf(v: &Vertex, from: &Vertex, to: &Vertex) -> f64 {
    v.bsdf
        .as_ref()
        .map_or(0.0, |b| b.pdf(direction(v, from), direction(v, to)))
}

/// Whether vertex `v` has a non-delta component (a perturbed chain may end or turn there).
pub fn scatters_diffusely(v: &Vertex) -> bool {
    v.bsdf.as_ref().is_some_and(|b| !b.is_delta_only())
}

/// Whether `v` only scatters specularly (every lobe of its BSDF is a delta lobe).
pub fn specular_only(v: &Vertex) -> bool {
    v.bsdf.as_ref().is_some_and(|b| b.is_delta_only())
}

/// Whether two paths follow the same specular structure over vertices `range`: the same vertices
/// are specular, and those reflect or refract alike.
pub fn same_specular_structure(x: &FullPath, y: &FullPath, range: std::ops::Range<usize>) -> bool {
    range.into_iter().all(|i| {
        x.specular(i) == y.specular(i) && (!x.specular(i) || refracts(x, i) == refracts(y, i))
    })
}

/// `ln Π P` of `y`'s specular vertices in `range`, sampled walking toward lower indices
/// (`toward_light`, camera walks) or higher ones (light walks); `−∞` when one cannot be made.
pub fn ln_branch_probabilities(
    y: &FullPath,
    range: std::ops::Range<usize>,
    toward_light: bool,
    mode: TransportMode,
) -> f64 {
    let v = &y.vertices;
    range
        .filter(|&i| y.specular(i))
        .map(|i| {
            let p = if toward_light {
                branch_probability(&v[i], &v[i + 1], &v[i - 1], mode)
            } else {
                branch_probability(&v[i], &v[i - 1], &v[i + 1], mode)
            };
            if p > 0.0 { p.ln() } else { f64::NEG_INFINITY }
        })
        .sum()
}

/// Follow the specular vertex `i` of `x` with the new vertex `v` the walk hit: the same lobe type
/// (reflection or refraction); the direction leaving `v`.
pub fn follow_specular(
    v: &mut Vertex,
    x: &FullPath,
    i: usize,
    mode: TransportMode,
) -> Result<DVec3, Failure> {
    let b = v.bsdf.as_ref().ok_or(Failure::Failed)?;
    let wi = b
        .delta_direction(v.wo, refracts(x, i), mode)
        .ok_or(Failure::Failed)?;
    v.delta = true;
    Ok(wi)
}

/// Which camera-side perturbation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraSide {
    /// Lens perturbation: only paths `(L|D) D S* E` (the first non-specular vertex from the eye
    /// connects to a non-specular vertex or the light).
    Lens,
    /// Multi-chain perturbation: further specular chains are followed after angular offsets of
    /// the direction leaving each non-specular vertex, until two non-specular vertices meet.
    MultiChain,
}

/// What a camera-side perturbation does to a path: it regenerates `v_s … v_{k−1}` (keeping the
/// light part `v_0 … v_{s−1}` and the lens point) and re-offsets the direction leaving each vertex
/// of `turns` (non-specular vertices followed by a specular one; multi-chain only).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CameraChain {
    /// First regenerated vertex; its light-side neighbour is kept.
    pub s: usize,
    /// Vertices where the direction turns by an angular offset (descending).
    pub turns: Vec<usize>,
}

impl CameraChain {
    /// The record of the change.
    pub fn change(&self, k: usize) -> super::mutation::Change {
        super::mutation::Change {
            l: self.s as isize - 1,
            m: k,
            added: k - self.s,
            pivot: 0,
        }
    }
}

/// Whether a path could be reached by propagation ending at the light: `v_0` must be an area light.
fn hittable_light(scene: &Scene, x: &FullPath) -> bool {
    match x.vertices[0].kind {
        VertexKind::Light { light } => !scene.lights[light as usize].is_delta_position(),
        _ => false,
    }
}

/// The chain a camera-side perturbation follows on `x`, when it applies.
pub fn camera_chain(scene: &Scene, which: CameraSide, x: &FullPath) -> Option<CameraChain> {
    let k = x.edges();
    if k < 1 {
        return None;
    }
    let mut turns = Vec::new();
    let mut i = k - 1;
    loop {
        if x.specular(i) {
            i = i.checked_sub(1)?;
            continue;
        }
        if i == 0 {
            // The chain ends on the light: the camera walk must be able to hit it.
            return hittable_light(scene, x).then_some(CameraChain { s: 0, turns });
        }
        if !scatters_diffusely(&x.vertices[i]) {
            return None;
        }
        if !x.specular(i - 1) {
            return Some(CameraChain { s: i, turns });
        }
        if which == CameraSide::Lens {
            return None;
        }
        turns.push(i);
        i -= 1;
    }
}

/// The camera-side chain of `x` when the perturbation can move it: the path carries its
/// strategy's light, its specular branches can be chosen and its turns sampled.
pub fn camera_chain_of(scene: &Scene, which: CameraSide, x: &PathState) -> Option<CameraChain> {
    let c = camera_chain(scene, which, &x.path)?;
    let v = &x.path.vertices;
    let k = x.path.edges();
    let ok = x.strategy_importance(c.s) > 0.0
        && x.raster().is_some()
        && ln_branch_probabilities(&x.path, c.s + 1..k, true, TransportMode::Radiance)
            > f64::NEG_INFINITY
        && c.turns
            .iter()
            .all(|&i| bsdf_pdf(&v[i], &v[i + 1], &v[i - 1]) > 0.0);
    ok.then_some(c)
}

/// A lens or multi-chain perturbation of `x` into `y` (evaluated, with its record).
pub fn camera_side_propose(
    scene: &Scene,
    which: CameraSide,
    settings: &PerturbationSettings,
    importance: ImportanceKind,
    x: &PathState,
    rng: &mut ChainRng,
    y: &mut PathState,
) -> Result<(), Failure> {
    let chain = camera_chain_of(scene, which, x).ok_or(Failure::NotApplicable)?;
    let xp = &x.path;
    let k = xp.edges();
    let raster = x.raster().ok_or(Failure::NotApplicable)?;
    let moved = pixel_offset(raster, settings.r1, settings.r2(scene), rng);
    let cs = scene
        .camera
        .ray_through(xp.lens().p(), moved)
        .ok_or(Failure::Failed)?;
    // ȳ is walked in place: it keeps x̄'s light part v_0 … v_{s−1} and lens point, and
    // v'_{k−1}, v'_{k−2}, … v'_s are traced into their slots from the lens (each trace rewrites
    // its slot whole, so the vertices it replaces are not copied first).
    y.path.splice_from(xp, chain.s, k + 1, 1);
    let yv = &mut y.path.vertices;
    let mut w = cs.ray.d;
    let mut i = k - 1;
    loop {
        if !trace_between(scene, yv, i + 1, i, w) {
            return Err(Failure::Failed);
        }
        let v = &mut yv[i];
        if xp.specular(i) {
            w = follow_specular(v, xp, i, TransportMode::Radiance)?;
            i -= 1;
            continue;
        }
        if i == 0 {
            // The chain ends on the light: the hit must be an area light (strategy s = 0).
            let (li, light) = scene.light_at(v.point.primitive).ok_or(Failure::Failed)?;
            if light.is_delta_position() {
                return Err(Failure::Failed);
            }
            v.kind = VertexKind::Light { light: li as u32 };
            break;
        }
        if !scatters_diffusely(v) {
            return Err(Failure::Failed);
        }
        if i == chain.s {
            break;
        }
        // Multi-chain: offset the direction leaving this vertex toward the next chain.
        let w_x = direction(&xp.vertices[i], &xp.vertices[i - 1]);
        w = angular_offset(w_x, settings.theta1, settings.theta2, rng);
        i -= 1;
    }
    y.finish_candidate(scene, importance, x, chain.change(k), chain.s);
    Ok(())
}

/// `ln T̃` of a camera-side perturbation making `y` from `x` with record `c` (module docs).
pub fn camera_side_density(
    scene: &Scene,
    which: CameraSide,
    settings: &PerturbationSettings,
    x: &PathState,
    y: &PathState,
    c: super::mutation::Change,
) -> f64 {
    let never = f64::NEG_INFINITY;
    let Some(chain) = camera_chain_of(scene, which, x) else {
        return never;
    };
    let (xp, yp) = (&x.path, &y.path);
    let k = xp.edges();
    let s = chain.s;
    if yp.edges() != k || c != chain.change(k) || !same_specular_structure(xp, yp, s + 1..k) {
        return never;
    }
    let yv = &yp.vertices;
    let end_ok = if s == 0 {
        hittable_light(scene, yp)
    } else {
        scatters_diffusely(&yv[s]) && !yp.specular(s)
    };
    if !end_ok || !chain.turns.iter().all(|&i| scatters_diffusely(&yv[i])) {
        return never;
    }
    let (Some(rx), Some(ry)) = (x.raster(), y.raster()) else {
        return never;
    };
    let r = ((ry[0] - rx[0]).powi(2) + (ry[1] - rx[1]).powi(2)).sqrt();
    let g = settings.pixel_offset_pdf(scene, r);
    let i_s = y.strategy_importance(s);
    if !(g > 0.0 && i_s > 0.0) {
        return never;
    }
    let pixels = (scene.camera.width * scene.camera.height) as f64;
    let mut ln = g.ln() + pixels.ln()
        - i_s.ln()
        - ln_branch_probabilities(yp, s + 1..k, true, TransportMode::Radiance);
    let xv = &xp.vertices;
    for &i in &chain.turns {
        let g_theta = settings
            .angular_offset_pdf(direction(&xv[i], &xv[i - 1]), direction(&yv[i], &yv[i - 1]));
        let p_sigma = bsdf_pdf(&yv[i], &yv[i + 1], &yv[i - 1]);
        if !(g_theta > 0.0 && p_sigma > 0.0) {
            return never;
        }
        ln += g_theta.ln() - p_sigma.ln();
    }
    if ln.is_nan() { never } else { ln }
}
