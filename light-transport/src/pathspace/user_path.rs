//! User paths and the user-path proposal of Metropolis photon sampling (Fan, Chenney & Lai 2005,
//! §5.1–5.2).
//!
//! **The file** (`--user-paths FILE`). Lines starting with `#` and blank lines are ignored. A line
//! `path` (optionally `path beta=<degrees>`, the default cone half-angle of its segments) starts a
//! path; each following line is a point `x y z` or `x y z beta`, where `beta` (degrees) is the cone
//! half-angle of the segment arriving at that point. The first point lies on a light, the last on
//! a surface that scatters diffusely; the points between are scattering points, and those on
//! surfaces that only scatter specularly are followed as mirror or refraction bounces (which one is
//! read from the path's geometry). Every segment must be unoccluded. A bad file is an error naming
//! its file and line.
//!
//! **The proposal.** Choose a user path `ū = u_0 … u_m` uniformly; draw `x'_0` uniformly on the
//! light `u_0` lies on; for `j = 0 … m − 1` draw the direction leaving `x'_j` in the cone of
//! half-angle `β_j` about `x'_j → u_{j+1}` (angle uniform in `[0, β_j)`, azimuth uniform) — or,
//! where `u_j` is specular, follow the same specular bounce — and trace it to `x'_{j+1}`, which
//! must be specular exactly where `u_{j+1}` is. Then `x'_m` is connected to the current path's
//! first non-specular vertex from the eye, `x_d`, whose eye subpath `x_d S* E` is kept.
//!
//! **Density (eq. 6).** `T_UP(ȳ|x̄) = (1/N_UP) Σ_i C_i(ȳ) p_pos(x'_0) Π_j g_{ij}` in area measure
//! (geometry factors converting the cone densities `g = 1/(2πβ sin θ)` to area), `C_i` the test
//! that user path `i` could have produced `ȳ`. The new vertices are strategy `s = m + 1`'s light
//! walk except for the light choice, the cone directions and the deterministic specular bounces,
//! so in the common measure of [`super::mutation`]:
//!
//! `T̃(ȳ|x̄) = (1/N_UP) Σ_i C_i / (p_light(ℓ) · I(C*_{m+1}(ȳ))) · (g_{i0}/p_e) · Π_{j diffuse} g_{ij}/p_σ · Π_{j specular} 1/P`.
//!
//! Departure from the paper: `x'_0` is drawn on the light instead of kept at `u_0` — a fixed point
//! of an area light is a set of measure zero, whose candidates could never be accepted (on a point
//! light the two coincide).
//!
//! The proposal can almost never reverse its own move (most paths are far from every user path),
//! so it runs as the hybrid of eq. 7 with the bidirectional mutation: one mixture component that
//! chooses between the two and accepts with the combined rule (see [`super::mutations`]).

use super::mutation::{Change, Mutation, Registration};
use super::perturbation::{
    branch_probability, bsdf_pdf, direction, refracts, scatters_diffusely, specular_only,
};
use super::state::PathState;
use super::walk::{cone_direction, cone_pdf, endpoint, trace};
use crate::bsdf::TransportMode;
use crate::geometry::Ray;
use crate::light::LightKind;
use crate::math::DVec3;
use crate::metropolis::ImportanceKind;
use crate::path::{Vertex, VertexKind};
use crate::scene::Scene;
use mcmc_core::rng::{uniform, uniform_index};
use mcmc_core::{ChainRng, Failure};
use std::path::Path;
use std::sync::Arc;

/// Default cone half-angle of user-path segments, degrees.
pub const DEFAULT_BETA_DEGREES: f64 = 5.0;

/// A user path as read and checked against a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct UserPath {
    /// `u_0 … u_m`.
    pub points: Vec<DVec3>,
    /// Cone half-angle (radians) of segment `j` (`u_j → u_{j+1}`).
    pub beta: Vec<f64>,
    /// The light `u_0` lies on.
    pub light: usize,
    /// Whether `u_j` is on a surface that only scatters specularly (`false` at both ends).
    pub specular: Vec<bool>,
    /// Whether the specular bounce at `u_j` refracts.
    pub refracts: Vec<bool>,
    /// Line of the file where the path starts.
    pub line: usize,
}

/// The user paths of a render (empty: no user-path proposal).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UserPaths {
    /// The paths.
    pub paths: Vec<UserPath>,
}

/// Why a user-path file was refused.
#[derive(Debug, thiserror::Error)]
pub enum UserPathError {
    /// The file could not be read.
    #[error("{file}: {source}")]
    Io {
        /// File name.
        file: String,
        /// The error.
        source: std::io::Error,
    },
    /// A line (or a path starting there) is wrong.
    #[error("{file}:{line}: {reason}")]
    Line {
        /// File name.
        file: String,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        reason: String,
    },
}

struct RawPath {
    line: usize,
    points: Vec<(DVec3, Option<f64>, usize)>,
    beta: f64,
}

impl UserPaths {
    /// Read user paths from `file` and check them against `scene`.
    pub fn load(file: &Path, scene: &Scene) -> Result<Self, UserPathError> {
        let name = file.display().to_string();
        let text = std::fs::read_to_string(file).map_err(|source| UserPathError::Io {
            file: name.clone(),
            source,
        })?;
        Self::parse(&text, &name, scene)
    }

    /// Parse user paths from `text` (named `file` in errors) and check them against `scene`.
    pub fn parse(text: &str, file: &str, scene: &Scene) -> Result<Self, UserPathError> {
        let err = |line: usize, reason: String| UserPathError::Line {
            file: file.to_string(),
            line,
            reason,
        };
        let degrees = |line: usize, s: &str| -> Result<f64, UserPathError> {
            let v: f64 = s
                .parse()
                .map_err(|_| err(line, format!("'{s}' is not a number of degrees")))?;
            if v > 0.0 && v <= 90.0 {
                Ok(v.to_radians())
            } else {
                Err(err(
                    line,
                    format!("a cone half-angle must lie in (0°, 90°], got {v}"),
                ))
            }
        };
        let mut raw: Vec<RawPath> = Vec::new();
        for (i, full) in text.lines().enumerate() {
            let line = i + 1;
            let content = full.split('#').next().unwrap_or("").trim();
            if content.is_empty() {
                continue;
            }
            let words: Vec<&str> = content.split_whitespace().collect();
            if words[0] == "path" {
                let mut beta = DEFAULT_BETA_DEGREES.to_radians();
                for w in &words[1..] {
                    match w.strip_prefix("beta=") {
                        Some(v) => beta = degrees(line, v)?,
                        None => {
                            return Err(err(
                                line,
                                format!("unknown path option '{w}' (known: beta=<degrees>)"),
                            ));
                        }
                    }
                }
                raw.push(RawPath {
                    line,
                    points: Vec::new(),
                    beta,
                });
                continue;
            }
            let Some(path) = raw.last_mut() else {
                return Err(err(line, "a point before the first 'path' line".into()));
            };
            if words.len() != 3 && words.len() != 4 {
                return Err(err(
                    line,
                    format!(
                        "expected 'x y z' or 'x y z beta', got {} fields",
                        words.len()
                    ),
                ));
            }
            let mut p = [0.0; 3];
            for (c, w) in p.iter_mut().zip(&words) {
                *c = w
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| err(line, format!("'{w}' is not a finite number")))?;
            }
            let beta = words.get(3).map(|w| degrees(line, w)).transpose()?;
            path.points.push((DVec3::from(p), beta, line));
        }
        if raw.is_empty() {
            return Err(err(1, "no 'path' in the file".into()));
        }
        let paths = raw
            .iter()
            .map(|r| resolve(r, scene).map_err(|(line, reason)| err(line, reason)))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self { paths })
    }

    /// Number of paths.
    pub fn len(&self) -> usize {
        self.paths.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.paths.is_empty()
    }
}

/// Check a raw path against the scene: its light, its specular points, its visibility.
fn resolve(r: &RawPath, scene: &Scene) -> Result<UserPath, (usize, String)> {
    if r.points.len() < 2 {
        return Err((
            r.line,
            format!(
                "a path needs at least 2 points (a light point and a diffuse point), got {}",
                r.points.len()
            ),
        ));
    }
    let radius = 0.5 * (scene.bounds.1 - scene.bounds.0).length();
    let tol = 1e-4 * radius.max(1e-9);
    let pts: Vec<DVec3> = r.points.iter().map(|p| p.0).collect();
    let m = pts.len() - 1;
    // Each segment u_{j} → u_{j+1} must reach u_{j+1} unoccluded; the hit tells its surface.
    let mut surfaces = Vec::with_capacity(m);
    for j in 0..m {
        let (a, b, line) = (pts[j], pts[j + 1], r.points[j + 1].2);
        let dist = (b - a).length();
        if !(dist > tol) {
            return Err((line, "this point coincides with the previous one".into()));
        }
        let w = (b - a) / dist;
        let hit = scene.intersect(&Ray::new(a + w * tol, w));
        match hit {
            Some(h) if (h.point.p - b).length() <= 10.0 * tol + 1e-6 * dist => surfaces.push(h),
            Some(h) => {
                return Err((
                    line,
                    format!(
                        "the segment from the previous point is blocked at ({:.4}, {:.4}, {:.4}), {:.4} before this point (or the point is not on a surface)",
                        h.point.p.x,
                        h.point.p.y,
                        h.point.p.z,
                        (h.point.p - b).length()
                    ),
                ));
            }
            None => {
                return Err((
                    line,
                    "the segment from the previous point hits nothing: the point is not on a surface".into(),
                ));
            }
        }
    }
    // u_0 on a light: an emitting surface hit from u_1, or a point light at u_0.
    let line0 = r.points[0].2;
    let light = {
        let w = (pts[0] - pts[1]).normalize();
        let hit = scene.intersect(&Ray::new(pts[1] + w * tol, w));
        let area = hit
            .filter(|h| (h.point.p - pts[0]).length() <= 10.0 * tol)
            .and_then(|h| scene.light_at(h.point.primitive).map(|l| l.0));
        let point = scene.lights.iter().position(|l| match l {
            LightKind::Point { position, .. } => (*position - pts[0]).length() <= tol,
            _ => false,
        });
        area.or(point).ok_or((
            line0,
            "the first point of a path must lie on a light (seen from the second point)".into(),
        ))?
    };
    let mut specular = vec![false; m + 1];
    let mut refr = vec![false; m + 1];
    for j in 1..=m {
        let b = scene.bsdf(&surfaces[j - 1].point).ok();
        let only = b.as_ref().is_some_and(|b| b.is_delta_only());
        let line = r.points[j].2;
        if j == m {
            if only || b.as_ref().is_none_or(|b| b.is_delta_only()) {
                return Err((
                    line,
                    "the last point of a path must lie on a surface that scatters diffusely".into(),
                ));
            }
        } else if only {
            specular[j] = true;
            let n = surfaces[j - 1].point.n;
            refr[j] = (pts[j - 1] - pts[j]).dot(n) * (pts[j + 1] - pts[j]).dot(n) < 0.0;
        }
    }
    let beta = (0..m)
        .map(|j| r.points[j + 1].1.unwrap_or(r.beta))
        .collect();
    Ok(UserPath {
        points: pts,
        beta,
        light,
        specular,
        refracts: refr,
        line: r.line,
    })
}

/// The registration of the user-path proposal (weight 0 unless user paths are given).
pub const REGISTRATION: Registration = Registration {
    name: "user-path",
    default_weight: 0.0,
    build: |c| {
        Box::new(UserPathProposal {
            scene: c.scene,
            paths: c.settings.photon.user_paths.clone(),
            max_edges: c.settings.max_edges,
            importance: c.settings.importance,
        })
    },
};

/// The first non-specular vertex from the eye, `x_d`, when it scatters diffusely (what the
/// user-path proposal connects to).
pub fn eye_diffuse(path: &super::FullPath) -> Option<usize> {
    let k = path.edges();
    let d = (1..k).rev().find(|&i| !path.specular(i))?;
    scatters_diffusely(&path.vertices[d]).then_some(d)
}

/// The user-path proposal on a scene.
pub struct UserPathProposal<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// The user paths.
    pub paths: Arc<UserPaths>,
    /// Longest path (edges).
    pub max_edges: usize,
    /// Colour to scalar.
    pub importance: ImportanceKind,
}

impl UserPathProposal<'_> {
    fn record(d: usize, added: usize) -> Change {
        Change {
            l: -1,
            m: d,
            added,
            pivot: 0,
        }
    }

    /// `T̃` of user path `u` producing the light part `y_0 … y_m` of `ȳ` (0 when `C = 0`), without
    /// the `1/N_UP` and `1/I(C*)` factors.
    fn path_factor(&self, u: &UserPath, y: &super::FullPath, m: usize) -> f64 {
        let yv = &y.vertices;
        if u.points.len() != m + 1 {
            return 0.0;
        }
        let VertexKind::Light { light } = yv[0].kind else {
            return 0.0;
        };
        if light as usize != u.light {
            return 0.0;
        }
        let l = &self.scene.lights[u.light];
        let p_light = self.scene.light_distribution.pdf(u.light);
        let w0 = direction(&yv[0], &yv[1]);
        let p_e = l.pdf_direction(yv[0].n(), w0);
        let g0 = cone_pdf((u.points[1] - yv[0].p()).normalize_or_zero(), w0, u.beta[0]);
        if !(p_light > 0.0 && p_e > 0.0 && g0 > 0.0) {
            return 0.0;
        }
        let mut f = g0 / (p_light * p_e);
        for j in 1..m {
            let v = &yv[j];
            if u.specular[j] {
                if !(y.specular(j) && specular_only(v) && refracts(y, j) == u.refracts[j]) {
                    return 0.0;
                }
                let p = branch_probability(v, &yv[j - 1], &yv[j + 1], TransportMode::Importance);
                if !(p > 0.0) {
                    return 0.0;
                }
                f /= p;
            } else {
                if y.specular(j) || specular_only(v) || !scatters_diffusely(v) {
                    return 0.0;
                }
                let w = direction(v, &yv[j + 1]);
                let g = cone_pdf((u.points[j + 1] - v.p()).normalize_or_zero(), w, u.beta[j]);
                let p_sigma = bsdf_pdf(v, &yv[j - 1], &yv[j + 1]);
                if !(g > 0.0 && p_sigma > 0.0) {
                    return 0.0;
                }
                f *= g / p_sigma;
            }
        }
        let last = &yv[m];
        if y.specular(m) || specular_only(last) || !scatters_diffusely(last) {
            return 0.0;
        }
        f
    }
}

impl Mutation for UserPathProposal<'_> {
    fn name(&self) -> &'static str {
        REGISTRATION.name
    }

    fn suitability(&self, x: &PathState) -> f64 {
        (!self.paths.is_empty() && eye_diffuse(&x.path).is_some()) as u8 as f64
    }

    fn propose(&self, x: &PathState, rng: &mut ChainRng, y: &mut PathState) -> Result<(), Failure> {
        let d = eye_diffuse(&x.path).ok_or(Failure::NotApplicable)?;
        if self.paths.is_empty() {
            return Err(Failure::NotApplicable);
        }
        let u = &self.paths.paths[uniform_index(uniform(rng), self.paths.len())];
        let (xv, k) = (&x.path.vertices, x.path.edges());
        let m = u.points.len() - 1;
        if m + 1 + (k - d) > self.max_edges {
            return Err(Failure::Failed);
        }
        let l = &self.scene.lights[u.light];
        let (point, _) = l
            .sample_point(&self.scene.bvh, [uniform(rng), uniform(rng)])
            .ok_or(Failure::Failed)?;
        let mut light_part: Vec<Vertex> = Vec::with_capacity(m + 1);
        light_part.push(endpoint(
            VertexKind::Light {
                light: u.light as u32,
            },
            point,
        ));
        for j in 0..m {
            let from = light_part.last().ok_or(Failure::Failed)?;
            let w = if j >= 1 && u.specular[j] {
                from.bsdf
                    .as_ref()
                    .and_then(|b| {
                        b.delta_direction(from.wo, u.refracts[j], TransportMode::Importance)
                    })
                    .ok_or(Failure::Failed)?
            } else {
                cone_direction(
                    (u.points[j + 1] - from.p()).normalize_or_zero(),
                    u.beta[j],
                    rng,
                )
            };
            let mut v = trace(self.scene, from, w).ok_or(Failure::Failed)?;
            let want_specular = j + 1 < m && u.specular[j + 1];
            if want_specular != specular_only(&v) || (!want_specular && !scatters_diffusely(&v)) {
                return Err(Failure::Failed);
            }
            v.delta = want_specular;
            light_part.push(v);
        }
        let yp = &mut y.path;
        yp.vertices.clear();
        yp.vertices.extend(light_part);
        yp.vertices.extend_from_slice(&xv[d..]);
        y.finish_candidate(
            self.scene,
            self.importance,
            x,
            Self::record(d, m + 1),
            m + 1,
        );
        Ok(())
    }

    fn ln_density(&self, x: &PathState, y: &PathState, c: Change) -> f64 {
        let never = f64::NEG_INFINITY;
        let Some(d) = eye_diffuse(&x.path) else {
            return never;
        };
        let k = x.path.edges();
        if self.paths.is_empty()
            || c != Self::record(d, c.added)
            || c.added < 2
            || c.result_edges(k) != Some(y.path.edges())
            || y.path.edges() > self.max_edges
        {
            return never;
        }
        let m = c.added - 1;
        let i_s = y.strategy_importance(m + 1);
        if !(i_s > 0.0) {
            return never;
        }
        let sum: f64 = self
            .paths
            .paths
            .iter()
            .map(|u| self.path_factor(u, &y.path, m))
            .sum();
        let t = sum / self.paths.len() as f64;
        if t > 0.0 && t.is_finite() {
            t.ln() - i_s.ln()
        } else {
            never
        }
    }
}

/// The deliberately wrong mix [`super::UserPathRule::BidirectionalRatio`]: user-path moves
/// accepted with `T̃_BD(x̄|ȳ) / T̃_BD(ȳ|x̄)`.
pub(super) struct BidirectionalRatio<'a> {
    pub(super) user_path: Box<dyn Mutation + 'a>,
    pub(super) bidirectional: Box<dyn Mutation + 'a>,
}

impl Mutation for BidirectionalRatio<'_> {
    fn name(&self) -> &'static str {
        self.user_path.name()
    }

    fn suitability(&self, x: &PathState) -> f64 {
        self.user_path.suitability(x)
    }

    fn propose(&self, x: &PathState, rng: &mut ChainRng, y: &mut PathState) -> Result<(), Failure> {
        self.user_path.propose(x, rng, y)
    }

    fn ln_density(&self, x: &PathState, y: &PathState, change: Change) -> f64 {
        self.user_path.ln_density(x, y, change)
    }

    fn ln_ratio(&self, x: &PathState, y: &PathState) -> f64 {
        let Some(c) = y.change else {
            return f64::NEG_INFINITY;
        };
        if !y.carries_light() {
            return f64::NEG_INFINITY;
        }
        let fwd = self.bidirectional.ln_density(x, y, c);
        if !(fwd > f64::NEG_INFINITY) {
            return f64::NEG_INFINITY;
        }
        self.bidirectional.ln_density(y, x, c.reverse()) - fwd
    }
}
