//! The light-vertex map of density estimation (Hachisuka, Pantaleoni & Jensen 2012; Georgiev et
//! al. 2012), as the charted-MLT paper §5.3 uses it: `N` light subpaths traced from independent
//! uniform numbers, their vertices at every depth `s ≥ 1` in a k-d tree per depth (kiddo's
//! immutable tree, as the photon maps), and each subpath's numbers kept, so a merge can hand the
//! numbers of the subpath's first `s` vertices to the technique chart `s`.
//!
//! Only vertices a merge may use are stored: surface points whose BSDF is not purely specular.

use crate::math::DVec3;
use crate::path::{Subpath, VertexKind, light_subpath};
use crate::sampler::{ReplayStream, layout::light_numbers};
use crate::scene::Scene;
use crate::{Error, Result};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use mcmc_core::rng::{stream, uniform};
use rayon::prelude::*;

/// The stored vertices of one depth.
struct Depth {
    /// `(subpath, geometric normal)` per stored vertex, in the tree's item order.
    items: Vec<(u32, DVec3)>,
    tree: Option<ImmutableKdTree<f64, 3>>,
}

/// Light subpaths' vertices by depth, with the subpaths' numbers.
pub struct LightVertexMap {
    paths: usize,
    stride: usize,
    numbers: Vec<f64>,
    depths: Vec<Depth>,
}

impl std::fmt::Debug for LightVertexMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LightVertexMap")
            .field("paths", &self.paths)
            .field("vertices", &self.vertices())
            .finish()
    }
}

/// A stored vertex while the map is built: subpath, position, normal.
type Found = (u32, DVec3, DVec3);

/// Subpaths traced per parallel task (the map is the same for any thread count).
const CHUNK: usize = 256;

impl LightVertexMap {
    /// Trace `paths` light subpaths of up to `max_depth + 1` vertices from stream key `seed` and
    /// store their vertices of depths `1 ..= max_depth`.
    pub fn build(scene: &Scene, max_depth: usize, paths: usize, seed: u64) -> Result<Self> {
        if paths == 0 || paths > u32::MAX as usize {
            return Err(Error::InvalidParameter {
                name: "density estimation light paths".into(),
                reason: format!("must be between 1 and {}, got {paths}", u32::MAX),
            });
        }
        let stride = light_numbers(max_depth + 1);
        let traced: Vec<(Vec<f64>, Vec<Vec<Found>>)> = (0..paths)
            .collect::<Vec<_>>()
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut numbers = Vec::with_capacity(chunk.len() * stride);
                let mut found = vec![Vec::new(); max_depth];
                let mut sub = Subpath::new();
                for &j in chunk {
                    let mut rng = stream(seed, j as u64);
                    let start = numbers.len();
                    numbers.extend((0..stride).map(|_| uniform(&mut rng)));
                    let mut s = ReplayStream::new(&[], &numbers[start..], &[]);
                    light_subpath(scene, &mut s, max_depth + 1, &mut sub);
                    for (d, v) in sub.iter().enumerate().skip(1) {
                        if v.kind == VertexKind::Surface && v.connectible() {
                            found[d - 1].push((j as u32, v.p(), v.n()));
                        }
                    }
                }
                (numbers, found)
            })
            .collect();
        let mut numbers = Vec::with_capacity(paths * stride);
        let mut per_depth: Vec<Vec<Found>> = vec![Vec::new(); max_depth];
        for (n, found) in traced {
            numbers.extend(n);
            for (d, f) in found.into_iter().enumerate() {
                per_depth[d].extend(f);
            }
        }
        let depths = per_depth
            .into_iter()
            .map(|v| {
                let points: Vec<[f64; 3]> = v.iter().map(|&(_, p, _)| p.to_array()).collect();
                let tree = if points.is_empty() {
                    None
                } else {
                    Some(ImmutableKdTree::new_from_slice(&points).map_err(|e| {
                        Error::InvalidScene(format!("light-vertex k-d tree: {e:?}"))
                    })?)
                };
                Ok(Depth {
                    items: v.into_iter().map(|(j, _, n)| (j, n)).collect(),
                    tree,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            paths,
            stride,
            numbers,
            depths,
        })
    }

    /// Without building a map: the subpaths `j < paths` of stream key `seed` (the ones
    /// [`LightVertexMap::build`] would trace) whose depth-`s` vertex is near `p`, as
    /// [`LightVertexMap::near`] would find them (in subpath order), into `out`. For a fresh map
    /// per lookup (tests): no tree, and only `s + 1` vertices traced per subpath.
    #[allow(clippy::too_many_arguments)]
    pub fn near_fresh(
        scene: &Scene,
        s: usize,
        (p, n): (DVec3, DVec3),
        radius: f64,
        min_cos: f64,
        paths: usize,
        seed: u64,
        out: &mut Vec<u32>,
    ) {
        out.clear();
        let len = light_numbers(s + 1);
        let found: Vec<Vec<u32>> = (0..paths as u32)
            .collect::<Vec<_>>()
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut numbers = vec![0.0; len];
                let mut sub = Subpath::new();
                let mut hits = Vec::new();
                for &j in chunk {
                    Self::fresh_numbers(seed, j, &mut numbers);
                    light_subpath(
                        scene,
                        &mut ReplayStream::new(&[], &numbers, &[]),
                        s + 1,
                        &mut sub,
                    );
                    if let Some(v) = sub.get(s)
                        && v.kind == VertexKind::Surface
                        && v.connectible()
                        && v.p().distance_squared(p) <= radius * radius
                        && v.n().dot(n) >= min_cos
                    {
                        hits.push(j);
                    }
                }
                hits
            })
            .collect();
        out.extend(found.into_iter().flatten());
    }

    /// The first `out.len()` numbers of subpath `j` of stream key `seed` (as in
    /// [`LightVertexMap::build`]).
    pub fn fresh_numbers(seed: u64, j: u32, out: &mut [f64]) {
        let mut rng = stream(seed, j as u64);
        out.iter_mut().for_each(|v| *v = uniform(&mut rng));
    }

    /// Light subpaths traced (`N`).
    pub fn paths(&self) -> usize {
        self.paths
    }

    /// Deepest stored depth.
    pub fn max_depth(&self) -> usize {
        self.depths.len()
    }

    /// Vertices stored, over all depths.
    pub fn vertices(&self) -> usize {
        self.depths.iter().map(|d| d.items.len()).sum()
    }

    /// Vertices stored at depth `s`.
    pub fn vertices_at(&self, s: usize) -> usize {
        s.checked_sub(1)
            .and_then(|i| self.depths.get(i))
            .map_or(0, |d| d.items.len())
    }

    /// The numbers of subpath `j` (its first `light_numbers(s)` replay its first `s` vertices).
    pub fn numbers(&self, j: u32) -> &[f64] {
        let a = j as usize * self.stride;
        &self.numbers[a..a + self.stride]
    }

    /// The subpaths whose depth-`s` vertex lies within `radius` of `p` with a normal within
    /// `acos(min_cos)` of `n`, nearest first, into `out` (cleared first).
    pub fn near(
        &self,
        s: usize,
        p: DVec3,
        n: DVec3,
        radius: f64,
        min_cos: f64,
        out: &mut Vec<u32>,
    ) {
        out.clear();
        let Some(d) = s.checked_sub(1).and_then(|i| self.depths.get(i)) else {
            return;
        };
        let Some(tree) = &d.tree else {
            return;
        };
        let found = tree
            .query(&p.to_array())
            .within::<SquaredEuclidean<f64>>(radius * radius)
            .execute();
        out.extend(found.iter().filter_map(|q| {
            let (j, nv) = d.items[q.item as usize];
            (nv.dot(n) >= min_cos).then_some(j)
        }));
    }
}
