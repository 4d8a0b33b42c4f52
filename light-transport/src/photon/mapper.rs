//! Standard photon mapping with a final gather (Jensen 2001, ch. 9), storage in the convention of
//! Fan, Chenney & Lai 2005, §3.1.
//!
//! Before rendering, photons are traced into a global and a caustic map ([`super::trace`]). Each
//! pixel sample follows the camera ray through specular bounces (adding the emission it meets) to
//! the first non-specular point `x₁`, where
//!
//! * **direct light** is one next-event estimate combined by MIS (power heuristic, counting the
//!   `G` gather rays as `G` samples: weights `(n_i p_i)² / Σ_j (n_j p_j)²`) with the gather rays
//!   that hit an emitter;
//! * **caustics** (`L S+ x₁`) are the caustic map's estimate at `x₁`;
//! * **indirect light** is `G` gather rays sampled from the BSDF at `x₁`: each follows specular
//!   bounces (their emission belongs to the caustic map and is not added) to a non-specular point
//!   `x₂`, where the global map's estimate is read. A gather direction from a delta lobe of `x₁`
//!   continues the camera path instead.
//!
//! The maps' bias (their smoothing over the lookup radius) makes the render consistent, not
//! unbiased: it approaches the converged image as the photon counts grow.

use super::map::{Lookup, PhotonMap, PhotonMapError};
use super::radius::{MaxRadius, Resolved};
use super::trace::trace_photons;
use crate::bsdf::TransportMode;
use crate::geometry::Ray;
use crate::integrators::direct::{mis, next_event};
use crate::integrators::{Estimator, Splat};
use crate::path::{MisHeuristic, camera_ray};
use crate::sampler::PixelStream;
use crate::scene::Scene;
use crate::spectrum::Rgb;
use mcmc_core::rng::{FastRng, uniform};

/// Settings of photon mapping.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonMapping {
    /// Light subpaths traced for the global map (200 000).
    pub global_paths: u64,
    /// Light subpaths traced for the caustic map (only their caustic photons are kept; 200 000).
    pub caustic_paths: u64,
    /// Gather rays per pixel sample (16).
    pub gather_rays: usize,
    /// Photons per estimate (`n = 60`, Fan et al. §6).
    pub k: usize,
    /// Largest lookup radius of the global map: by default from the map's photon density with
    /// `α = 0.1` (Fan et al. §6; [`super::radius`]).
    pub global_radius: MaxRadius,
    /// Largest lookup radius of the caustic map (same default).
    pub caustic_radius: MaxRadius,
    /// Maximum number of edges of a path (camera and photon paths).
    pub max_edges: usize,
    /// Seed of the photon tracing.
    pub seed: u64,
}

impl PhotonMapping {
    /// The defaults for paths of at most `max_edges` edges.
    pub fn new(max_edges: usize) -> Self {
        Self {
            global_paths: 200_000,
            caustic_paths: 200_000,
            gather_rays: 16,
            k: 60,
            global_radius: MaxRadius::DEFAULT,
            caustic_radius: MaxRadius::DEFAULT,
            max_edges,
            seed: 0x9407_0A11,
        }
    }
}

/// Why photon mapping could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum PhotonMappingError {
    /// A setting out of range.
    #[error("photon mapping: {0}")]
    Settings(String),
    /// A map could not be built.
    #[error(transparent)]
    Map(#[from] PhotonMapError),
}

/// Photon mapping on a scene: its settings and its two maps.
#[derive(Debug)]
pub struct PhotonMapper {
    settings: PhotonMapping,
    global: PhotonMap,
    caustic: PhotonMap,
    global_lookup: Lookup,
    caustic_lookup: Lookup,
    /// Lines about how the maps were filled (Metropolis photon sampling's statistics).
    notes: Vec<String>,
}

impl PhotonMapper {
    /// Trace the photons and build the maps.
    pub fn new(scene: &Scene, settings: PhotonMapping) -> Result<Self, PhotonMappingError> {
        Self::check(&settings)?;
        let s = &settings;
        let t = std::time::Instant::now();
        // A gather reads the global map two edges from the eye, the caustic map one edge: their
        // photons' light paths may have `max_edges − 2` and `max_edges − 1` edges.
        let (global, _) =
            trace_photons(scene, s.global_paths, s.max_edges.saturating_sub(2), s.seed);
        let (_, caustic) = trace_photons(
            scene,
            s.caustic_paths,
            s.max_edges.saturating_sub(1),
            s.seed ^ 0xCA05,
        );
        let notes = vec![format!(
            "photons    traced: {} paths for the global map, {} for the caustic map, t_map {:.2} s",
            s.global_paths,
            s.caustic_paths,
            t.elapsed().as_secs_f64()
        )];
        Self::from_photons(scene, settings, global, caustic, notes)
    }

    /// Whether the settings are usable: the error a mapper built from them would give (Metropolis
    /// photon sampling checks before it samples).
    pub fn check(s: &PhotonMapping) -> Result<(), PhotonMappingError> {
        if s.gather_rays == 0
            || s.k < 2
            || s.max_edges < 1
            || !s.global_radius.is_valid()
            || !s.caustic_radius.is_valid()
        {
            return Err(PhotonMappingError::Settings(format!(
                "need ≥ 1 gather ray, k ≥ 2, max depth ≥ 1, positive finite radius fractions and α in (0, 1]; got {} gather rays, k = {}, radii {:?} and {:?}",
                s.gather_rays, s.k, s.global_radius, s.caustic_radius
            )));
        }
        Ok(())
    }

    /// Photon mapping's final gather over given photons (Metropolis photon sampling's), with
    /// `notes` on how they were made for the summary.
    pub fn from_photons(
        scene: &Scene,
        settings: PhotonMapping,
        global: Vec<super::Photon>,
        caustic: Vec<super::Photon>,
        notes: Vec<String>,
    ) -> Result<Self, PhotonMappingError> {
        Self::check(&settings)?;
        let s = &settings;
        let scene_radius = 0.5 * (scene.bounds.1 - scene.bounds.0).length();
        let global = PhotonMap::new(global)?;
        let caustic = PhotonMap::new(caustic)?;
        let g = s
            .global_radius
            .resolve(&global, s.k, scene_radius, CAP_GLOBAL);
        let c = s
            .caustic_radius
            .resolve(&caustic, s.k, scene_radius, CAP_CAUSTIC);
        let mut notes = notes;
        notes.push(format!(
            "lookup     k = {}; d_max global {}, caustic {}",
            s.k,
            describe(&g, scene_radius),
            describe(&c, scene_radius)
        ));
        Ok(Self {
            global,
            caustic,
            global_lookup: Lookup::new(s.k, g.radius),
            caustic_lookup: Lookup::new(s.k, c.radius),
            settings,
            notes,
        })
    }

    /// The lookups of the global and the caustic map (their resolved maximum radii).
    pub fn lookups(&self) -> (&Lookup, &Lookup) {
        (&self.global_lookup, &self.caustic_lookup)
    }

    /// The photon maps `(global, caustic)`.
    pub fn maps(&self) -> (&PhotonMap, &PhotonMap) {
        (&self.global, &self.caustic)
    }

    /// Photons in the global and the caustic map.
    pub fn photons(&self) -> (usize, usize) {
        (self.global.len(), self.caustic.len())
    }

    /// Report lines: the maps' sizes and memory.
    pub fn summary(&self, _: f64) -> Vec<String> {
        let (g, c) = self.photons();
        let b = PhotonMap::bytes_per_photon();
        let mut out = self.notes.clone();
        out.push(format!(
            "photons    global {g}, caustic {c}; {b} bytes per photon ({:.1} MB)",
            ((g + c) * b) as f64 / 1e6
        ));
        out
    }

    /// Radiance arriving along `ray` (toward its origin) through specular bounces from the camera
    /// or a delta lobe: emission met is added; at the first non-specular point, the estimate of
    /// the module docs. `edges` counts the edges used so far.
    fn shade(&self, scene: &Scene, mut ray: Ray, mut edges: usize, rng: &mut FastRng) -> Rgb {
        let mut beta = Rgb::WHITE;
        let mut l = Rgb::BLACK;
        let mut slot = None; // each vertex's BSDF, built in place
        while edges < self.settings.max_edges {
            let Some(hit) = scene.intersect(&ray) else {
                break;
            };
            edges += 1;
            let p = hit.point;
            let wo = -ray.d;
            if let Some((_, light)) = scene.light_at(p.primitive) {
                l += beta * light.radiance(p.n, wo);
            }
            scene.bsdf_into(&p, &mut slot);
            let Some(bsdf) = slot.as_ref() else { break };
            if bsdf.is_delta_only() {
                let Some((weight, next, _, _)) = bounce(bsdf, &p, wo, rng) else {
                    break;
                };
                beta *= weight;
                ray = next;
                continue;
            }
            l += beta * self.at_diffuse(scene, &p, wo, bsdf, edges, rng);
            break;
        }
        l
    }

    /// The estimate at a non-specular point `p` seen from `wo`, reached with `edges` edges.
    fn at_diffuse(
        &self,
        scene: &Scene,
        p: &crate::geometry::SurfacePoint,
        wo: crate::math::DVec3,
        bsdf: &crate::bsdf::Bsdf,
        edges: usize,
        rng: &mut FastRng,
    ) -> Rgb {
        let mode = TransportMode::Radiance;
        let mut l = Rgb::BLACK;
        if edges + 1 > self.settings.max_edges {
            return l;
        }
        let g = self.settings.gather_rays as f64;
        let n_side = if p.n.dot(wo) >= 0.0 { p.n } else { -p.n };
        // Caustics: L S+ x₁.
        l += self
            .caustic
            .estimate(p.p, n_side, &self.caustic_lookup, |wi| {
                bsdf.eval(wo, wi, mode)
            });
        // Direct light by next-event estimation (MIS with the gather rays).
        let choice = uniform(rng);
        let u_light = [uniform(rng), uniform(rng)];
        l += next_event(
            scene,
            p,
            wo,
            bsdf,
            choice,
            u_light,
            MisHeuristic::Power,
            g,
            |_| Some(1.0),
        );
        // Indirect light by gather rays.
        let mut gathered = Rgb::BLACK;
        for _ in 0..self.settings.gather_rays {
            let Some((weight, ray, pdf, delta)) = bounce(bsdf, p, wo, rng) else {
                continue;
            };
            if delta {
                // A delta lobe of x₁: the camera path continues.
                gathered += weight * self.shade(scene, ray, edges, rng);
                continue;
            }
            gathered += weight * self.gather(scene, ray, g * pdf, edges, rng);
        }
        l + gathered * (1.0 / g)
    }

    /// One gather ray leaving a non-specular point, `pdf` its BSDF density times the number of
    /// gather rays (the MIS weights count samples): the MIS-weighted emission it hits directly,
    /// then through specular bounces the global map's estimate at the next non-specular point.
    fn gather(
        &self,
        scene: &Scene,
        mut ray: Ray,
        pdf: f64,
        mut edges: usize,
        rng: &mut FastRng,
    ) -> Rgb {
        let mode = TransportMode::Radiance;
        let mut beta = Rgb::WHITE;
        let mut l = Rgb::BLACK;
        let mut first = true;
        let mut slot = None; // each vertex's BSDF, built in place
        while edges < self.settings.max_edges {
            let Some(hit) = scene.intersect(&ray) else {
                break;
            };
            edges += 1;
            let p = hit.point;
            let wo = -ray.d;
            if first && let Some((li, light)) = scene.light_at(p.primitive) {
                let le = light.radiance(p.n, wo);
                if !le.is_black() {
                    let pdf_light =
                        scene.light_distribution.pdf(li) * light.pdf_position() * hit.t * hit.t
                            / p.n.dot(wo).abs();
                    l += le * mis(pdf, pdf_light, MisHeuristic::Power);
                }
            }
            first = false;
            scene.bsdf_into(&p, &mut slot);
            let Some(bsdf) = slot.as_ref() else { break };
            if bsdf.is_delta_only() {
                let Some((weight, next, _, _)) = bounce(bsdf, &p, wo, rng) else {
                    break;
                };
                beta *= weight;
                ray = next;
                continue;
            }
            let n_side = if p.n.dot(wo) >= 0.0 { p.n } else { -p.n };
            l += beta
                * self
                    .global
                    .estimate(p.p, n_side, &self.global_lookup, |wi| {
                        bsdf.eval(wo, wi, mode)
                    });
            break;
        }
        l
    }
}

/// The global map's largest radius under the density rule, and its radius when the rule has
/// nothing to read (a fraction of the scene's bounding-sphere radius; Mitsuba 0.6's default).
const CAP_GLOBAL: f64 = 0.05;
/// The caustic map's (Mitsuba 0.6's default).
const CAP_CAUSTIC: f64 = 0.0125;

/// A resolved radius for the summary: its size, as a share of the scene's radius, and where it
/// came from.
fn describe(r: &Resolved, scene_radius: f64) -> String {
    let share = 100.0 * r.radius / scene_radius;
    match (r.density, r.capped) {
        (Some(rho), false) => format!(
            "{:.4} ({share:.2}% of the scene; typical density {rho:.3e} per unit area)",
            r.radius
        ),
        (Some(rho), true) => format!(
            "{:.4} ({share:.2}% of the scene, the cap; typical density {rho:.3e} per unit area)",
            r.radius
        ),
        (None, true) => format!(
            "{:.4} ({share:.2}% of the scene, the cap: too few photons to read a density)",
            r.radius
        ),
        (None, false) => format!("{:.4} ({share:.2}% of the scene; fixed)", r.radius),
    }
}

/// Sample `bsdf` at `p` (seen from `wo`) with three numbers of `rng`: the weight `f |cos| / pdf`,
/// the ray leaving, the density and whether a delta lobe was chosen; `None` when nothing leaves.
fn bounce(
    bsdf: &crate::bsdf::Bsdf,
    p: &crate::geometry::SurfacePoint,
    wo: crate::math::DVec3,
    rng: &mut FastRng,
) -> Option<(Rgb, Ray, f64, bool)> {
    let u_lobe = uniform(rng);
    let u = [uniform(rng), uniform(rng)];
    let bs = bsdf.sample(wo, u_lobe, u, TransportMode::Radiance)?;
    if bs.pdf == 0.0 || bs.f.is_black() {
        return None;
    }
    let weight = bs.f * (bs.wi.dot(p.ns).abs() / bs.pdf);
    Some((weight, Ray::leaving(p, bs.wi), bs.pdf, bs.delta))
}

impl Estimator for PhotonMapper {
    fn sample(
        &self,
        scene: &Scene,
        pixel: usize,
        stream: &mut PixelStream,
        _splats: &mut Vec<Splat>,
    ) -> Rgb {
        let cs = camera_ray(scene, stream, Some(pixel));
        if cs.we == 0.0 {
            return Rgb::BLACK;
        }
        let l = self.shade(scene, cs.ray, 0, stream.rng());
        if l.is_finite() { l } else { Rgb::BLACK }
    }

    fn splats(&self) -> bool {
        false
    }
}
