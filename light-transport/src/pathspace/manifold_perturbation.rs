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
//! **Glossy chains (§5.2).** A glossy vertex (every non-delta lobe GGX) joins a chain with its
//! specular probability `ψ` ([`SpecularProbability`], eq. 28): having chosen `x_a` uniformly among
//! the vertices where some strategy applies, the perturbation walks away from it and classifies
//! each vertex — ideal specular ones always join, diffuse ones and endpoints never, glossy ones
//! with probability `ψ` — until the first free vertex `x_b` and the next one `x_c`. A glossy vertex
//! in a chain keeps its offset `o` (its microfacet normal in its shading frame, eq. 11): the first
//! chain scatters about it, the walk keeps it. The classification's probability
//! `Π ψ(x_i) (1 − ψ(x_b)) (1 − ψ(x_c))` enters `T`, and since `T` now lives on an offset manifold
//! while `f` is a density over the glossy vertices' areas, `f` is taken in the measure of
//! `(x_b, o)`: `F · |det ∂[x_b, x_glossy]/∂[x_b, o_glossy]|` (eq. 12's determinant; the
//! constraint Jacobian over `x_{a+1} … x_{c−1}`, `x_b`'s rows made the identity, inverted, the
//! rows and columns of ideal specular vertices dropped). `F` then keeps the glossy vertices'
//! BSDFs in area measure, and the generalised geometry terms run between consecutive non-delta
//! vertices. The record of a move names `x_b` ([`Change::pivot`]), which tells apart strategies
//! that share their ends.
//!
//! Not yet: chains that start at a point light (its position has no area measure for the
//! generalised geometry term), and the combined mixture rule (its `T̃` would need the walk's
//! success for pairs this mutation did not propose; [`super::Mutations::validate`] refuses it).

use super::mutation::{Change, Mutation, MutationContext, Registration};
use super::path::{Walks, arriving_throughput};
use super::perturbation::{direction, follow_specular, refracts, scatters_diffusely};
use super::state::PathState;
use super::walk::trace_between;
use crate::bsdf::TransportMode;
use crate::light::LightKind;
use crate::manifold::{
    Chain, ChainJacobian, ChainVertex, Interaction, ManifoldSettings, NO_MATERIAL, PerVertex,
    SpecularProbability, VonMisesFisher, WalkStats, Walked, chain_jacobian_into, constraint,
    generalized_geometry, generalized_geometry_reverse, ordinary_geometry, scatter,
    walk_manifold_into, walk_reversibly_into,
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
    /// When glossy vertices join chains (`ψ`, §5.2).
    pub specular: SpecularProbability,
    /// Tune `λ` in a warm-up toward this acceptance of the perturbation, then freeze it
    /// ([`super::lambda_tuning`]); `None`: use `lambda` as given.
    pub target_acceptance: Option<f64>,
    /// How `λ` was chosen, when a warm-up tuned it ([`super::lambda_tuning`]).
    pub tuning: Option<super::lambda_tuning::LambdaTuning>,
    /// How `Δθ` of `ψ` was measured, when a pilot did it ([`super::normal_change`]).
    pub pilot: Option<super::normal_change::NormalChange>,
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
    /// Moves accepted without walking back (non-reversible moves kept).
    SkipReverseWalk,
    /// The von Mises–Fisher density without its `κ` factor (`e^{κ(cos θ − 1)} / 2π(1 − e^{−2κ})`).
    VmfNormaliser,
    /// Glossy chains without eq. 12's determinant.
    GlossyDeterminant,
}

impl Default for ManifoldPerturbationSettings {
    fn default() -> Self {
        Self {
            lambda: 50.0,
            walk: ManifoldSettings::default(),
            specular: SpecularProbability::default(),
            target_acceptance: None,
            tuning: None,
            pilot: None,
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
            && self.specular.is_valid()
        {
            Ok(())
        } else {
            Err(crate::Error::InvalidParameter {
                name: "manifold perturbation".into(),
                reason: format!(
                    "need λ > 0, at least one walk iteration, 0 < ε < 1, a target acceptance in (0, 1), a quantile q in (0, 1) and 0 ≤ Δθ ≤ π; got λ = {}, N = {}, ε = {}, target {:?}, q = {}, Δθ = {}",
                    self.lambda,
                    w.max_iterations,
                    w.epsilon,
                    self.target_acceptance,
                    self.specular.quantile,
                    self.specular.delta_theta()
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

/// The strategies of a path ([`strategies`]): on the stack for paths of up to 15 edges, since the
/// mutation lists them at every proposal, suitability and density.
pub type Strategies = smallvec::SmallVec<[Strategy; 16]>;

/// The three vertices of a perturbation (path indices).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Strategy {
    /// Where the direction turns (or the endpoint that moves, for a position move).
    pub a: usize,
    /// The free vertex the first chain reaches (`a` itself for a position move).
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
                    pivot: self.b,
                };
            }
            // The lens point moves: nothing kept after x_c.
            (true, k) => {
                return Change {
                    l: lo as isize,
                    m: k + 1,
                    added: k - lo,
                    pivot: self.b,
                };
            }
            _ => {}
        }
        Change {
            l: lo as isize,
            m: hi,
            added: hi - lo - 1,
            pivot: self.b,
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

    /// The strategies this direction can use on `x` with every glossy vertex free (the candidates
    /// for `x_a`; [`ManifoldPerturbation::classify`] then draws which glossy vertices join chains).
    pub fn strategies(&self, x: &PathState) -> Strategies {
        strategies(self.scene, &x.path, self.toward)
    }

    /// `ψ` of vertex `i` of `path`: 1 for ideal specular vertices, 0 at the endpoints and diffuse
    /// vertices, eq. 28 for glossy ones.
    pub fn specular_probability(&self, path: &super::FullPath, i: usize) -> f64 {
        if i == 0 || i >= path.edges() {
            return 0.0;
        }
        let v = &path.vertices[i];
        if v.delta {
            return 1.0;
        }
        v.bsdf
            .as_ref()
            .map_or(0.0, |b| self.settings.specular.of_bsdf(b))
    }

    /// The first vertex after `from` (in this direction) that the classification leaves free.
    fn next_free(&self, path: &super::FullPath, from: usize, rng: &mut ChainRng) -> Option<usize> {
        let k = path.edges();
        let mut i = from;
        loop {
            i = match self.toward {
                Toward::Light => i.checked_sub(1)?,
                Toward::Eye => Some(i + 1).filter(|&j| j <= k)?,
            };
            let psi = self.specular_probability(path, i);
            if psi >= 1.0 {
                continue;
            }
            if psi <= 0.0 || uniform(rng) >= psi {
                return Some(i);
            }
        }
    }

    /// The strategy from candidate `candidate`'s `x_a` (or position move) once the vertices after
    /// it are classified (§5.2): `None` when the classification leaves no valid strategy.
    pub fn classify(
        &self,
        path: &super::FullPath,
        candidate: &Strategy,
        rng: &mut ChainRng,
    ) -> Option<Strategy> {
        let a = candidate.a;
        let b = if candidate.position {
            a
        } else {
            self.next_free(path, a, rng)?
        };
        let c = self.next_free(path, b, rng)?;
        let s = Strategy {
            a,
            b,
            c,
            position: candidate.position,
        };
        valid(self.scene, path, &s).then_some(s)
    }

    /// `ln` of the probability that the classification of `path` produces `s`:
    /// `Π ψ(x_i) (1 − ψ(x_b)) (1 − ψ(x_c))` over the chains' vertices (eq. 12).
    pub fn ln_classification(&self, path: &super::FullPath, s: &Strategy) -> f64 {
        let (lo, hi) = s.ends();
        let mut p = 1.0 - self.specular_probability(path, s.c);
        for i in lo + 1..hi {
            let psi = self.specular_probability(path, i);
            p *= if i == s.b { 1.0 - psi } else { psi };
        }
        if p > 0.0 { p.ln() } else { f64::NEG_INFINITY }
    }

    /// The strategy a record of this direction names on a path of `k` edges.
    fn strategy_of(&self, change: Change, k: usize) -> Option<Strategy> {
        let s = if change.l < 0 {
            (self.toward == Toward::Eye).then_some(Strategy {
                a: 0,
                b: 0,
                c: change.m,
                position: true,
            })?
        } else if change.m == k + 1 {
            (self.toward == Toward::Light).then_some(Strategy {
                a: k,
                b: k,
                c: change.l as usize,
                position: true,
            })?
        } else {
            let (lo, hi) = (change.l as usize, change.m);
            let (a, c) = match self.toward {
                Toward::Light => (hi, lo),
                Toward::Eye => (lo, hi),
            };
            let b = change.pivot;
            if !(lo < b && b < hi) {
                return None;
            }
            Strategy {
                a,
                b,
                c,
                position: false,
            }
        };
        (s.change() == change).then_some(s)
    }

    /// Follow the direction arriving at the glossy vertex `v` (traced as vertex `i` of the first
    /// chain) about the microfacet normal that `x̄`'s vertex `i` has in its shading frame: the
    /// direction leaving it.
    fn follow_offset(
        &self,
        v: &mut Vertex,
        x: &super::FullPath,
        i: usize,
    ) -> Result<DVec3, Failure> {
        let want = chain_vertex(self.scene, x, i, true).ok_or(Failure::Failed)?;
        let here = ChainVertex::new(
            self.scene,
            v.point,
            self.scene.primitive_material[v.point.primitive as usize],
            want.interaction,
            want.offset,
        );
        if here.material != want.material {
            return Err(Failure::Failed);
        }
        let h = here.half_vector(v.wo).ok_or(Failure::Failed)?;
        let eta = here.relative_eta(v.wo);
        let refract = matches!(here.interaction, Interaction::Refract { .. });
        let wo = scatter(v.wo, h, eta, refract, v.point.n).ok_or(Failure::Failed)?;
        v.delta = false;
        Ok(wo)
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
    fn between(&self, from: usize, to: usize) -> smallvec::SmallVec<[usize; 16]> {
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
        // The classification, and the glossy vertices of the chains: they scatter alike and keep
        // their offsets (a symmetric check; the walk meets its target to ε, the offsets to ~1e-6).
        let classification = self.ln_classification(xp, s);
        if classification == never {
            return never;
        }
        let (lo, hi) = s.ends();
        for i in (lo + 1..hi).filter(|&i| i != s.b && !xp.specular(i)) {
            let same = match (
                chain_vertex(self.scene, xp, i, true),
                chain_vertex(self.scene, yp, i, true),
            ) {
                (Some(u), Some(v)) => {
                    u.interaction == v.interaction
                        && (u.offset[0] - v.offset[0]).hypot(u.offset[1] - v.offset[1]) < 1e-3
                }
                _ => false,
            };
            if !same {
                return never;
            }
        }
        let det = match self.settings.defect {
            Some(ManifoldDefect::GlossyDeterminant) => Some(1.0),
            _ => glossy_determinant(self.scene, yp, s),
        };
        let Some(det) = det else {
            return never;
        };
        let chains = classification - det.ln();
        if s.position {
            return self.ln_position_density(x, y, s, count) + chains;
        }
        let Some(d) = self.distribution(xp, s) else {
            return never;
        };
        let yv = &yp.vertices;
        let w = direction(&yv[s.a], &yv[self.step(s.a)]);
        let density = match self.settings.defect {
            Some(ManifoldDefect::VmfNormaliser) if d.kappa > 0.0 => d.pdf(w) / d.kappa,
            _ => d.pdf(w),
        };
        let cos_a = endpoint_cos(self.scene, &yv[s.a], w);
        // The chain at x_a seen from x_a (the density's) and both chains from their camera ends
        // (F's): the chain at x_a is built once for both.
        let (segments, g_a) = segments_and_first(self.scene, yp, s);
        let g_a = match self.settings.defect {
            Some(ManifoldDefect::FirstChainGeometry) => 1.0,
            _ => g_a,
        };
        let f = contribution(self.scene, yp, Some(&y.walks), s, segments);
        let i = f.map_or(0.0, |f| self.importance.of(f));
        if !(density > 0.0 && cos_a > 0.0 && g_a > 0.0 && i > 0.0) {
            return never;
        }
        let ln = density.ln() - cos_a.ln() + g_a.ln() - i.ln() - (count as f64).ln() + chains;
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
        let i = position_contribution(self.scene, &y.path, Some(&y.walks), s)
            .map_or(0.0, |f| self.importance.of(f));
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
        let (e1, e2) = chain_vertex(scene, xp, s.a, false)
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
        let yv = &mut y.path.vertices;
        yv.clone_from(&xp.vertices);
        self.walk_second_chain(xp, s.c, &second, s.a, &ya.point, yv)?;
        yv[s.a] = ya;
        let connection = if second.is_empty() { s.a.max(s.c) } else { 0 };
        y.finish_candidate(scene, self.importance, x, s.change(), connection);
        Ok(())
    }

    /// Walk the specular vertices `second` (listed from `c` toward `b`) of `path` so that the
    /// chain from the fixed `x_c` ends at `target` instead of `x_b`, and back; the new specular
    /// vertices go into their slots of `out` (nothing to do when `second` is empty).
    fn walk_second_chain(
        &self,
        path: &super::FullPath,
        c: usize,
        second: &[usize],
        b: usize,
        target: &crate::geometry::SurfacePoint,
        out: &mut [Vertex],
    ) -> Result<(), Failure> {
        let scene = self.scene;
        if second.is_empty() {
            return Ok(());
        }
        let mut chain = Chain::new();
        let vertices = std::iter::once((c, false))
            .chain(second.iter().map(|&i| (i, true)))
            .chain(std::iter::once((b, false)));
        if !push_chain(scene, path, vertices, &mut chain) {
            return Err(Failure::Failed);
        }
        let material = if target.primitive == u32::MAX {
            NO_MATERIAL
        } else {
            scene.primitive_material[target.primitive as usize]
        };
        let target = ChainVertex::new(scene, *target, material, Interaction::Reflect, [0.0; 2]);
        // The walk is written in place here (a chain is about a kilobyte).
        let mut forward = Walked::default();
        let walked = match self.stats.lock() {
            Ok(mut stats) if self.settings.defect == Some(ManifoldDefect::SkipReverseWalk) => {
                let result =
                    walk_manifold_into(scene, &chain, &target, &self.settings.walk, &mut forward);
                stats.record(chain.len() - 2, result.map(|()| forward.iterations));
                result.is_ok()
            }
            Ok(mut stats) => walk_reversibly_into(
                scene,
                &chain,
                &target,
                &self.settings.walk,
                &mut stats,
                &mut forward,
            ),
            Err(_) => false,
        };
        if !walked {
            return Err(Failure::Failed);
        }
        let m = forward.chain.len();
        for (cv, &i) in forward.chain[1..m - 1].iter().zip(second) {
            let v = &mut out[i];
            v.set_surface(&cv.point, DVec3::ZERO, Rgb::BLACK);
            v.delta = path.specular(i);
            scene.bsdf_into(&cv.point, &mut v.bsdf);
        }
        Ok(())
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
pub fn position_contribution(
    scene: &Scene,
    path: &super::FullPath,
    walks: Option<&Walks>,
    s: &Strategy,
) -> Option<Rgb> {
    let v = &path.vertices;
    let (lo, hi) = s.ends();
    let ends = if s.a == 0 {
        v[0].le(scene, &v[1]) * camera_side(scene, path, walks, hi)?
    } else {
        let w = direction(&v[hi], &v[hi - 1]);
        light_side(scene, path, walks, lo)? * scene.camera.importance(v[hi].p(), w).0
    };
    let mut f = ends * segments_geometry(scene, path, lo, hi);
    for i in lo + 1..hi {
        f *= vertex_factor(scene, path, i);
    }
    (f.is_finite() && !f.is_black()).then_some(f)
}

/// The light side of `path` up to its kept vertex `lo`: the light subpath's throughput arriving
/// there times `f_s(x_lo)`, or `L_e/p(x_0)` at the light. The throughput is read from `walks`
/// (the path's evaluation, [`Walks::light_arriving`]) when they are the path's, walked otherwise.
fn light_side(
    scene: &Scene,
    path: &super::FullPath,
    walks: Option<&Walks>,
    lo: usize,
) -> Option<Rgb> {
    let v = &path.vertices;
    if lo == 0 {
        let VertexKind::Light { light } = v[0].kind else {
            return None;
        };
        let p = scene.light_distribution.pdf(light as usize)
            * scene.lights[light as usize].pdf_position();
        return Some(v[0].le(scene, &v[1]) * (1.0 / p));
    }
    let beta = match walks.and_then(|w| w.light_arriving(v, lo)) {
        Some(beta) => beta?,
        None => arriving_throughput(scene, lo + 1, |i| &v[i], TransportMode::Importance)?,
    };
    Some(beta * vertex_factor(scene, path, lo))
}

/// The camera side of `path` from its kept vertex `hi`: `f_s(x_hi)` times the camera walk's
/// throughput arriving there (from `walks` when they are the path's, as for [`light_side`]), or
/// `W_e/p(lens)` at the lens.
fn camera_side(
    scene: &Scene,
    path: &super::FullPath,
    walks: Option<&Walks>,
    hi: usize,
) -> Option<Rgb> {
    let v = &path.vertices;
    let k = path.edges();
    if hi == k {
        let w = direction(&v[k], &v[k - 1]);
        return Some(Rgb::splat(
            scene.camera.importance(v[k].p(), w).0 / scene.camera.pdf_lens(),
        ));
    }
    let beta = match walks.and_then(|w| w.camera_arriving(v, hi)) {
        Some(beta) => beta?,
        None => arriving_throughput(scene, k - hi + 1, |i| &v[k - i], TransportMode::Radiance)?,
    };
    Some(beta * vertex_factor(scene, path, hi))
}

/// The strategies running `toward` on `path` with every glossy vertex free (the candidates for
/// `x_a`): every non-delta `x_a` from which the next non-delta vertex `x_b` is a scattering surface
/// and a further one `x_c` exists, excluding chains that start at a point light; and the position
/// move of the endpoint on this direction's side (the lens toward the light when it has an
/// aperture, an area light toward the eye).
pub fn strategies(scene: &Scene, path: &super::FullPath, toward: Toward) -> Strategies {
    strategies_of(scene, path, toward).collect()
}

/// Whether [`strategies`] has any: the mutation's suitability, which needs only the first.
pub fn has_strategy(scene: &Scene, path: &super::FullPath, toward: Toward) -> bool {
    strategies_of(scene, path, toward).next().is_some()
}

/// The strategies of [`strategies`] one by one, in its order.
fn strategies_of<'p>(
    scene: &'p Scene,
    path: &'p super::FullPath,
    toward: Toward,
) -> impl Iterator<Item = Strategy> + 'p {
    let k = path.edges();
    // No strategy on a path of fewer than two edges.
    let ends = if k < 2 { 0..0 } else { 0..k + 1 };
    let next_non_specular = move |from: usize| -> Option<usize> {
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
    let directions = ends.clone().filter_map(move |a| {
        if path.specular(a) {
            return None;
        }
        let b = next_non_specular(a)?;
        let c = next_non_specular(b)?;
        let s = Strategy {
            a,
            b,
            c,
            position: false,
        };
        valid(scene, path, &s).then_some(s)
    });
    let any = !ends.is_empty();
    // Position moves of a thin lens's point, toward the light.
    let lens = (any && toward == Toward::Light && scene.camera.lens_radius > 0.0)
        .then(|| next_non_specular(k))
        .flatten()
        .map(move |c| Strategy {
            a: k,
            b: k,
            c,
            position: true,
        });
    // Position moves of an area light's point, toward the eye.
    let area_light = any
        && matches!(
            path.vertices[0].kind,
            VertexKind::Light { light } if !scene.lights[light as usize].is_delta_position()
        );
    let light = (toward == Toward::Eye && area_light)
        .then(|| next_non_specular(0))
        .flatten()
        .map(|c| Strategy {
            a: 0,
            b: 0,
            c,
            position: true,
        });
    directions.chain(lens).chain(light)
}

/// Whether `s` is a strategy on `path`: a direction move's `x_b` is a scattering surface (not an
/// endpoint) and no chain starts at a point light.
fn valid(scene: &Scene, path: &super::FullPath, s: &Strategy) -> bool {
    let k = path.edges();
    let v = &path.vertices;
    if s.position {
        return s.c != s.a;
    }
    if s.b == 0 || s.b == k || !scatters_diffusely(&v[s.b]) {
        return false;
    }
    let point_light = matches!(
        v[0].kind,
        VertexKind::Light { light } if scene.lights[light as usize].is_delta_position()
    );
    // A specular chain between a point light and x_b.
    let (lo, _) = s.ends();
    !(point_light && lo == 0 && s.b > 1)
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

/// The chain vertex of path vertex `i`. As a chain's end (`specular` false) it only carries its
/// point and material. Inside a chain it carries its interaction (reflection or refraction, read
/// from the path) and its offset: 0 at an ideal specular vertex, at a glossy one its microfacet
/// normal — the normalised generalised half vector of its two path neighbours — in its shading
/// frame (eq. 11).
fn chain_vertex(
    scene: &Scene,
    path: &super::FullPath,
    i: usize,
    specular: bool,
) -> Option<ChainVertex> {
    let mut chain = Chain::new();
    push_chain(scene, path, [(i, specular)], &mut chain).then(|| chain[0])
}

/// Push the chain vertices of `path` at `vertices` (each index with whether it is to be specular,
/// [`chain_vertex`]) onto `chain`, in order; `false` when one has none. Each vertex is built in
/// its slot of the list (a vertex is 264 bytes; returning each from a call and moving it in was
/// a quarter of MEMLT's copying on `pool`).
fn push_chain(
    scene: &Scene,
    path: &super::FullPath,
    vertices: impl IntoIterator<Item = (usize, bool)>,
    chain: &mut Chain,
) -> bool {
    for (i, specular) in vertices {
        let v = &path.vertices[i];
        let material = match v.kind {
            VertexKind::Camera => NO_MATERIAL,
            VertexKind::Light { light } => match scene.lights[light as usize] {
                LightKind::Area { primitive, .. } => scene.primitive_material[primitive as usize],
                LightKind::Point { .. } => NO_MATERIAL,
            },
            VertexKind::Surface => scene.primitive_material[v.point.primitive as usize],
        };
        chain.push(ChainVertex::new(
            scene,
            v.point,
            material,
            Interaction::Reflect,
            [0.0; 2],
        ));
        if !specular {
            continue;
        }
        let Some(cv) = chain.last_mut() else {
            return false;
        };
        if refracts(path, i) {
            let Some(eta) = v.bsdf.as_ref().and_then(|b| b.eta()) else {
                return false;
            };
            cv.interaction = Interaction::Refract { eta };
        }
        if !path.specular(i) {
            let Some(o) = constraint(path.vertices[i - 1].p(), cv, path.vertices[i + 1].p()) else {
                return false;
            };
            cv.offset = [o[0], o[1]];
        }
    }
    true
}

/// eq. 12's change of variables at `path` for strategy `s`: `|det ∂[x_b, x_g…]/∂[x_b, o_g…]|`
/// over the glossy vertices `x_g` of its chains (1 when there are none). The constraint
/// Jacobian over the vertices strictly between the ends, `x_b`'s rows replaced by the identity
/// (`x_b` is an end for a position move), is inverted; the rows and columns of the non-delta
/// vertices are kept. `None` when it is singular.
pub fn glossy_determinant(scene: &Scene, path: &super::FullPath, s: &Strategy) -> Option<f64> {
    let (lo, hi) = s.ends();
    if (lo + 1..hi).all(|i| i == s.b || path.specular(i)) {
        return Some(1.0);
    }
    let mut chain = Chain::new();
    let vertices = (lo..=hi).map(|i| (i, i != lo && i != hi && i != s.b));
    if !push_chain(scene, path, vertices, &mut chain) {
        return None;
    }
    let n = chain.len();
    let m = n - 2;
    let mut j = ChainJacobian::default();
    if !chain_jacobian_into(
        &chain,
        chain[0].tangent_basis(),
        chain[n - 1].tangent_basis(),
        &mut j,
    ) {
        return None;
    }
    let mut a = nalgebra::DMatrix::<f64>::zeros(2 * m, 2 * m);
    for r in 0..m {
        if lo + 1 + r == s.b {
            a[(2 * r, 2 * r)] = 1.0;
            a[(2 * r + 1, 2 * r + 1)] = 1.0;
            continue;
        }
        let mut put = |col: usize, block: &crate::manifold::Mat2| {
            a.fixed_view_mut::<2, 2>(2 * r, 2 * col).copy_from(block);
        };
        put(r, &j.a.diagonal[r]);
        if r > 0 {
            put(r - 1, &j.a.lower[r]);
        }
        if r + 1 < m {
            put(r + 1, &j.a.upper[r]);
        }
    }
    let inverse = a.try_inverse()?;
    let keep: PerVertex<usize> = (0..m).filter(|&r| !path.specular(lo + 1 + r)).collect();
    let size = 2 * keep.len();
    let sub = nalgebra::DMatrix::from_fn(size, size, |r, c| {
        inverse[(2 * keep[r / 2] + r % 2, 2 * keep[c / 2] + c % 2)]
    });
    let d = sub.determinant().abs();
    (d > 0.0 && d.is_finite()).then_some(d)
}

/// The product of the generalised geometry terms of `path` between consecutive non-delta vertices
/// from `lo` to `hi`, each seen from its camera end (the convention of radiance-mode deltas,
/// module docs).
fn segments_geometry(scene: &Scene, path: &super::FullPath, lo: usize, hi: usize) -> f64 {
    free_vertices(path, lo, hi)
        .windows(2)
        .map(|w| chain_geometry(scene, path, w[0], w[1], w[1]))
        .product()
}

/// `lo`, `hi` and the non-delta vertices of `path` between them.
fn free_vertices(path: &super::FullPath, lo: usize, hi: usize) -> smallvec::SmallVec<[usize; 16]> {
    (lo..=hi)
        .filter(|&i| i == lo || i == hi || !path.specular(i))
        .collect()
}

/// [`segments_geometry`] between the ends of strategy `s`, and the generalised geometry term of
/// the chain from `x_a` to `x_b` seen from `x_a` ([`chain_geometry`]`(a, b, a)`), bit for bit,
/// with that chain built once for both.
fn segments_and_first(scene: &Scene, path: &super::FullPath, s: &Strategy) -> (f64, f64) {
    let (lo, hi) = s.ends();
    let mut first = None;
    let segments = free_vertices(path, lo, hi)
        .windows(2)
        .map(|w| {
            if w.contains(&s.a) && w.contains(&s.b) {
                let sides = chain_geometry_sides(scene, path, w[0], w[1], [s.a == w[0], true]);
                first = Some(sides[usize::from(s.a == w[1])]);
                sides[1]
            } else {
                chain_geometry(scene, path, w[0], w[1], w[1])
            }
        })
        .product();
    let first = first.unwrap_or_else(|| chain_geometry(scene, path, s.a, s.b, s.a));
    (segments, first)
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
    chain_geometry_sides(scene, path, lo, hi, [side == lo, side == hi])[usize::from(side == hi)]
}

/// [`chain_geometry`] of the chain from `lo` to `hi` (`lo < hi`) seen from `lo` and from `hi`,
/// each where `sides` asks for it (0 otherwise), the chain built once.
fn chain_geometry_sides(
    scene: &Scene,
    path: &super::FullPath,
    lo: usize,
    hi: usize,
    sides: [bool; 2],
) -> [f64; 2] {
    let v = &path.vertices;
    if hi == lo + 1 {
        // No specular vertex between: the ordinary geometry term, without chain vertices.
        let seen_from = |side: usize, far: usize| {
            let w = direction(&v[side], &v[far]);
            let cos = endpoint_cos(scene, &v[side], w);
            ordinary_geometry(v[side].p(), cos, v[far].p(), v[far].point.n).unwrap_or(0.0)
        };
        return [
            if sides[0] { seen_from(lo, hi) } else { 0.0 },
            if sides[1] { seen_from(hi, lo) } else { 0.0 },
        ];
    }
    let mut chain = Chain::new();
    if !push_chain(
        scene,
        path,
        (lo..=hi).map(|i| (i, i != lo && i != hi)),
        &mut chain,
    ) {
        return [0.0; 2];
    }
    let from_lo = sides[0].then(|| {
        let w = direction(&v[lo], &v[lo + 1]);
        generalized_geometry(&chain, endpoint_cos(scene, &v[lo], w))
    });
    let from_hi = sides[1].then(|| {
        let w = direction(&v[hi], &v[hi - 1]);
        generalized_geometry_reverse(&chain, endpoint_cos(scene, &v[hi], w))
    });
    [from_lo.unwrap_or(0.0), from_hi.unwrap_or(0.0)]
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
/// (module docs), given its chains' [`segments_geometry`] `segments`; `None` when a factor is
/// missing. `walks`, the path's own evaluation, spares walking the two kept sides again
/// ([`Walks::light_arriving`]; the same numbers bit for bit).
pub fn contribution(
    scene: &Scene,
    path: &super::FullPath,
    walks: Option<&Walks>,
    s: &Strategy,
    segments: f64,
) -> Option<Rgb> {
    let (lo, hi) = s.ends();
    // A_lo: the light side up to x_lo, with x_lo's factor.
    let a_lo = light_side(scene, path, walks, lo)?;
    // A_hi: the camera side down to x_hi, with x_hi's factor.
    let a_hi = camera_side(scene, path, walks, hi)?;
    let mut f = a_lo * a_hi;
    for i in lo + 1..hi {
        f *= vertex_factor(scene, path, i);
    }
    let f = f * segments;
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
        has_strategy(self.scene, &x.path, self.toward) as u8 as f64
    }

    fn propose(&self, x: &PathState, rng: &mut ChainRng, y: &mut PathState) -> Result<(), Failure> {
        let scene = self.scene;
        let list = self.strategies(x);
        if list.is_empty() {
            return Err(Failure::NotApplicable);
        }
        let pick = ((uniform(rng) * list.len() as f64) as usize).min(list.len() - 1);
        let s = self
            .classify(&x.path, &list[pick], rng)
            .ok_or(Failure::Failed)?;
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
        // ȳ is walked in place: a copy of x̄ whose first chain (`path_b`, then x'_b) is traced
        // into its slots from x_a, and whose second chain is walked from x_c to x'_b.
        let yv = &mut y.path.vertices;
        yv.clone_from(&xp.vertices);
        let path_b = self.between(s.a, s.b);
        let mut from = s.a;
        for &i in path_b.iter().chain(std::iter::once(&s.b)) {
            if !trace_between(scene, yv, from, i, w) {
                return Err(Failure::Failed);
            }
            let v = &mut yv[i];
            if i == s.b {
                if !scatters_diffusely(v) {
                    return Err(Failure::Failed);
                }
            } else if xp.specular(i) {
                w = follow_specular(v, xp, i, mode)?;
            } else {
                w = self.follow_offset(v, xp, i)?;
            }
            from = i;
        }
        let second = self.between(s.c, s.b);
        let target = yv[s.b].point;
        self.walk_second_chain(xp, s.c, &second, s.b, &target, yv)?;
        let connection = if second.is_empty() { s.b.max(s.c) } else { 0 };
        y.finish_candidate(scene, self.importance, x, s.change(), connection);
        Ok(())
    }

    fn ln_density(&self, x: &PathState, y: &PathState, change: Change) -> f64 {
        let Some(s) = self.strategy_of(change, x.path.edges()) else {
            return f64::NEG_INFINITY;
        };
        // How many strategies x̄ has, and whether the change's is one: one pass, no list.
        let (mut count, mut listed) = (0, false);
        for c in strategies_of(self.scene, &x.path, self.toward) {
            count += 1;
            listed |= c.a == s.a && c.position == s.position;
        }
        if listed {
            self.ln_density_of(x, y, &s, count)
        } else {
            f64::NEG_INFINITY
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pathspace::walk::sample_path;
    use crate::sampler::IndependentStream;
    use crate::scene::{Projection, builtin};
    use mcmc_core::rng::stream;

    /// The mutation's suitability (whether a path has a strategy, from the first one found) agrees
    /// with the whole list, and the list is the direct enumeration of its definition, on paths of
    /// every length and strategy in every built-in scene, both directions. Fails when the lazy list
    /// drops the position moves or lists a strategy on a path too short for any.
    #[test]
    fn the_first_strategy_decides_suitability_as_the_list_does() {
        let mut rng = stream(3, 0);
        let (mut paths, mut with, mut position) = (0, 0, 0);
        // Every built-in, as it is (a pinhole) and with a thin lens (its position moves).
        let names = builtin::all();
        let scenes = names.iter().flat_map(|&name| {
            [0.0, 0.02].map(|radius| {
                let mut desc = builtin::builtin(name).unwrap();
                if let Some(camera) = desc.camera.as_mut() {
                    let Projection::Perspective { lens_radius, .. } = &mut camera.projection;
                    *lens_radius = radius;
                }
                (name, Scene::new(&desc, Some((32, 24))).unwrap())
            })
        });
        for (name, scene) in scenes {
            let mut sampler = IndependentStream::new(stream(4, 0));
            let mut state = PathState::default();
            for _ in 0..3000 {
                let k = 1 + (uniform(&mut rng) * 6.0) as usize;
                let s = ((uniform(&mut rng) * (k + 2) as f64) as usize).min(k + 1);
                sampler.new_sample();
                if sample_path(&scene, k, s, &mut sampler, &mut state).is_none() {
                    continue;
                }
                let path = &state.path;
                paths += 1;
                for toward in [Toward::Light, Toward::Eye] {
                    let list = strategies(&scene, path, toward);
                    assert_eq!(has_strategy(&scene, path, toward), !list.is_empty());
                    with += !list.is_empty() as usize;
                    position += list.iter().filter(|s| s.position).count();
                    // The definition, directly: direction moves from every non-specular x_a
                    // whose next two non-specular vertices exist, then the position move.
                    let nns = |from: usize| -> Option<usize> {
                        let mut order: Vec<usize> = match toward {
                            Toward::Light => (0..from).rev().collect(),
                            Toward::Eye => (from + 1..=k).collect(),
                        };
                        order.retain(|&i| !path.specular(i));
                        order.first().copied()
                    };
                    let mut expected: Vec<Strategy> = Vec::new();
                    if k >= 2 {
                        for a in (0..=k).filter(|&a| !path.specular(a)) {
                            if let Some(b) = nns(a)
                                && let Some(c) = nns(b)
                            {
                                let st = Strategy {
                                    a,
                                    b,
                                    c,
                                    position: false,
                                };
                                if valid(&scene, path, &st) {
                                    expected.push(st);
                                }
                            }
                        }
                        let light_moves = matches!(path.vertices[0].kind,
                            VertexKind::Light { light } if !scene.lights[light as usize].is_delta_position());
                        let end = match toward {
                            Toward::Light if scene.camera.lens_radius > 0.0 => Some(k),
                            Toward::Eye if light_moves => Some(0),
                            _ => None,
                        };
                        if let Some(a) = end
                            && let Some(c) = nns(a)
                        {
                            expected.push(Strategy {
                                a,
                                b: a,
                                c,
                                position: true,
                            });
                        }
                    }
                    assert_eq!(
                        list.as_slice(),
                        expected.as_slice(),
                        "{name}, k = {k}, {toward:?}"
                    );
                }
            }
        }
        assert!(
            paths > 3000 && with > 5000 && position > 3000,
            "{paths} {with} {position}"
        );
    }
}
