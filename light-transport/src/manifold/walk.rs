//! The manifold walk (Jakob & Marschner 2012, §4, `WalkManifold`): move the last vertex of a
//! specular chain `x_0 … x_{m+1}` to a target `x'` while `x_0` stays fixed and the chain stays
//! specular.
//!
//! Each iteration predicts, from the tangent map, where the first specular vertex must go for the
//! endpoint to move by the remaining offset (a step of size `β`), then corrects by tracing rays
//! from `x_0` through that point with the chain's reflections and refractions, the last segment
//! ending on a plane through the endpoint and the target. A step that brings the endpoint closer is
//! kept and doubles `β` (at most 1); otherwise `β` is halved. The walk converges when the endpoint
//! is within `ε L` of the target (`L` the scene's diagonal) and then checks that the last segment
//! is unoccluded. The plane's normal is the symmetric orthogonalisation of §4,
//! `n_plane = γ(γ(n + n') − d ⟨γ(n + n'), d⟩)` with `d` the unit direction from the endpoint to the
//! target, so that walks in the two directions use the same plane.

use super::chain::{ChainVertex, Interaction, scatter};
use super::geometry_term::{ChainJacobian, chain_jacobian_into, coordinates};
use super::{Chain, PerVertex, Vec2};
use crate::geometry::{Ray, SurfaceEnd};
use crate::math::{DVec3, Frame};
use crate::scene::Scene;

/// `ChainVertex::material` of a vertex that is not on a scene surface (a pinhole, a point light).
pub const NO_MATERIAL: u32 = u32::MAX;

/// Settings of the manifold walk (the paper's defaults).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ManifoldSettings {
    /// Largest number of iterations `N` (20).
    pub max_iterations: usize,
    /// Convergence tolerance `ε` relative to the scene's diagonal (1e-7).
    pub epsilon: f64,
}

impl Default for ManifoldSettings {
    fn default() -> Self {
        Self {
            max_iterations: 20,
            epsilon: 1e-7,
        }
    }
}

/// Why a walk failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WalkFailure {
    /// No convergence within the iteration limit (no solution, or not reachable from here).
    NoSolution,
    /// The Jacobian `A` is singular (the endpoint sits on a caustic of the other).
    Singular,
    /// A traced ray met another material, missed, or scattered to the wrong side.
    ChangedConfiguration,
    /// A refraction became a total internal reflection.
    TotalInternalReflection,
    /// Converged, but the last segment is occluded.
    Occluded,
}

impl WalkFailure {
    /// All causes, in the order of [`WalkStats::failures`].
    pub const ALL: [WalkFailure; 5] = [
        WalkFailure::NoSolution,
        WalkFailure::Singular,
        WalkFailure::ChangedConfiguration,
        WalkFailure::TotalInternalReflection,
        WalkFailure::Occluded,
    ];

    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            WalkFailure::NoSolution => "no solution",
            WalkFailure::Singular => "singular",
            WalkFailure::ChangedConfiguration => "changed configuration",
            WalkFailure::TotalInternalReflection => "total internal reflection",
            WalkFailure::Occluded => "occluded",
        }
    }

    fn index(self) -> usize {
        Self::ALL.iter().position(|&f| f == self).unwrap_or(0)
    }
}

/// A successful walk.
#[derive(Clone, Debug, Default)]
pub struct Walked {
    /// The new chain `x_0, x'_1 … x'_m, x'`.
    pub chain: Chain,
    /// Iterations used.
    pub iterations: usize,
    /// Distance of the endpoint to the target before each iteration (the last below `ε L`;
    /// inline up to 16 entries, which covers the default limit of iterations).
    pub distances: smallvec::SmallVec<[f64; 16]>,
}

/// Per-walk statistics (the columns of the paper's Table 1 that concern walks).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WalkStats {
    /// Walks attempted.
    pub walks: u64,
    /// Walks that converged and were unoccluded.
    pub converged: u64,
    /// Iterations summed over converged walks.
    pub iterations: u64,
    /// Specular vertices summed over walks (the manifold's size).
    pub vertices: u64,
    /// Largest number of specular vertices of a walk.
    pub max_vertices: u64,
    /// Failures by cause, in the order of [`WalkFailure::ALL`].
    pub failures: [u64; 5],
    /// Converged walks whose reverse walk failed or found another configuration
    /// ([`walk_reversibly`]).
    pub non_reversible: u64,
}

impl WalkStats {
    /// Count one walk over `m` specular vertices that converged in `result` iterations or failed.
    pub fn record(&mut self, m: usize, result: Result<usize, WalkFailure>) {
        self.walks += 1;
        self.vertices += m as u64;
        self.max_vertices = self.max_vertices.max(m as u64);
        match result {
            Ok(iterations) => {
                self.converged += 1;
                self.iterations += iterations as u64;
            }
            Err(f) => self.failures[f.index()] += 1,
        }
    }

    /// Add another set of statistics.
    pub fn merge(&mut self, o: &WalkStats) {
        self.walks += o.walks;
        self.converged += o.converged;
        self.iterations += o.iterations;
        self.vertices += o.vertices;
        self.max_vertices = self.max_vertices.max(o.max_vertices);
        for (a, b) in self.failures.iter_mut().zip(o.failures) {
            *a += b;
        }
        self.non_reversible += o.non_reversible;
    }

    /// One line: walks, success, iterations, failures by cause, non-reversible share.
    pub fn summary(&self) -> String {
        let share = |n: u64| 100.0 * n as f64 / self.walks.max(1) as f64;
        let causes: Vec<String> = WalkFailure::ALL
            .iter()
            .zip(self.failures)
            .filter(|(_, n)| *n > 0)
            .map(|(f, n)| format!("{} {:.2}%", f.name(), share(n)))
            .collect();
        format!(
            "{} walks over {:.2} specular vertices (at most {}), {:.2}% converged in {:.2} iterations; \
             failed: {}; non-reversible {:.2}%",
            self.walks,
            self.vertices as f64 / self.walks.max(1) as f64,
            self.max_vertices,
            100.0 * self.success_rate(),
            self.mean_iterations(),
            if causes.is_empty() {
                "none".to_string()
            } else {
                causes.join(", ")
            },
            share(self.non_reversible)
        )
    }

    /// Share of walks that converged.
    pub fn success_rate(&self) -> f64 {
        self.converged as f64 / self.walks.max(1) as f64
    }

    /// Mean iterations of a converged walk.
    pub fn mean_iterations(&self) -> f64 {
        self.iterations as f64 / self.converged.max(1) as f64
    }
}

/// The plane of the last propagation step: through the endpoint `x` (normal `n`) and containing
/// the target `x'` (normal `n'`), with the symmetric normal of §4.
pub fn endpoint_plane(x: DVec3, n: DVec3, target: DVec3, target_n: DVec3) -> DVec3 {
    let sum = (n + target_n).normalize_or_zero();
    let d = (target - x).normalize_or_zero();
    let np = (sum - d * sum.dot(d)).normalize_or_zero();
    if np == DVec3::ZERO { n } else { np }
}

/// What a traced specular vertex must be: the material it must lie on (`None`: any), how it
/// scatters, and its offset.
type Expected = (Option<u32>, Interaction, [f64; 2]);

/// Trace from `start` along `dir` through one specular vertex per entry of `expected`, repeating
/// its interaction: the new specular vertices, and the origin and direction of the last segment.
fn follow(
    scene: &Scene,
    start: &ChainVertex,
    dir: DVec3,
    expected: impl Iterator<Item = Expected>,
    out: &mut Chain,
) -> Result<Ray, WalkFailure> {
    let mut ray = if start.material == NO_MATERIAL {
        Ray::new(start.p(), dir)
    } else {
        Ray::leaving(&start.point, dir)
    };
    for (want, interaction, offset) in expected {
        let hit = scene
            .intersect(&ray)
            .ok_or(WalkFailure::ChangedConfiguration)?;
        let material = scene.primitive_material[hit.point.primitive as usize];
        if want.is_some_and(|m| m != material) {
            return Err(WalkFailure::ChangedConfiguration);
        }
        let v = ChainVertex::new(scene, hit.point, material, interaction, offset);
        let wi = -ray.d;
        let h = v.half_vector(wi).ok_or(WalkFailure::ChangedConfiguration)?;
        let eta = v.relative_eta(wi);
        let refract = matches!(v.interaction, Interaction::Refract { .. });
        let c = h.dot(wi);
        if refract && c * c - 1.0 + eta * eta < 0.0 {
            return Err(WalkFailure::TotalInternalReflection);
        }
        let wo =
            scatter(wi, h, eta, refract, v.point.n).ok_or(WalkFailure::ChangedConfiguration)?;
        ray = Ray::leaving(&v.point, wo);
        out.push(v);
    }
    Ok(ray)
}

/// Trace from `chain[0]` through the point `through`, repeating the chain's interactions at each
/// hit, and end on the plane `(x_plane, n_plane)`: the new specular vertices, into `out` (emptied
/// first; a walk keeps one list for all its steps instead of moving a new one out of each), and
/// the end point.
fn propagate(
    scene: &Scene,
    chain: &[ChainVertex],
    through: DVec3,
    x_plane: DVec3,
    n_plane: DVec3,
    out: &mut Chain,
) -> Result<DVec3, WalkFailure> {
    let m = chain.len() - 2;
    let dir = (through - chain[0].p()).normalize_or_zero();
    if dir == DVec3::ZERO {
        return Err(WalkFailure::ChangedConfiguration);
    }
    out.clear();
    let expected = chain[1..=m]
        .iter()
        .map(|v| (Some(v.material), v.interaction, v.offset));
    let ray = follow(scene, &chain[0], dir, expected, out)?;
    let t = (x_plane - ray.o).dot(n_plane) / ray.d.dot(n_plane);
    if !(t > 0.0 && t.is_finite()) {
        return Err(WalkFailure::ChangedConfiguration);
    }
    Ok(ray.at(t))
}

/// A chain traced from `start` along `dir` through specular vertices that scatter as
/// `interactions` say (ideal specular, offsets 0) to the next surface: `start`, the specular
/// vertices and the end (a reflecting vertex of the surface it lands on). For building chains in
/// tests, benchmarks and the perturbation's deterministic propagation.
pub fn trace_chain(
    scene: &Scene,
    start: &ChainVertex,
    dir: DVec3,
    interactions: &[Interaction],
) -> Result<Chain, WalkFailure> {
    let mut out: Chain = smallvec::smallvec![*start];
    let expected = interactions.iter().map(|&i| (None, i, [0.0; 2]));
    let ray = follow(scene, start, dir, expected, &mut out)?;
    let hit = scene
        .intersect(&ray)
        .ok_or(WalkFailure::ChangedConfiguration)?;
    out.push(ChainVertex::new(
        scene,
        hit.point,
        scene.primitive_material[hit.point.primitive as usize],
        Interaction::Reflect,
        [0.0; 2],
    ));
    Ok(out)
}

/// Walk the end of `chain` to `target` and back (Jakob & Marschner 2012, §5.1: a walk can succeed
/// one way and fail the other, or converge to another solution across a bifurcation): the forward
/// walk when the reverse one returns every vertex to within 1e-6 of the scene's diagonal, `None`
/// otherwise. Both outcomes are recorded in `stats`.
pub fn walk_reversibly(
    scene: &Scene,
    chain: &[ChainVertex],
    target: &ChainVertex,
    settings: &ManifoldSettings,
    stats: &mut WalkStats,
) -> Option<Walked> {
    let mut forward = Walked::default();
    walk_reversibly_into(scene, chain, target, settings, stats, &mut forward).then_some(forward)
}

/// [`walk_reversibly`] into `forward`, whose storage it reuses (a chain is about a kilobyte, and
/// moving the walks' results out of each call was about a fifth of MEMLT's copying on `pool`):
/// `true` when the walk succeeded and is reversible, `forward` then holding it.
pub fn walk_reversibly_into(
    scene: &Scene,
    chain: &[ChainVertex],
    target: &ChainVertex,
    settings: &ManifoldSettings,
    stats: &mut WalkStats,
    forward: &mut Walked,
) -> bool {
    let m = chain.len() - 2;
    let result = walk_manifold_into(scene, chain, target, settings, forward);
    stats.record(m, result.map(|()| forward.iterations));
    if result.is_err() {
        return false;
    }
    let scale = (scene.bounds.1 - scene.bounds.0).length();
    let mut back = Walked::default();
    let returned = walk_manifold_into(scene, &forward.chain, &chain[m + 1], settings, &mut back)
        .is_ok()
        && back
            .chain
            .iter()
            .zip(chain)
            .all(|(a, o)| (a.p() - o.p()).length() <= 1e-6 * scale);
    if !returned {
        stats.non_reversible += 1;
    }
    returned
}

/// Walk the last vertex of `chain` (`x_0 … x_{m+1}`, `m ≥ 1` specular vertices between two fixed
/// non-specular ends) to `target`, a point on a scene surface (or, with [`NO_MATERIAL`], a point
/// without one). On success the chain ends at `target` and its specular vertices are real
/// surface points with their differential geometry.
pub fn walk_manifold(
    scene: &Scene,
    chain: &[ChainVertex],
    target: &ChainVertex,
    settings: &ManifoldSettings,
) -> Result<Walked, WalkFailure> {
    let mut walked = Walked::default();
    walk_manifold_into(scene, chain, target, settings, &mut walked).map(|()| walked)
}

/// [`walk_manifold`] into `out`, whose storage it reuses: the walk's chain is built in place
/// instead of moved out of the call. On failure `out` holds no walk.
pub fn walk_manifold_into(
    scene: &Scene,
    chain: &[ChainVertex],
    target: &ChainVertex,
    settings: &ManifoldSettings,
    out: &mut Walked,
) -> Result<(), WalkFailure> {
    let n = chain.len();
    assert!(n >= 3, "a manifold walk needs a specular vertex");
    let m = n - 2;
    let end = &chain[n - 1];
    let scale = (scene.bounds.1 - scene.bounds.0).length().max(1e-300);
    let tolerance = settings.epsilon * scale;
    let n_plane = endpoint_plane(end.p(), end.point.n, target.p(), target.point.n);
    let plane_frame = Frame::from_normal(n_plane);
    let plane_basis = (plane_frame.s, plane_frame.t);
    let cur = &mut out.chain;
    cur.clear();
    cur.extend_from_slice(chain);
    let mut end_p = end.p();
    let mut beta = 1.0f64;
    let distances = &mut out.distances;
    distances.clear();
    let mut cause = WalkFailure::NoSolution;
    let iterations = &mut out.iterations;
    *iterations = 0;
    let mut traced = Chain::new();
    let mut j = ChainJacobian::default();
    loop {
        let dist = (end_p - target.p()).length();
        distances.push(dist);
        if dist <= tolerance {
            break;
        }
        if *iterations >= settings.max_iterations {
            return Err(cause);
        }
        *iterations += 1;
        if !chain_jacobian_into(cur, cur[0].tangent_basis(), plane_basis, &mut j) {
            return Err(WalkFailure::Singular);
        }
        let delta = coordinates(target.p() - end_p, plane_basis);
        let mut rhs: PerVertex<Vec2> = smallvec::smallvec![Vec2::zeros(); m];
        rhs[m - 1] = -(j.last * delta);
        let step = j.a.solve_vec(&rhs).ok_or(WalkFailure::Singular)?;
        let (e1, e2) = cur[1].tangent_basis();
        let through = cur[1].p() + (e1 * step[0][0] + e2 * step[0][1]) * beta;
        match propagate(scene, cur, through, end.p(), n_plane, &mut traced) {
            Ok(new_end) if (new_end - target.p()).length() < dist => {
                cur[1..=m].copy_from_slice(&traced);
                end_p = new_end;
                cur[n - 1].point.p = new_end;
                beta = (2.0 * beta).min(1.0);
            }
            Ok(_) => {
                cause = WalkFailure::NoSolution;
                beta *= 0.5;
            }
            Err(f) => {
                cause = f;
                beta *= 0.5;
            }
        }
    }
    let last = &cur[m];
    let target_end = (target.material != NO_MATERIAL).then(|| SurfaceEnd::of(&target.point));
    if !scene.visible(
        last.p(),
        Some(SurfaceEnd::of(&last.point)),
        target.p(),
        target_end,
    ) {
        return Err(WalkFailure::Occluded);
    }
    cur[n - 1] = *target;
    Ok(())
}
