//! The manifold perturbation (Jakob & Marschner 2012, "Manifold exploration", §5.1) for ideal
//! specular chains: choose three non-specular vertices `x_a, x_b, x_c` of the path, separated by
//! specular chains; turn the direction leaving `x_a` by a von Mises–Fisher offset whose density
//! at the current direction is `λ² p(ω_i → ω_o)`; trace it through the first chain to a new `x'_b`;
//! move the second chain with [`walk_manifold`] so that it joins `x'_b` to the kept `x_c`; walk
//! back to reject non-reversible moves.
//!
//! **Two directions, two registrations.** The paper draws the direction (toward the light or
//! toward the camera) with the vertex `x_a`. A change `(l, m)` can be made from either end, and
//! the walk's success in the other direction is not known without replaying it, so each direction
//! is its own mutation (`manifold-light`: `x_a` on the camera side of `x_b`, the perturbation runs
//! toward the light; `manifold-eye`: the reverse). Each is exact for its own ratio; the mixture of
//! the two is the paper's perturbation.
//!
//! **Density (§5.1).** Sampling `ω'` at `x_a` and propagating it through the first chain gives
//! `x'_b` the area density `D⊥(ω') G(x_a ↔ … ↔ x'_b)` (eq. 9's generalised geometry term from
//! `x_a`'s side; `D⊥ = D / |cos θ_a|`); the second chain is a function of `x'_b`. In the common
//! measure of [`super::mutation`] the density is
//!
//! `T̃(ȳ|x̄) = P(a) D⊥(ω') G_a(ȳ) / I(F(ȳ))`,
//!
//! where `P(a)` is the probability of choosing `x_a` (uniform over the vertices where this direction
//! applies; the path's configuration fixes it) and `F = f / (K_L K_C)` is the path's contribution
//! with the specular vertices integrated out:
//!
//! `F = A_lo · Π ρ_i · G(x_lo ↔ … ↔ x_b) · f_s(x_b) · Π ρ_i · G(x_b ↔ … ↔ x_hi) · A_hi`,
//!
//! `lo < b < hi` the two kept ends (`{a, c}`), `A_lo` the light subpath's throughput up to `x_lo`
//! times its BSDF (`L_e / p(x_0)` at the light), `A_hi` the camera side's (`W_e / p(lens)` at the
//! lens), `ρ_i` the weight of each specular vertex's delta (radiance-mode BSDF value times
//! `|cos|`, so the deltas are in projected solid angle toward the light), and the generalised
//! geometry terms taken from the *camera* end of each chain — the convention of radiance-mode
//! deltas: light crossing a refraction changes étendue by η², and `G` from the light end would
//! differ by that factor.
//!
//! **Position moves.** When `x_a` is an area light's point or a thin lens's point (the paper splits
//! endpoints into a position and a direction vertex), the point moves on the light or lens by a
//! tangential Gaussian offset of variance `ρ/(2πλ²)`, `ρ` the light's (triangle's) or the lens's
//! area, and the chain from it to the next non-specular vertex `x_c` is walked. Nothing is kept on
//! that side, so `T̃ = P(a) g(Δ) / I(F)` with `g` the Gaussian density per unit area of the
//! light's plane or the lens and `F` the contribution without that side's `1/K`.
//!
//! Not yet: glossy chains on offset manifolds (eq. 11–12 and the specular probability ψ of the
//! appendix), chains that start at a point light (its position has no area measure for the
//! generalised geometry term), and the combined mixture rule (its `T̃` would need the walk's
//! success for pairs this mutation did not propose; [`super::Mutations::validate`] refuses it).

use super::mutation::{Change, Mutation, MutationContext, Registration};
use super::path::retrace;
use super::perturbation::{direction, follow_specular, refracts, scatters_diffusely};
use super::state::PathState;
use super::walk::trace;
use crate::bsdf::TransportMode;
use crate::light::LightKind;
use crate::manifold::{
    ChainVertex, Interaction, ManifoldSettings, NO_MATERIAL, VonMisesFisher, WalkStats,
    generalized_geometry, generalized_geometry_reverse, walk_reversibly,
};
use crate::math::DVec3;
use crate::metropolis::ImportanceKind;
use crate::path::{Vertex, VertexKind};
use crate::scene::Scene;
use crate::spectrum::Rgb;
use mcmc_core::rng::uniform;
use mcmc_core::{ChainRng, Failure};
use std::sync::Mutex;

/// Settings of the manifold perturbation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ManifoldPerturbationSettings {
    /// `λ`: the perturbation's density at the current direction is `λ²` times the sampling
    /// density there (50; the paper uses 50–500).
    pub lambda: f64,
    /// The manifold walk.
    pub walk: ManifoldSettings,
    /// Tune `λ` in a warm-up toward this acceptance of the perturbation, then freeze it
    /// ([`super::lambda_tuning`]); `None`: use `lambda` as given.
    pub target_acceptance: Option<f64>,
    /// How `λ` was chosen, when a warm-up tuned it ([`super::lambda_tuning`]).
    pub tuning: Option<super::lambda_tuning::LambdaTuning>,
    /// A deliberate error, for showing that the tests see one (`None` outside those tests).
    #[doc(hidden)]
    pub defect: Option<ManifoldDefect>,
}

/// Deliberate errors of the manifold perturbation (tests of the tests).
#[doc(hidden)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ManifoldDefect {
    /// `T` without the generalised geometry term of the first chain: the density of `x'_b` taken
    /// as the density of the direction.
    FirstChainGeometry,
}

impl Default for ManifoldPerturbationSettings {
    fn default() -> Self {
        Self {
            lambda: 50.0,
            walk: ManifoldSettings::default(),
            target_acceptance: None,
            tuning: None,
            defect: None,
        }
    }
}

impl ManifoldPerturbationSettings {
    /// Check the parameters.
    pub fn validate(&self) -> crate::Result<()> {
        let w = &self.walk;
        if self.lambda > 0.0
            && self.lambda.is_finite()
            && w.max_iterations >= 1
            && w.epsilon > 0.0
            && w.epsilon < 1.0
            && self.target_acceptance.is_none_or(|a| a > 0.0 && a < 1.0)
        {
            Ok(())
        } else {
            Err(crate::Error::InvalidParameter {
                name: "manifold perturbation".into(),
                reason: format!(
                    "need λ > 0, at least one walk iteration, 0 < ε < 1 and a target acceptance in (0, 1); got λ = {}, N = {}, ε = {}, target {:?}",
                    self.lambda, w.max_iterations, w.epsilon, self.target_acceptance
                ),
            })
        }
    }
}

/// The perturbation running toward the light (`x_a` on the camera side).
pub const TOWARD_LIGHT: Registration = Registration {
    name: "manifold-light",
    default_weight: 0.0,
    build: |c| Box::new(ManifoldPerturbation::new(c, Toward::Light)),
};

/// The perturbation running toward the camera (`x_a` on the light side).
pub const TOWARD_EYE: Registration = Registration {
    name: "manifold-eye",
    default_weight: 0.0,
    build: |c| Box::new(ManifoldPerturbation::new(c, Toward::Eye)),
};

/// Which way the perturbation runs from `x_a`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Toward {
    /// Toward `v_0` (decreasing indices).
    Light,
    /// Toward the lens (increasing indices).
    Eye,
}

/// The three vertices of a perturbation (path indices).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Strategy {
    /// Where the direction turns (or the endpoint that moves, for a position move).
    pub a: usize,
    /// The non-specular vertex the first chain reaches (`a` itself for a position move).
    pub b: usize,
    /// The kept end of the second chain.
    pub c: usize,
    /// A position move: `x_a` is an area light's point or a thin lens's point, displaced on the
    /// light or the lens by a tangential Gaussian offset of variance `ρ/(2πλ²)` (`ρ` the light's or
    /// the lens's area), the chain to `x_c` walked.
    pub position: bool,
}

impl Strategy {
    /// The lower and upper kept ends (for a position move the lower end, the light, moves).
    pub fn ends(&self) -> (usize, usize) {
        (self.a.min(self.c), self.a.max(self.c))
    }

    /// The record of the change.
    pub fn change(&self) -> Change {
        let (lo, hi) = self.ends();
        match (self.position, self.a) {
            // The light point moves: nothing kept before x_c.
            (true, 0) => {
                return Change {
                    l: -1,
                    m: hi,
                    added: hi,
                };
            }
            // The lens point moves: nothing kept after x_c.
            (true, k) => {
                return Change {
                    l: lo as isize,
                    m: k + 1,
                    added: k - lo,
                };
            }
            _ => {}
        }
        Change {
            l: lo as isize,
            m: hi,
            added: hi - lo - 1,
        }
    }
}

/// The manifold perturbation in one direction, with its walk statistics.
pub struct ManifoldPerturbation<'a> {
    scene: &'a Scene,
    toward: Toward,
    settings: ManifoldPerturbationSettings,
    importance: ImportanceKind,
    /// Walks of this mutation object (merged into `sink` when it is dropped).
    stats: Mutex<WalkStats>,
    sink: Option<&'a Mutex<WalkStats>>,
}

impl Drop for ManifoldPerturbation<'_> {
    fn drop(&mut self) {
        if let (Some(sink), Ok(mine)) = (self.sink, self.stats.lock())
            && let Ok(mut total) = sink.lock()
        {
            total.merge(&mine);
        }
    }
}

impl<'a> ManifoldPerturbation<'a> {
    /// The perturbation running `toward` on a scene.
    pub fn new(c: &MutationContext<'a, '_>, toward: Toward) -> Self {
        Self {
            scene: c.scene,
            toward,
            settings: c.settings.manifold,
            importance: c.settings.importance,
            stats: Mutex::new(WalkStats::default()),
            sink: c.walks,
        }
    }

    /// The walk statistics of this object so far.
    pub fn stats(&self) -> WalkStats {
        self.stats.lock().map(|s| *s).unwrap_or_default()
    }

    /// The strategies this direction can use on `x`.
    pub fn strategies(&self, x: &PathState) -> Vec<Strategy> {
        strategies(self.scene, &x.path, self.toward)
    }

    /// The sampling density `p(ω_i → ω_o)` at vertex `a` of `path` of leaving toward `w`: the
    /// camera's directional density, the light's emission density, or the BSDF's (arriving from the
    /// vertex behind `a`).
    fn sampling_pdf(&self, path: &super::FullPath, a: usize, w: DVec3) -> f64 {
        let v = &path.vertices[a];
        match v.kind {
            VertexKind::Camera => self.scene.camera.importance(v.p(), w).1,
            VertexKind::Light { light } => {
                self.scene.lights[light as usize].pdf_direction(v.n(), w)
            }
            VertexKind::Surface => {
                let behind = match self.toward {
                    Toward::Light => a + 1,
                    Toward::Eye => a - 1,
                };
                v.bsdf
                    .as_ref()
                    .map_or(0.0, |b| b.pdf(direction(v, &path.vertices[behind]), w))
            }
        }
    }

    /// The von Mises–Fisher distribution of the new direction at `x_a` of `path`.
    fn distribution(&self, path: &super::FullPath, s: &Strategy) -> Option<VonMisesFisher> {
        let v = &path.vertices;
        let w = direction(&v[s.a], &v[self.step(s.a)]);
        let p = self.sampling_pdf(path, s.a, w);
        (p > 0.0 && p.is_finite())
            .then(|| VonMisesFisher::with_peak(w, self.settings.lambda.powi(2) * p))
    }

    /// The next index from `i` in this direction.
    fn step(&self, i: usize) -> usize {
        match self.toward {
            Toward::Light => i - 1,
            Toward::Eye => i + 1,
        }
    }

    /// The indices strictly between `from` and `to`, walking from `from`.
    fn between(&self, from: usize, to: usize) -> Vec<usize> {
        if from < to {
            (from + 1..to).collect()
        } else {
            (to + 1..from).rev().collect()
        }
    }

    /// `ln T̃` for strategy `s` (module docs): `−∞` unless `y` is `x` with only the vertices
    /// between `s`'s ends changed, the same configuration, and a direction `D` can produce.
    fn ln_density_of(&self, x: &PathState, y: &PathState, s: &Strategy, count: usize) -> f64 {
        let never = f64::NEG_INFINITY;
        let (xp, yp) = (&x.path, &y.path);
        if yp.edges() != xp.edges() || count == 0 {
            return never;
        }
        let k = xp.edges();
        if (0..=k).any(|i| xp.specular(i) != yp.specular(i))
            || (1..k).any(|i| xp.specular(i) && refracts(xp, i) != refracts(yp, i))
        {
            return never;
        }
        if s.position {
            return self.ln_position_density(x, y, s, count);
        }
        let Some(d) = self.distribution(xp, s) else {
            return never;
        };
        let yv = &yp.vertices;
        let w = direction(&yv[s.a], &yv[self.step(s.a)]);
        let density = d.pdf(w);
        let cos_a = endpoint_cos(self.scene, &yv[s.a], w);
        let g_a = match self.settings.defect {
            Some(ManifoldDefect::FirstChainGeometry) => 1.0,
            None => chain_geometry(self.scene, yp, s.a, s.b, s.a),
        };
        let f = contribution(self.scene, yp, s);
        let i = f.map_or(0.0, |f| self.importance.of(f));
        if !(density > 0.0 && cos_a > 0.0 && g_a > 0.0 && i > 0.0) {
            return never;
        }
        let ln = density.ln() - cos_a.ln() + g_a.ln() - i.ln() - (count as f64).ln();
        if ln.is_nan() { never } else { ln }
    }

    /// The standard deviation of a position move's offset on the light of vertex `v`
    /// (`ρ/(2πλ²)` is its variance, `ρ` the light's area).
    fn position_sigma(&self, v: &Vertex) -> Option<f64> {
        let area = match v.kind {
            VertexKind::Light { light } => match self.scene.lights[light as usize] {
                LightKind::Area { area, .. } => area,
                LightKind::Point { .. } => return None,
            },
            VertexKind::Camera => {
                let r = self.scene.camera.lens_radius;
                if !(r > 0.0) {
                    return None;
                }
                std::f64::consts::PI * r * r
            }
            VertexKind::Surface => return None,
        };
        Some((area / (std::f64::consts::TAU * self.settings.lambda.powi(2))).sqrt())
    }

    /// `ln T̃` of a position move: `P(a) g(y_0 − x_0) / I(F(ȳ))` with `g` the Gaussian density
    /// per unit area of the light's plane (both points on it).
    fn ln_position_density(&self, x: &PathState, y: &PathState, s: &Strategy, count: usize) -> f64 {
        let never = f64::NEG_INFINITY;
        let (x0, y0) = (&x.path.vertices[s.a], &y.path.vertices[s.a]);
        let Some(sigma) = self.position_sigma(x0) else {
            return never;
        };
        let d = y0.p() - x0.p();
        let camera = &self.scene.camera;
        let off_lens = y0.kind == VertexKind::Camera
            && (y0.p() - camera.position()).length() > camera.lens_radius;
        if !coplanar(x0, y0) || off_lens {
            return never;
        }
        let g = (-d.length_squared() / (2.0 * sigma * sigma)).exp()
            / (std::f64::consts::TAU * sigma * sigma);
        let i =
            position_contribution(self.scene, &y.path, s).map_or(0.0, |f| self.importance.of(f));
        if !(g > 0.0 && i > 0.0) {
            return never;
        }
        let ln = g.ln() - i.ln() - (count as f64).ln();
        if ln.is_nan() { never } else { ln }
    }

    /// A position move of `x` into `y`: the light or lens point displaced, the chain to `x_c`
    /// walked.
    fn propose_position(
        &self,
        x: &PathState,
        s: &Strategy,
        rng: &mut ChainRng,
        y: &mut PathState,
    ) -> Result<(), Failure> {
        let scene = self.scene;
        let xp = &x.path;
        let xa = &xp.vertices[s.a];
        let sigma = self.position_sigma(xa).ok_or(Failure::NotApplicable)?;
        let (e1, e2) = chain_vertex(scene, xp, s.a)
            .ok_or(Failure::Failed)?
            .tangent_basis();
        let gauss = |rng: &mut ChainRng| {
            let (u1, u2) = (uniform(rng), uniform(rng));
            (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        };
        let (z1, z2) = (gauss(rng), gauss(rng));
        let p = xa.p() + (e1 * z1 + e2 * z2) * sigma;
        let ya = if s.a == 0 {
            // The light's surface at p: cast onto it from its front, along its normal.
            let scale = (scene.bounds.1 - scene.bounds.0).length();
            let n = xa.n();
            let hit = scene
                .intersect(&crate::geometry::Ray::new(p + n * (1e-4 * scale), -n))
                .ok_or(Failure::Failed)?;
            let (light, kind) = scene.light_at(hit.point.primitive).ok_or(Failure::Failed)?;
            if kind.is_delta_position() || (hit.point.p - p).length() > 1e-7 * scale {
                return Err(Failure::Failed);
            }
            Vertex {
                kind: VertexKind::Light {
                    light: light as u32,
                },
                bsdf: scene.bsdf(&hit.point).ok(),
                point: hit.point,
                wo: DVec3::ZERO,
                beta: Rgb::BLACK,
                delta: false,
                pdf_fwd: 0.0,
                pdf_rev: 0.0,
            }
        } else {
            // On the lens; a point off the aperture carries no importance (f = 0 there).
            let camera = &scene.camera;
            if (p - camera.position()).length() > camera.lens_radius {
                return Err(Failure::Failed);
            }
            Vertex {
                kind: VertexKind::Camera,
                point: scene.camera.lens_point(p),
                ..xa.clone()
            }
        };
        if !coplanar(xa, &ya) {
            return Err(Failure::Failed);
        }
        let second = self.between(s.c, s.a);
        let walked = self.walk_second_chain(xp, s.c, &second, s.a, &ya.point)?;
        let yp = &mut y.path;
        yp.vertices.clear();
        yp.vertices.extend_from_slice(&xp.vertices);
        yp.vertices[s.a] = ya;
        for (&i, v) in second.iter().zip(walked) {
            yp.vertices[i] = v;
        }
        let connection = if second.is_empty() { s.a.max(s.c) } else { 0 };
        y.finish_candidate(scene, self.importance, s.change(), connection);
        Ok(())
    }

    /// Walk the specular vertices `second` (listed from `c` toward `b`) of `path` so that the
    /// chain from the fixed `x_c` ends at `target` instead of `x_b`, and back; the new specular
    /// vertices (none when `second` is empty).
    fn walk_second_chain(
        &self,
        path: &super::FullPath,
        c: usize,
        second: &[usize],
        b: usize,
        target: &crate::geometry::SurfacePoint,
    ) -> Result<Vec<Vertex>, Failure> {
        let scene = self.scene;
        if second.is_empty() {
            return Ok(Vec::new());
        }
        let chain: Option<Vec<ChainVertex>> = std::iter::once(c)
            .chain(second.iter().copied())
            .chain(std::iter::once(b))
            .map(|i| chain_vertex(scene, path, i))
            .collect();
        let chain = chain.ok_or(Failure::Failed)?;
        let material = if target.primitive == u32::MAX {
            NO_MATERIAL
        } else {
            scene.primitive_material[target.primitive as usize]
        };
        let target = ChainVertex {
            point: *target,
            material,
            interaction: Interaction::Reflect,
            offset: [0.0; 2],
        };
        let walked = match self.stats.lock() {
            Ok(mut stats) => {
                walk_reversibly(scene, &chain, &target, &self.settings.walk, &mut stats)
            }
            Err(_) => None,
        };
        let forward = walked.ok_or(Failure::Failed)?;
        let m = forward.chain.len();
        Ok(forward.chain[1..m - 1]
            .iter()
            .map(|cv| Vertex {
                kind: VertexKind::Surface,
                bsdf: scene.bsdf(&cv.point).ok(),
                point: cv.point,
                wo: DVec3::ZERO,
                beta: Rgb::BLACK,
                delta: true,
                pdf_fwd: 0.0,
                pdf_rev: 0.0,
            })
            .collect())
    }
}

/// Whether two light vertices lie in one plane (a position move stays in its light's plane, where
/// its Gaussian density is symmetric).
fn coplanar(a: &Vertex, b: &Vertex) -> bool {
    let scale = 1.0 + a.p().length().max(b.p().length());
    a.n().dot(b.n()) > 1.0 - 1e-9 && (b.p() - a.p()).dot(a.n()).abs() <= 1e-9 * scale
}

/// `F` of a position move's result. Light point moved: `L_e` times the chain to `x_c` (specular
/// weights, the generalised geometry term from the camera end) and the camera side from `x_c`;
/// nothing is kept on the light side, so no `1/K_L`. Lens point moved: the light side up to `x_c`,
/// the chain, and `W_e`; nothing kept on the camera side, so no `1/K_C`.
pub fn position_contribution(scene: &Scene, path: &super::FullPath, s: &Strategy) -> Option<Rgb> {
    let v = &path.vertices;
    let (lo, hi) = s.ends();
    let ends = if s.a == 0 {
        v[0].le(scene, &v[1]) * camera_side(scene, path, hi)?
    } else {
        let w = direction(&v[hi], &v[hi - 1]);
        light_side(scene, path, lo)? * scene.camera.importance(v[hi].p(), w).0
    };
    let mut f = ends * chain_geometry(scene, path, lo, hi, hi);
    for i in lo + 1..hi {
        f *= vertex_factor(scene, path, i);
    }
    (f.is_finite() && !f.is_black()).then_some(f)
}

/// The light side of `path` up to its kept vertex `lo`: the light subpath's throughput arriving
/// there times `f_s(x_lo)`, or `L_e/p(x_0)` at the light.
fn light_side(scene: &Scene, path: &super::FullPath, lo: usize) -> Option<Rgb> {
    let v = &path.vertices;
    if lo == 0 {
        let VertexKind::Light { light } = v[0].kind else {
            return None;
        };
        let p = scene.light_distribution.pdf(light as usize)
            * scene.lights[light as usize].pdf_position();
        return Some(v[0].le(scene, &v[1]) * (1.0 / p));
    }
    let mut sub: Vec<Vertex> = v[..=lo].to_vec();
    if retrace(scene, &mut sub, TransportMode::Importance) <= lo {
        return None;
    }
    Some(sub[lo].beta * vertex_factor(scene, path, lo))
}

/// The camera side of `path` from its kept vertex `hi`: `f_s(x_hi)` times the camera walk's
/// throughput arriving there, or `W_e/p(lens)` at the lens.
fn camera_side(scene: &Scene, path: &super::FullPath, hi: usize) -> Option<Rgb> {
    let v = &path.vertices;
    let k = path.edges();
    if hi == k {
        let w = direction(&v[k], &v[k - 1]);
        return Some(Rgb::splat(
            scene.camera.importance(v[k].p(), w).0 / scene.camera.pdf_lens(),
        ));
    }
    let mut sub: Vec<Vertex> = v[hi..].iter().rev().cloned().collect();
    let j = k - hi;
    if retrace(scene, &mut sub, TransportMode::Radiance) <= j {
        return None;
    }
    Some(sub[j].beta * vertex_factor(scene, path, hi))
}

/// The strategies running `toward` on `path`: every non-specular `x_a` from which the first
/// non-specular vertex `x_b` is a scattering surface and a second one `x_c` exists, excluding
/// chains that start at a point light; and the position move of the endpoint on this direction's
/// side (the lens toward the light when it has an aperture, an area light toward the eye).
pub fn strategies(scene: &Scene, path: &super::FullPath, toward: Toward) -> Vec<Strategy> {
    let k = path.edges();
    let mut out = Vec::new();
    if k < 2 {
        return out;
    }
    let v = &path.vertices;
    let next_non_specular = |from: usize| -> Option<usize> {
        let mut i = from;
        loop {
            i = match toward {
                Toward::Light => i.checked_sub(1)?,
                Toward::Eye => Some(i + 1).filter(|&j| j <= k)?,
            };
            if !path.specular(i) {
                return Some(i);
            }
        }
    };
    let point_light = matches!(
        v[0].kind,
        VertexKind::Light { light } if scene.lights[light as usize].is_delta_position()
    );
    for a in 0..=k {
        if path.specular(a) {
            continue;
        }
        let Some(b) = next_non_specular(a) else {
            continue;
        };
        if b == 0 || b == k || !scatters_diffusely(&v[b]) {
            continue;
        }
        let Some(c) = next_non_specular(b) else {
            continue;
        };
        let s = Strategy {
            a,
            b,
            c,
            position: false,
        };
        let (lo, hi) = s.ends();
        // A specular chain between a point light and x_b.
        let starts_at_point_light = point_light && lo == 0 && b > 1;
        if starts_at_point_light || hi - lo < 2 {
            continue;
        }
        out.push(s);
    }
    // Position moves of a thin lens's point, toward the light.
    if toward == Toward::Light
        && scene.camera.lens_radius > 0.0
        && let Some(c) = next_non_specular(k)
    {
        out.push(Strategy {
            a: k,
            b: k,
            c,
            position: true,
        });
    }
    // Position moves of an area light's point, toward the eye.
    let area_light = matches!(
        v[0].kind,
        VertexKind::Light { light } if !scene.lights[light as usize].is_delta_position()
    );
    if toward == Toward::Eye
        && area_light
        && let Some(c) = next_non_specular(0)
    {
        out.push(Strategy {
            a: 0,
            b: 0,
            c,
            position: true,
        });
    }
    out
}

/// `|cos|` between `w` and the surface of `v` as the path's geometry terms use it: the geometric
/// normal of a surface or an area light, the camera's viewing direction at the lens, 1 at a point
/// light.
fn endpoint_cos(scene: &Scene, v: &Vertex, w: DVec3) -> f64 {
    match v.kind {
        VertexKind::Camera => scene.camera.forward().dot(w).abs(),
        VertexKind::Light { light } if scene.lights[light as usize].is_delta_position() => 1.0,
        _ => v.n().dot(w).abs(),
    }
}

/// The chain vertex of path vertex `i` (its interaction read from the path).
fn chain_vertex(scene: &Scene, path: &super::FullPath, i: usize) -> Option<ChainVertex> {
    let v = &path.vertices[i];
    let material = match v.kind {
        VertexKind::Camera => NO_MATERIAL,
        VertexKind::Light { light } => match scene.lights[light as usize] {
            LightKind::Area { primitive, .. } => scene.primitive_material[primitive as usize],
            LightKind::Point { .. } => NO_MATERIAL,
        },
        VertexKind::Surface => scene.primitive_material[v.point.primitive as usize],
    };
    let interaction = if path.specular(i) && refracts(path, i) {
        Interaction::Refract {
            eta: v.bsdf.as_ref()?.eta()?,
        }
    } else {
        Interaction::Reflect
    };
    Some(ChainVertex {
        point: v.point,
        material,
        interaction,
        offset: [0.0; 2],
    })
}

/// The generalised geometry term of `path` between the non-specular vertices `from` and `to`
/// (specular in between), seen from the end `side` (one of the two): the projected solid angle
/// at `side` per unit area at the other end. 0 when the chain is singular.
fn chain_geometry(
    scene: &Scene,
    path: &super::FullPath,
    from: usize,
    to: usize,
    side: usize,
) -> f64 {
    let (lo, hi) = (from.min(to), from.max(to));
    let Some(chain) = (lo..=hi)
        .map(|i| chain_vertex(scene, path, i))
        .collect::<Option<Vec<_>>>()
    else {
        return 0.0;
    };
    let v = &path.vertices;
    if side == hi {
        let w = direction(&v[hi], &v[hi - 1]);
        generalized_geometry_reverse(&chain, endpoint_cos(scene, &v[hi], w))
    } else {
        let w = direction(&v[lo], &v[lo + 1]);
        generalized_geometry(&chain, endpoint_cos(scene, &v[lo], w))
    }
}

/// The path-integral factor of surface vertex `i` of `path` in radiance mode (light arriving from
/// `v_{i−1}`, leaving toward `v_{i+1}`): `f_s` times the shading-normal factor, or for a specular
/// vertex the weight `ρ` of its delta in projected solid angle.
fn vertex_factor(scene: &Scene, path: &super::FullPath, i: usize) -> Rgb {
    let v = &path.vertices;
    let Some(b) = v[i].bsdf.as_ref() else {
        return Rgb::BLACK;
    };
    let to_light = direction(&v[i], &v[i - 1]);
    let to_eye = direction(&v[i], &v[i + 1]);
    let mode = TransportMode::Radiance;
    let shading = v[i].shading_factor(scene, to_eye, to_light, mode);
    if path.specular(i) {
        b.eval_delta(to_eye, to_light, mode)
            .map_or(Rgb::BLACK, |d| {
                d.f * (shading * to_light.dot(v[i].n()).abs())
            })
    } else {
        b.eval(to_eye, to_light, mode) * shading
    }
}

/// `F = f / (K_L K_C)` of `path` with the specular vertices between the ends of `s` integrated out
/// (module docs); `None` when a factor is missing.
pub fn contribution(scene: &Scene, path: &super::FullPath, s: &Strategy) -> Option<Rgb> {
    let (lo, hi) = s.ends();
    // A_lo: the light side up to x_lo, with x_lo's factor.
    let a_lo = light_side(scene, path, lo)?;
    // A_hi: the camera side down to x_hi, with x_hi's factor.
    let a_hi = camera_side(scene, path, hi)?;
    let mut f = a_lo * a_hi * vertex_factor(scene, path, s.b);
    for i in (lo + 1..hi).filter(|&i| i != s.b) {
        f *= vertex_factor(scene, path, i);
    }
    let g = chain_geometry(scene, path, lo, s.b, s.b) * chain_geometry(scene, path, s.b, hi, hi);
    let f = f * g;
    (f.is_finite() && !f.is_black()).then_some(f)
}

impl Mutation for ManifoldPerturbation<'_> {
    fn name(&self) -> &'static str {
        match self.toward {
            Toward::Light => TOWARD_LIGHT.name,
            Toward::Eye => TOWARD_EYE.name,
        }
    }

    fn suitability(&self, x: &PathState) -> f64 {
        (!self.strategies(x).is_empty()) as u8 as f64
    }

    fn propose(&self, x: &PathState, rng: &mut ChainRng, y: &mut PathState) -> Result<(), Failure> {
        let scene = self.scene;
        let list = self.strategies(x);
        if list.is_empty() {
            return Err(Failure::NotApplicable);
        }
        let pick = ((uniform(rng) * list.len() as f64) as usize).min(list.len() - 1);
        let s = list[pick];
        if s.position {
            return self.propose_position(x, &s, rng, y);
        }
        let xp = &x.path;
        let d = self.distribution(xp, &s).ok_or(Failure::Failed)?;
        let mut w = d.sample([uniform(rng), uniform(rng)]);
        let mode = match self.toward {
            Toward::Light => TransportMode::Radiance,
            Toward::Eye => TransportMode::Importance,
        };
        // The first chain: trace and follow the specular vertices to x'_b.
        let mut first: Vec<Vertex> = Vec::new();
        let path_b = self.between(s.a, s.b);
        for &i in path_b.iter().chain(std::iter::once(&s.b)) {
            let from = first.last().unwrap_or(&xp.vertices[s.a]);
            let mut v = trace(scene, from, w).ok_or(Failure::Failed)?;
            if i == s.b {
                if !scatters_diffusely(&v) {
                    return Err(Failure::Failed);
                }
            } else {
                w = follow_specular(&mut v, xp, i, mode)?;
            }
            first.push(v);
        }
        let y_b = first.last().ok_or(Failure::Failed)?.clone();
        // The second chain: walk it from x_c to x'_b (and back).
        let second = self.between(s.c, s.b);
        let walked = self.walk_second_chain(xp, s.c, &second, s.b, &y_b.point)?;
        let connection = if second.is_empty() { s.b.max(s.c) } else { 0 };
        // ȳ: x̄ with the first chain at `path_b`, x'_b, and the walked chain at `second`.
        let yp = &mut y.path;
        yp.vertices.clear();
        yp.vertices.extend_from_slice(&xp.vertices);
        for (&i, v) in path_b.iter().zip(&first) {
            yp.vertices[i] = v.clone();
        }
        yp.vertices[s.b] = y_b;
        yp.vertices[s.b].delta = false;
        for (&i, v) in second.iter().zip(walked) {
            yp.vertices[i] = v;
        }
        y.finish_candidate(scene, self.importance, s.change(), connection);
        Ok(())
    }

    fn ln_density(&self, x: &PathState, y: &PathState, change: Change) -> f64 {
        let list = self.strategies(x);
        list.iter()
            .find(|s| s.change() == change)
            .map_or(f64::NEG_INFINITY, |s| {
                self.ln_density_of(x, y, s, list.len())
            })
    }
}
