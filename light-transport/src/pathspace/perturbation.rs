//! The perturbations of Veach & Guibas (1997, §5.3; practical-MLT paper §3.4 and eqs. 4–5):
//! **lens**, **multi-chain** and **caustic** perturbations. Each moves one end of the path by a
//! small random offset, propagates the move through the path's specular chain with the same
//! reflection/refraction at every specular vertex, and reconnects to the unchanged rest of the
//! path. The path keeps its structure, so the reverse move is the same perturbation.
//!
//! Transition densities. Write `s` for the strategy whose light subpath is the kept part (`s = j`
//! for the camera-side perturbations, `s = k` — a `t = 1` connection — for the caustic
//! perturbation). The generated vertices have the density `p_s` of that strategy's other subpath,
//! except that (a) the first direction comes from a symmetric offset instead of the endpoint's
//! distribution, (b) specular vertices are followed deterministically, without the probability
//! `P` of choosing their lobe, and (c) every re-perturbed direction (multi-chain, caustic) comes
//! from a symmetric angular offset instead of the BSDF density `p_σ`. With `f / p_s = C*_s`,
//!
//! `a(ȳ|x̄) = min(1, [I(C*_s(ȳ)) Π P(ȳ) Π p_σ(ȳ)] / [I(C*_s(x̄)) Π P(x̄) Π p_σ(x̄)])`,
//!
//! the exact form of the practical-MLT paper's ratios (its `cos φ` factors are `p_σ` of a
//! Lambertian surface or emitter; its `d²/cos` factors are inside `C*`).

use super::path::FullPath;
use super::state::PathState;
use super::walk::{angular_offset, pixel_offset, trace};
use crate::bsdf::TransportMode;
use crate::math::DVec3;
use crate::metropolis::ImportanceKind;
use crate::path::{Vertex, VertexKind};
use crate::scene::Scene;
use mcmc_core::{ChainRng, Failure};

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

/// Probability that vertex `i`'s BSDF picks the delta lobe the path uses, sampling from the side
/// of `from` toward `to` (`None` when no delta lobe produces it).
fn branch_probability(v: &Vertex, from: &Vertex, to: &Vertex, mode: TransportMode) -> Option<f64> {
    let b = v.bsdf.as_ref()?;
    b.eval_delta(direction(v, from), direction(v, to), mode)
        .map(|d| d.pdf)
        .filter(|p| *p > 0.0)
}

/// BSDF density (solid angle) at `v` of leaving toward `to` having arrived from `from`.
fn bsdf_pdf(v: &Vertex, from: &Vertex, to: &Vertex) -> f64 {
    v.bsdf
        .as_ref()
        .map_or(0.0, |b| b.pdf(direction(v, from), direction(v, to)))
}

/// Follow the specular vertex `old` (of the current path) with the new vertex `v` hit by the
/// walk: same lobe type (reflection or refraction). Returns the new outgoing direction and the
/// log branch probabilities `(ln P(ȳ), ln P(x̄))`, or why it failed.
fn follow_specular(
    v: &mut Vertex,
    x: &FullPath,
    i: usize,
    toward_lower: bool,
    mode: TransportMode,
) -> Result<(DVec3, f64, f64), Failure> {
    let b = v.bsdf.as_ref().ok_or(Failure::Failed)?;
    let wi = b
        .delta_direction(v.wo, refracts(x, i), mode)
        .ok_or(Failure::Failed)?;
    let p_y = b
        .eval_delta(v.wo, wi, mode)
        .map(|d| d.pdf)
        .filter(|p| *p > 0.0)
        .ok_or(Failure::Failed)?;
    let (from, to) = if toward_lower {
        (&x.vertices[i + 1], &x.vertices[i - 1])
    } else {
        (&x.vertices[i - 1], &x.vertices[i + 1])
    };
    let p_x = branch_probability(&x.vertices[i], from, to, mode).ok_or(Failure::NotApplicable)?;
    v.delta = true;
    Ok((wi, p_y.ln(), p_x.ln()))
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

/// Index of the first non-specular vertex counting from the eye (`v_{k−1}` down to `v_0`).
pub fn first_non_specular_from_eye(x: &FullPath) -> usize {
    let k = x.edges();
    (1..k).rev().find(|&i| !x.specular(i)).unwrap_or(0)
}

/// Whether a path could be reached by propagation ending at the light: `v_0` must be an area light.
fn hittable_light(scene: &Scene, x: &FullPath) -> bool {
    match x.vertices[0].kind {
        VertexKind::Light { light } => !scene.lights[light as usize].is_delta_position(),
        _ => false,
    }
}

/// A lens or multi-chain perturbation of `x` into `y`; returns `ln` of the acceptance ratio.
pub fn camera_side(
    scene: &Scene,
    which: CameraSide,
    settings: &PerturbationSettings,
    importance: ImportanceKind,
    x: &PathState,
    rng: &mut ChainRng,
    y: &mut PathState,
) -> Result<f64, Failure> {
    let xp = &x.path;
    let k = xp.edges();
    if k < 1 {
        return Err(Failure::NotApplicable);
    }
    let j = first_non_specular_from_eye(xp);
    if which == CameraSide::Lens && j > 0 && xp.specular(j - 1) {
        return Err(Failure::NotApplicable);
    }
    if j == 0 && !hittable_light(scene, xp) {
        return Err(Failure::NotApplicable);
    }
    let raster = xp.raster(scene).ok_or(Failure::NotApplicable)?;
    let moved = pixel_offset(raster, settings.r1, settings.r2(scene), rng);
    let lens = xp.lens().clone();
    let cs = scene
        .camera
        .ray_through(lens.p(), moved)
        .ok_or(Failure::Failed)?;
    // New vertices in camera order: lens, v'_{k−1}, v'_{k−2}, …
    let mut cam: Vec<Vertex> = Vec::with_capacity(k + 1);
    cam.push(lens);
    let (mut ln_y, mut ln_x) = (0.0, 0.0);
    let mut w = cs.ray.d;
    let mut i = k - 1;
    let s = loop {
        let mut v = trace(scene, cam.last().ok_or(Failure::Failed)?, w).ok_or(Failure::Failed)?;
        if xp.specular(i) {
            let (wi, py, px) = follow_specular(&mut v, xp, i, true, TransportMode::Radiance)?;
            ln_y += py;
            ln_x += px;
            cam.push(v);
            w = wi;
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
            cam.push(v);
            break 0;
        }
        if v.bsdf.as_ref().is_none_or(|b| b.is_delta_only()) {
            return Err(Failure::Failed);
        }
        if !xp.specular(i - 1) {
            cam.push(v);
            break i;
        }
        // Multi-chain: offset the direction leaving this vertex toward the next chain.
        debug_assert_eq!(which, CameraSide::MultiChain);
        let old = &xp.vertices[i];
        let w_x = direction(old, &xp.vertices[i - 1]);
        let w_y = angular_offset(w_x, settings.theta1, settings.theta2, rng);
        let p_x = bsdf_pdf(old, &xp.vertices[i + 1], &xp.vertices[i - 1]);
        let p_y = v.bsdf.as_ref().map_or(0.0, |b| b.pdf(v.wo, w_y));
        if !(p_x > 0.0) {
            return Err(Failure::NotApplicable);
        }
        if !(p_y > 0.0) {
            return Ok(f64::NEG_INFINITY);
        }
        ln_y += p_y.ln();
        ln_x += p_x.ln();
        cam.push(v);
        w = w_y;
        i -= 1;
    };
    // ȳ = kept light part v_0 … v_{s−1}, then the new camera part reversed.
    let yp = &mut y.path;
    yp.vertices.clear();
    yp.vertices.extend_from_slice(&xp.vertices[..s]);
    yp.vertices.extend(cam.into_iter().rev());
    if s > 0 && !connection_clear(scene, &yp.vertices[s - 1], &yp.vertices[s]) {
        return Ok(f64::NEG_INFINITY);
    }
    yp.vertices[s].delta = false;
    finish(scene, importance, x, y, s, ln_y - ln_x)
}

/// The caustic perturbation of `x` into `y` (paths `(L|D) S* D E`): offset the direction leaving
/// the last non-specular vertex before the eye's, follow the specular chain, connect to the eye.
pub fn caustic(
    scene: &Scene,
    settings: &PerturbationSettings,
    importance: ImportanceKind,
    x: &PathState,
    rng: &mut ChainRng,
    y: &mut PathState,
) -> Result<f64, Failure> {
    let xp = &x.path;
    let k = xp.edges();
    if k < 2 || xp.specular(k - 1) {
        return Err(Failure::NotApplicable);
    }
    let i0 = (0..k - 1).rev().find(|&i| !xp.specular(i)).unwrap_or(0);
    let start = &xp.vertices[i0];
    let w_x = direction(start, &xp.vertices[i0 + 1]);
    let w_y = angular_offset(w_x, settings.theta1, settings.theta2, rng);
    let pdf_at = |w: DVec3| -> f64 {
        match start.kind {
            VertexKind::Light { light } => scene.lights[light as usize].pdf_direction(start.n(), w),
            _ => match (&start.bsdf, i0) {
                (Some(b), i) if i >= 1 => b.pdf(direction(start, &xp.vertices[i - 1]), w),
                _ => 0.0,
            },
        }
    };
    let (p_x, p_y) = (pdf_at(w_x), pdf_at(w_y));
    if !(p_x > 0.0) {
        return Err(Failure::NotApplicable);
    }
    if !(p_y > 0.0) {
        return Ok(f64::NEG_INFINITY);
    }
    let (mut ln_y, mut ln_x) = (p_y.ln(), p_x.ln());
    let yp = &mut y.path;
    yp.vertices.clear();
    yp.vertices.extend_from_slice(&xp.vertices[..=i0]);
    let mut w = w_y;
    for i in i0 + 1..k {
        let last = yp.vertices.last().ok_or(Failure::Failed)?;
        let mut v = trace(scene, last, w).ok_or(Failure::Failed)?;
        if i < k - 1 {
            let (wi, py, px) = follow_specular(&mut v, xp, i, false, TransportMode::Importance)?;
            ln_y += py;
            ln_x += px;
            w = wi;
        } else if v.bsdf.as_ref().is_none_or(|b| b.is_delta_only()) {
            return Err(Failure::Failed);
        }
        yp.vertices.push(v);
    }
    yp.vertices.push(xp.lens().clone());
    if !connection_clear(scene, &yp.vertices[k - 1], &yp.vertices[k]) {
        return Ok(f64::NEG_INFINITY);
    }
    finish(scene, importance, x, y, k, ln_y - ln_x)
}

/// Whether the edge `a – b` is unoccluded.
pub fn connection_clear(scene: &Scene, a: &Vertex, b: &Vertex) -> bool {
    let na = a.on_surface(scene).then(|| a.n());
    let nb = b.on_surface(scene).then(|| b.n());
    scene.visible(a.p(), na, b.p(), nb)
}

/// Evaluate `y` and form `ln a = ln I(C*_s(ȳ)) − ln I(C*_s(x̄)) + extra`.
fn finish(
    scene: &Scene,
    importance: ImportanceKind,
    x: &PathState,
    y: &mut PathState,
    s: usize,
    extra: f64,
) -> Result<f64, Failure> {
    if !y.evaluate(scene, importance, 1.0) {
        return Ok(f64::NEG_INFINITY);
    }
    let (iy, ix) = (y.strategy_importance(s), x.strategy_importance(s));
    if !(ix > 0.0) {
        return Err(Failure::NotApplicable);
    }
    if !(iy > 0.0) {
        return Ok(f64::NEG_INFINITY);
    }
    Ok(iy.ln() - ix.ln() + extra)
}
