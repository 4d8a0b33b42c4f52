//! The lens subpath mutation (Veach & Guibas 1997, §5.3.2; overview paper §5.3 item 2): replace
//! the lens subpath — the trailing part of the path of the form `[^S] S* E` — by a new one traced
//! from a uniformly chosen lens point and image position through purely specular surfaces until
//! the first surface with a non-delta component, and connect that vertex to the unchanged rest.
//!
//! The new lens subpath `v_j … v_k` has exactly the density of the camera subpath of strategy
//! `s = j` (the kept light part is `v_0 … v_{j−1}`), lobe choices at the specular vertices
//! included, so in the common measure `T̃(ȳ|x̄) = 1 / I(C*_j(ȳ))` (record
//! `(j − 1, k + 1, k' − j + 1)`) and `a = min(1, I(C*_j(ȳ)) / I(C*_j(x̄)))`. A path whose first
//! vertex with a non-delta component (from the eye) scattered through a delta lobe has no lens
//! subpath of this form: the mutation does not apply.

use super::mutation::{Change, Mutation, Registration};
use super::state::PathState;
use super::walk::{lens_endpoint, sample_direction, trace, with_vertex_buffers};
use crate::bsdf::TransportMode;
use crate::metropolis::ImportanceKind;
use crate::path::Vertex;
use crate::scene::Scene;
use mcmc_core::{ChainRng, Failure};

/// The registration of the lens subpath mutation.
pub const REGISTRATION: Registration = Registration {
    name: "lens-subpath",
    default_weight: 0.1,
    build: |c| {
        Box::new(LensSubpath {
            scene: c.scene,
            max_edges: c.settings.max_edges,
            importance: c.settings.importance,
        })
    },
};

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

/// The lens subpath mutation on a scene.
struct LensSubpath<'a> {
    scene: &'a Scene,
    max_edges: usize,
    importance: ImportanceKind,
}

impl LensSubpath<'_> {
    /// The start `j` of `x`'s lens subpath when the mutation applies to `x`.
    fn start(&self, x: &PathState) -> Option<usize> {
        lens_subpath_start(&x.path).filter(|&j| x.strategy_importance(j) > 0.0)
    }
}

impl Mutation for LensSubpath<'_> {
    fn name(&self) -> &'static str {
        REGISTRATION.name
    }

    fn suitability(&self, x: &PathState) -> f64 {
        self.start(x).is_some() as u8 as f64
    }

    fn propose(&self, x: &PathState, rng: &mut ChainRng, y: &mut PathState) -> Result<(), Failure> {
        let scene = self.scene;
        let xp = &x.path;
        let j = self.start(x).ok_or(Failure::NotApplicable)?;
        // The new camera side is walked in a per-thread list (its length is known only when
        // the walk stops), then moved onto the kept light side.
        with_vertex_buffers(|cam, _| {
            cam.push(lens_endpoint(scene, rng).ok_or(Failure::Failed)?);
            loop {
                // Vertices so far: j kept + the new camera part; at most max_edges + 1.
                if j + cam.len() > self.max_edges {
                    return Err(Failure::Failed);
                }
                let w = sample_direction(scene, cam, TransportMode::Radiance, rng)
                    .ok_or(Failure::Failed)?;
                let last = cam.last().ok_or(Failure::Failed)?;
                let v = trace(scene, last, w).ok_or(Failure::Failed)?;
                let stop = !delta_only(&v);
                cam.push(v);
                if stop {
                    break;
                }
            }
            let added = cam.len();
            let yp = &mut y.path;
            yp.vertices.clear();
            yp.vertices.extend_from_slice(&xp.vertices[..j]);
            yp.vertices.extend(cam.drain(..).rev());
            let change = Change {
                l: j as isize - 1,
                m: xp.edges() + 1,
                added,
                pivot: 0,
            };
            y.finish_candidate(scene, self.importance, x, change, j);
            Ok(())
        })
    }

    fn ln_density(&self, x: &PathState, y: &PathState, c: Change) -> f64 {
        let never = f64::NEG_INFINITY;
        let Some(j) = self.start(x) else {
            return never;
        };
        let (kx, ky) = (x.path.edges(), y.path.edges());
        if c != (Change {
            l: j as isize - 1,
            m: kx + 1,
            added: (ky + 1).saturating_sub(j),
            pivot: 0,
        }) || ky > self.max_edges
            || ky < j + 1
        {
            return never;
        }
        // ȳ's new part must be what the walk makes: purely specular vertices up to the first
        // surface with a non-delta component.
        let yv = &y.path.vertices;
        let through = (j + 1..ky).all(|i| y.path.specular(i) && delta_only(&yv[i]));
        if !through || delta_only(&yv[j]) || y.path.specular(j) {
            return never;
        }
        let i = y.strategy_importance(j);
        if i > 0.0 { -i.ln() } else { never }
    }
}
