//! Density estimation as an independence sampler in charted MLT (charted-MLT paper §5.3,
//! eqs. 28–29): a chain in technique chart `(s, t)` builds a candidate with the `(s + 1, t)`
//! merging technique — a fresh camera subpath `z_0 … z_{t−1}` whose last vertex is merged with a
//! stored light vertex `y_s` within radius `r` — and drops `y_s`: the candidate is the
//! connection path `y_0 … y_{s−1} z_{t−1} … z_0` of chart `s`, made from the stored subpath's
//! numbers and the fresh camera numbers. It joins the chain through `mcmc_charts`'
//! [`ChartIndependence`](mcmc_charts::moves::ChartIndependence), mixed with the chart's own
//! uniform draws (a bidirectional connection) by eq. 29.
//!
//! # The density `p_de`
//! With `N` independent light subpaths in the [`LightVertexMap`], the merge picks an index
//! uniformly in `0 … cap − 1` and takes that one of the `K` stored vertices near `z_{t−1}` (failing
//! when the index is `≥ K`). As long as `K ≤ cap`, each stored vertex near `z_{t−1}` is taken with
//! probability `1/cap`, whatever the others, so the candidate's density is
//!
//! `p_de(x̄) = p_s(x̄) · N · P_merge(y_{s−1}, z_{t−1}) / cap`,
//!
//! with `p_s = p_light(y_0 … y_{s−1}) p_eye(z_0 … z_{t−1})` the connection density of chart `s`
//! and `P_merge` the probability that the light walk's next vertex from `y_{s−1}` lands in the
//! merge region around `z_{t−1}`. It is approximated as in Hachisuka et al. 2012's vertex
//! merging, `P_merge ≈ π r² p_→(y_{s−1} → z_{t−1})` (the area density of that step at
//! `z_{t−1}`): exact as `r → 0` on a smooth surface; near edges, corners and where `p_→` varies
//! within `r` it is biased. In the charts' measure `I(f) dμ` this is
//! `p_de = m(x̄) / I(C*_s)` with the **merge factor** `m = P_merge N / cap`.
//!
//! Three approximations remain, each measured by the tests: `P_merge` (above); a shared map
//! (rebuilt every round) stands in for fresh subpaths per proposal — conditioned on one map, the
//! light prefixes are a finite set, and only the "as if fresh" law is the one `p_de` describes;
//! and lookups with `K > cap` (counted) take only the nearest `cap` vertices.
//! [`LightVertices::FreshPerProposal`] removes the second (tests), a small `r` the first.
//!
//! `p_de > 0` needs `1 ≤ s`, `t ≥ 2`, `z_{t−1}` a surface point with a non-specular BSDF and
//! `y_{s−1}` able to scatter toward it: a path whose `y_{s−1}` is purely specular has
//! `P_merge = 0` and `f = 0` alike (a merged S D S path is not a connection path of any chart:
//! dropping `y_s` breaks the specular bounce at `y_{s−1}`).

use super::light_vertex_map::LightVertexMap;
use super::technique::TechniqueChart;
use crate::metropolis::ImportanceKind;
use crate::path::{Subpath, VertexKind, camera_subpath};
use crate::pathspace::PathState;
use crate::sampler::ReplayStream;
use crate::sampler::layout::{camera_numbers, light_numbers};
use crate::scene::Scene;
use crate::{Error, Result};
use mcmc_charts::Chart;
use mcmc_charts::moves::{IndependenceRule, PointSampler};
use mcmc_core::ChainRng;
use mcmc_core::rng::{uniform, uniform_index};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// Density-estimation settings (validated by [`DensityEstimation::validate`]).
#[derive(Clone, Debug, PartialEq)]
pub struct DensityEstimation {
    /// Probability of a density-estimation move per mutation (`--density-estimation`; 0: off).
    pub probability: f64,
    /// Share of merges in the combined sampler (`λ`; the rest are connections).
    pub merge_share: f64,
    /// Merge radius as a fraction of the scene's bounding-sphere radius.
    pub radius: f64,
    /// Light subpaths per map (`N`).
    pub light_paths: usize,
    /// Largest number of stored vertices a merge chooses among.
    pub cap: usize,
    /// Merge normals must agree to this cosine.
    pub min_normal_cos: f64,
    /// Eq. 29 (expected density) or eq. 28 (per component).
    pub rule: IndependenceRule,
}

impl Default for DensityEstimation {
    fn default() -> Self {
        Self {
            probability: 0.0,
            merge_share: 0.5,
            radius: 0.005,
            light_paths: 20_000,
            cap: 4,
            min_normal_cos: 0.9,
            rule: IndependenceRule::Expected,
        }
    }
}

impl DensityEstimation {
    /// Check the settings.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &str, reason: String| {
            Err(Error::InvalidParameter {
                name: name.into(),
                reason,
            })
        };
        for (name, p) in [
            ("density estimation", self.probability),
            ("merge share", self.merge_share),
        ] {
            if !(0.0..=1.0).contains(&p) {
                return bad(name, format!("must be a probability, got {p}"));
            }
        }
        if !(self.radius > 0.0 && self.radius.is_finite()) {
            return bad(
                "merge radius",
                format!("must be positive and finite, got {}", self.radius),
            );
        }
        if self.light_paths == 0 || self.light_paths > u32::MAX as usize {
            return bad(
                "merge light paths",
                format!(
                    "must be between 1 and {}, got {}",
                    u32::MAX,
                    self.light_paths
                ),
            );
        }
        if self.cap == 0 {
            return bad("merge cap", "must be at least 1".into());
        }
        if !(-1.0..=1.0).contains(&self.min_normal_cos) {
            return bad(
                "merge normal cosine",
                format!("must lie in [-1, 1], got {}", self.min_normal_cos),
            );
        }
        Ok(())
    }

    /// The merge radius in scene units.
    pub fn radius_in(&self, scene: &Scene) -> f64 {
        self.radius * 0.5 * (scene.bounds.1 - scene.bounds.0).length()
    }
}

/// Where a merge finds its light vertices.
#[derive(Clone, Debug)]
pub enum LightVertices {
    /// One map shared by the chains (rebuilt by the integrator every round).
    Shared(Arc<LightVertexMap>),
    /// A new map of `light_paths` subpaths for every proposal (exact as to the map; slow — tests).
    FreshPerProposal,
}

/// Counters of the merges (shared by the threads).
#[derive(Debug, Default)]
pub struct MergeCounters {
    /// Merge proposals made.
    pub proposals: AtomicU64,
    /// Lookups that found at least one vertex.
    pub found: AtomicU64,
    /// Lookups that found more than `cap` vertices (the nearest `cap` were used).
    pub overflows: AtomicU64,
    /// Sum of the vertices found.
    pub vertices: AtomicU64,
}

/// The merge sampler of the charts of paths of `k` edges (chart index = `s`).
pub struct MergeSampler<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Path length.
    pub k: usize,
    /// Colour to scalar (as the charts).
    pub importance: ImportanceKind,
    /// The settings.
    pub settings: DensityEstimation,
    /// The light vertices.
    pub vertices: LightVertices,
    /// Counters.
    pub counters: Option<Arc<MergeCounters>>,
}

impl MergeSampler<'_> {
    fn chart(&self, s: usize) -> Option<TechniqueChart<'_>> {
        TechniqueChart::new(self.scene, self.k, s, self.importance)
    }

    /// `N`, the light subpaths of a map.
    fn light_paths(&self) -> f64 {
        match &self.vertices {
            LightVertices::Shared(m) => m.paths() as f64,
            LightVertices::FreshPerProposal => self.settings.light_paths as f64,
        }
    }

    /// `ln m(x̄)`, the log merge factor `π r² p_→(y_{s−1} → z_{t−1}) N / cap` of a path of chart
    /// `s` (`-inf` where no merge can make it).
    pub fn ln_merge_factor(&self, s: usize, x: &PathState) -> f64 {
        let k = self.k;
        if s == 0 || s + 1 > k || x.path.edges() != k {
            return f64::NEG_INFINITY;
        }
        let v = &x.path.vertices;
        let z = &v[s];
        if !(z.kind == VertexKind::Surface && z.connectible()) {
            return f64::NEG_INFINITY;
        }
        let prev = if s >= 2 { Some(&v[s - 2]) } else { None };
        let p = v[s - 1].pdf(self.scene, prev, z);
        let r = self.settings.radius_in(self.scene);
        let n = self.light_paths();
        // A probability: at most 1 (the disc approximation exceeds it where y_{s−1} is within a
        // few radii of z_{t−1}, in corners).
        let p_merge = (std::f64::consts::PI * r * r * p).min(1.0);
        let m = p_merge * n / self.settings.cap as f64;
        if m > 0.0 && m.is_finite() {
            m.ln()
        } else {
            f64::NEG_INFINITY
        }
    }
}

impl PointSampler<PathState> for MergeSampler<'_> {
    fn draw(&self, s: usize, y: &mut PathState, rng: &mut ChainRng) -> bool {
        let st = &self.settings;
        let Some(chart) = self.chart(s) else {
            return false;
        };
        let t = chart.t();
        if s == 0 || t < 2 {
            return false;
        }
        if let Some(c) = &self.counters {
            c.proposals.fetch_add(1, Ordering::Relaxed);
        }
        if let LightVertices::Shared(map) = &self.vertices
            && map.vertices_at(s) == 0
        {
            return false; // nothing to merge with at this depth
        }
        // The fresh camera subpath and its last vertex z_{t−1}.
        let nc = camera_numbers(t);
        let mut u: Vec<f64> = (0..nc).map(|_| uniform(rng)).collect();
        let mut sub = Subpath::new();
        camera_subpath(
            self.scene,
            &mut ReplayStream::new(&u, &[], &[]),
            t,
            None,
            &mut sub,
        );
        let Some(z) = sub.get(t - 1) else {
            return false;
        };
        if !(z.kind == VertexKind::Surface && z.connectible()) {
            return false;
        }
        // The light vertices near it.
        let r = st.radius_in(self.scene);
        let mut near = Vec::new();
        let fresh_seed = match &self.vertices {
            LightVertices::Shared(map) => {
                map.near(s, z.p(), z.n(), r, st.min_normal_cos, &mut near);
                None
            }
            LightVertices::FreshPerProposal => {
                let seed = (uniform(rng) * 2f64.powi(53)) as u64;
                LightVertexMap::near_fresh(
                    self.scene,
                    s,
                    (z.p(), z.n()),
                    r,
                    st.min_normal_cos,
                    st.light_paths,
                    seed,
                    &mut near,
                );
                Some(seed)
            }
        };
        if let Some(c) = &self.counters {
            if !near.is_empty() {
                c.found.fetch_add(1, Ordering::Relaxed);
            }
            if near.len() > st.cap {
                c.overflows.fetch_add(1, Ordering::Relaxed);
            }
            c.vertices.fetch_add(near.len() as u64, Ordering::Relaxed);
        }
        let i = uniform_index(uniform(rng), st.cap);
        let Some(&j) = near.get(i) else {
            return false;
        };
        // The candidate: the stored subpath's first s vertices, connected to the camera subpath.
        let n = light_numbers(s);
        match (&self.vertices, fresh_seed) {
            (LightVertices::Shared(map), _) => u.extend_from_slice(&map.numbers(j)[..n]),
            (_, Some(seed)) => {
                u.resize(nc + n, 0.0);
                LightVertexMap::fresh_numbers(seed, j, &mut u[nc..]);
            }
            _ => return false,
        }
        chart.forward(&u, y)
    }

    fn ln_density(&self, s: usize, x: &PathState) -> f64 {
        let Some(chart) = self.chart(s) else {
            return f64::NEG_INFINITY;
        };
        chart.ln_density(x) + self.ln_merge_factor(s, x)
    }

    fn name(&self) -> String {
        "merge".into()
    }
}
