//! Photon tracing (Jensen 2001, ch. 5): light subpaths from the lights, each vertex on a surface
//! that is not purely specular storing a photon whose power is the subpath's throughput there over
//! the number of subpaths (the particle-tracing estimator of Veach 1997, §4.A: the expected summed
//! power of the photons in a region is the flux arriving there).
//!
//! Two maps, in the final-gather convention of Fan, Chenney & Lai 2005, §3.1: the **global** map
//! holds a photon at every such vertex (a gather ray reads it at the second diffuse point of an eye
//! path), the **caustic** map one at the first such vertex of `L S+ D` subpaths.

use super::map::Photon;
use crate::path::{VertexKind, light_subpath};
use crate::sampler::IndependentStream;
use crate::scene::Scene;

/// The photons of `paths` light subpaths of at most `max_edges` edges, subpath `i` drawn from
/// stream `(seed, i)`: `(global, caustic)`.
pub fn trace_photons(
    scene: &Scene,
    paths: u64,
    max_edges: usize,
    seed: u64,
) -> (Vec<Photon>, Vec<Photon>) {
    let (mut global, mut caustic) = (Vec::new(), Vec::new());
    let mut path = Vec::new();
    let scale = 1.0 / paths.max(1) as f64;
    for i in 0..paths {
        let mut stream = IndependentStream::new(mcmc_core::rng::stream(seed, i));
        light_subpath(scene, &mut stream, max_edges, &mut path);
        for (j, v) in path.iter().enumerate().skip(1) {
            if v.kind != VertexKind::Surface || !v.connectible() {
                continue;
            }
            let power = v.beta * scale;
            if power.is_black() || !power.is_finite() {
                continue;
            }
            let wi = v.wo;
            let n = if v.point.n.dot(wi) >= 0.0 {
                v.point.n
            } else {
                -v.point.n
            };
            let photon = Photon {
                p: v.p(),
                wi,
                power,
                n,
            };
            global.push(photon);
            if j >= 2 && path[1..j].iter().all(|u| u.delta) {
                caustic.push(photon);
            }
        }
    }
    (global, caustic)
}
