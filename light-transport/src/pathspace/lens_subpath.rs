//! The lens subpath mutation (Veach & Guibas 1997, §5.3.2; overview paper §5.3 item 2): replace
//! the lens subpath — the trailing part of the path of the form `[^S] S* E` — by a new one traced
//! from a uniformly chosen lens point and image position through purely specular surfaces until
//! the first surface with a non-delta component, and connect that vertex to the unchanged rest.
//!
//! The new lens subpath has exactly the density of the camera subpath of strategy `s = j` (the
//! kept light part is `v_0 … v_{j−1}`), lobe choices at the specular vertices included, so
//! `a = min(1, I(C*_j(ȳ)) / I(C*_j(x̄)))`. A path whose first vertex with a non-delta component
//! (from the eye) scattered through a delta lobe has no lens subpath of this form: the mutation
//! does not apply.

use super::perturbation::connection_clear;
use super::state::PathState;
use super::walk::{lens_endpoint, sample_direction, trace};
use crate::bsdf::TransportMode;
use crate::metropolis::ImportanceKind;
use crate::path::Vertex;
use crate::scene::Scene;
use mcmc_core::{ChainRng, Failure};

/// Whether a vertex lies on a purely specular surface (a lens subpath passes through it).
fn delta_only(v: &Vertex) -> bool {
    v.bsdf.as_ref().is_some_and(|b| b.is_delta_only())
}

/// The index `j` of the vertex where the lens subpath of `x` starts, if it has one of the form
/// the mutation regenerates.
pub fn lens_subpath_start(x: &super::FullPath) -> Option<usize> {
    let k = x.edges();
    let mut j = k.checked_sub(1)?;
    while j >= 1 && x.specular(j) && delta_only(&x.vertices[j]) {
        j -= 1;
    }
    (j >= 1 && !x.specular(j) && !x.specular(j - 1)).then_some(j)
}

/// Propose `y` from `x`; returns `ln` of the acceptance ratio.
pub fn lens_subpath(
    scene: &Scene,
    max_edges: usize,
    importance: ImportanceKind,
    x: &PathState,
    rng: &mut ChainRng,
    y: &mut PathState,
) -> Result<f64, Failure> {
    let xp = &x.path;
    let j = lens_subpath_start(xp).ok_or(Failure::NotApplicable)?;
    let mut cam: Vec<Vertex> = Vec::with_capacity(xp.edges() + 1);
    cam.push(lens_endpoint(scene, rng).ok_or(Failure::Failed)?);
    loop {
        // Vertices so far: j kept + the new camera part; at most max_edges + 1.
        if j + cam.len() > max_edges {
            return Err(Failure::Failed);
        }
        let w = sample_direction(scene, &mut cam, TransportMode::Radiance, rng)
            .ok_or(Failure::Failed)?;
        let last = cam.last().ok_or(Failure::Failed)?;
        let v = trace(scene, last, w).ok_or(Failure::Failed)?;
        let stop = !delta_only(&v);
        cam.push(v);
        if stop {
            break;
        }
    }
    let yp = &mut y.path;
    yp.vertices.clear();
    yp.vertices.extend_from_slice(&xp.vertices[..j]);
    yp.vertices.extend(cam.into_iter().rev());
    if !connection_clear(scene, &yp.vertices[j - 1], &yp.vertices[j]) {
        return Ok(f64::NEG_INFINITY);
    }
    if !y.evaluate(scene, importance, 1.0) {
        return Ok(f64::NEG_INFINITY);
    }
    let (iy, ix) = (y.strategy_importance(j), x.strategy_importance(j));
    if !(ix > 0.0) {
        return Err(Failure::NotApplicable);
    }
    if !(iy > 0.0) {
        return Ok(f64::NEG_INFINITY);
    }
    Ok(iy.ln() - ix.ln())
}
