//! Photon tracing (Jensen 2001, ch. 5): light subpaths from the lights, each vertex on a surface
//! that is not purely specular storing a photon whose power is the subpath's throughput there over
//! the number of subpaths (the particle-tracing estimator of Veach 1997, §4.A: the expected summed
//! power of the photons in a region is the flux arriving there).
//!
//! Two maps, in the final-gather convention of Fan, Chenney & Lai 2005, §3.1: the **global** map
//! holds a photon at every such vertex (a gather ray reads it at the second diffuse point of an eye
//! path), the **caustic** map one at the first such vertex of `L S+ D` subpaths.
//!
//! **Stratified emission.** The five numbers that choose the light, the point on it and the emitted
//! direction form a Latin hypercube over the `N` subpaths: in each of the five dimensions the
//! subpaths fall one per stratum of width `1/N` (a random permutation per dimension, jittered
//! within the stratum by the subpath's own number). Each subpath's numbers stay uniform, so every
//! photon's expected power is unchanged; emission is spread evenly over the lights' surfaces and
//! directions.

use super::map::Photon;
use crate::path::{Subpath, VertexKind, light_subpath};
use crate::sampler::{IndependentStream, LIGHT_STREAM, SampleStream, layout};
use crate::scene::Scene;
use mcmc_core::rng::{FastRng, uniform, uniform_index};

/// Positions of the light stream's emission numbers (choice, position, direction).
const EMISSION: [usize; 5] = [
    layout::LIGHT_CHOICE,
    layout::LIGHT_POSITION,
    layout::LIGHT_POSITION + 1,
    layout::LIGHT_DIRECTION,
    layout::LIGHT_DIRECTION + 1,
];

/// A Latin hypercube over the emission numbers of `n` subpaths: a permutation of the strata per
/// dimension.
struct Strata {
    n: usize,
    perms: Vec<Vec<u32>>,
}

impl Strata {
    fn new(n: usize, seed: u64) -> Self {
        let mut rng = mcmc_core::rng::stream(seed, u64::MAX);
        let perms = (0..EMISSION.len())
            .map(|_| {
                let mut p: Vec<u32> = (0..n as u32).collect();
                // Fisher–Yates.
                for i in (1..n).rev() {
                    let j = uniform_index(uniform(&mut rng), i + 1);
                    p.swap(i, j);
                }
                p
            })
            .collect();
        Self { n, perms }
    }
}

/// Subpath `i`'s numbers, with the emission numbers moved into their strata.
struct StratifiedStream<'a> {
    inner: IndependentStream<FastRng>,
    strata: &'a Strata,
    i: usize,
    current: usize,
}

impl SampleStream for StratifiedStream<'_> {
    fn start_stream(&mut self, index: usize) {
        self.current = index;
        self.inner.start_stream(index);
    }

    fn next_1d(&mut self) -> f64 {
        let at = self.inner.position();
        let u = self.inner.next_1d();
        if self.current != LIGHT_STREAM {
            return u;
        }
        match EMISSION.iter().position(|&e| e == at) {
            Some(d) => {
                let v = (self.strata.perms[d][self.i] as f64 + u) / self.strata.n as f64;
                v.min(1.0 - f64::EPSILON / 2.0)
            }
            None => u,
        }
    }

    fn seek(&mut self, index: usize) {
        self.inner.seek(index);
    }

    fn position(&self) -> usize {
        self.inner.position()
    }
}

/// The photons of `paths` light subpaths of at most `max_edges` edges (a photon at the end of a
/// subpath of `j` edges stands for light that arrives after `j` edges), subpath `i` drawn from
/// `fast_stream(seed, i)` (a generator per subpath, cheap to set up for the few dozen numbers it
/// reads) with its emission stratified (module docs): `(global, caustic)`.
pub fn trace_photons(
    scene: &Scene,
    paths: u64,
    max_edges: usize,
    seed: u64,
) -> (Vec<Photon>, Vec<Photon>) {
    use rayon::prelude::*;
    const CHUNK: u64 = 4096;
    let scale = 1.0 / paths.max(1) as f64;
    let strata = Strata::new(paths as usize, seed);
    // Chunks in parallel, concatenated in order: the same photons for any thread count.
    let chunks: Vec<(Vec<Photon>, Vec<Photon>)> = (0..paths.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let (mut global, mut caustic) = (Vec::new(), Vec::new());
            let mut path = Subpath::new();
            for i in c * CHUNK..((c + 1) * CHUNK).min(paths) {
                let mut stream = StratifiedStream {
                    inner: IndependentStream::new(mcmc_core::rng::fast_stream(seed, i)),
                    strata: &strata,
                    i: i as usize,
                    current: 0,
                };
                light_subpath(scene, &mut stream, max_edges + 1, &mut path);
                store(&path, scale, &mut global, &mut caustic);
            }
            (global, caustic)
        })
        .collect();
    let (mut global, mut caustic) = (Vec::new(), Vec::new());
    for (g, c) in chunks {
        global.extend(g);
        caustic.extend(c);
    }
    (global, caustic)
}

/// The photons of one light subpath.
fn store(
    path: &[crate::path::Vertex],
    scale: f64,
    global: &mut Vec<Photon>,
    caustic: &mut Vec<Photon>,
) {
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
