//! Path vertices and the densities between them.

use crate::bsdf::{Bsdf, LocalPair, TransportMode};
use crate::geometry::SurfacePoint;
use crate::light::LightKind;
use crate::math::DVec3;
use crate::scene::Scene;
use crate::spectrum::Rgb;

/// What a vertex is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VertexKind {
    /// The lens point of the camera.
    Camera,
    /// The first vertex of a light subpath (on light `light`).
    Light {
        /// Index of the light.
        light: u32,
    },
    /// A scattering vertex (which may lie on an emitter).
    Surface,
}

/// A vertex of a camera or light subpath.
#[derive(Debug)]
pub struct Vertex {
    /// Kind.
    pub kind: VertexKind,
    /// Position, normal, uv, tangent, primitive.
    pub point: SurfacePoint,
    /// Unit direction toward the previous vertex of its subpath (zero at endpoints).
    pub wo: DVec3,
    /// BSDF (surface vertices).
    pub bsdf: Option<Bsdf>,
    /// Throughput of the subpath up to this vertex divided by its density: for a camera vertex 1
    /// (importance is evaluated when connecting), for a light vertex `1 / (p_choice p_pos)` (emission
    /// is evaluated when connecting), for surface vertices the usual product of
    /// `f |cos| / p_σ` factors times the emitted quantity along the subpath.
    pub beta: Rgb,
    /// Whether the walk left this vertex through a delta (specular) lobe: no strategy may connect
    /// here.
    pub delta: bool,
    /// Area density of generating this vertex from its predecessor (for endpoints: the density of
    /// the endpoint itself — lens position, or light choice × position).
    pub pdf_fwd: f64,
    /// Area density of generating this vertex from its successor (filled by the walk).
    pub pdf_rev: f64,
}

impl Clone for Vertex {
    fn clone(&self) -> Self {
        Self {
            kind: self.kind,
            point: self.point,
            wo: self.wo,
            bsdf: self.bsdf.clone(),
            beta: self.beta,
            delta: self.delta,
            pdf_fwd: self.pdf_fwd,
            pdf_rev: self.pdf_rev,
        }
    }

    /// Field by field, the BSDF into the storage this vertex has ([`Bsdf`]'s `clone_from` copies
    /// only the lobes in use): a candidate path copies its source's vertices into its own. (The
    /// destructuring makes a new field a compile error here until it is copied.)
    fn clone_from(&mut self, source: &Self) {
        let Self {
            kind,
            point,
            wo,
            bsdf,
            beta,
            delta,
            pdf_fwd,
            pdf_rev,
        } = source;
        self.kind = *kind;
        self.point = *point;
        self.wo = *wo;
        self.bsdf.clone_from(bsdf);
        self.beta = *beta;
        self.delta = *delta;
        self.pdf_fwd = *pdf_fwd;
        self.pdf_rev = *pdf_rev;
    }
}

impl Vertex {
    /// A surface vertex at `point`, arrived at from `wo` with throughput `beta` (densities 0, not
    /// delta, no BSDF yet).
    pub fn surface(point: &SurfacePoint, wo: DVec3, beta: Rgb) -> Self {
        Self {
            kind: VertexKind::Surface,
            point: *point,
            wo,
            bsdf: None,
            beta,
            delta: false,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
        }
    }

    /// Make this vertex [`Vertex::surface`]`(point, wo, beta)` in place, except its BSDF: that
    /// keeps its storage for the caller to rebuild ([`crate::scene::Scene::bsdf_into`]) before
    /// anything reads it. Walks that write into kept slots use it (a vertex is large to copy).
    pub fn set_surface(&mut self, point: &SurfacePoint, wo: DVec3, beta: Rgb) {
        self.kind = VertexKind::Surface;
        self.point = *point;
        self.wo = wo;
        self.beta = beta;
        self.delta = false;
        self.pdf_fwd = 0.0;
        self.pdf_rev = 0.0;
    }

    /// Position.
    #[inline]
    pub fn p(&self) -> DVec3 {
        self.point.p
    }

    /// Geometric normal (camera: viewing direction; point light: unused).
    #[inline]
    pub fn n(&self) -> DVec3 {
        self.point.n
    }

    /// Whether this vertex lies on a surface (has a meaningful normal for density conversions).
    pub fn on_surface(&self, scene: &Scene) -> bool {
        match self.kind {
            VertexKind::Surface => true,
            VertexKind::Light { light } => {
                matches!(scene.lights[light as usize], LightKind::Area { .. })
            }
            VertexKind::Camera => false,
        }
    }

    /// Whether a connection through this vertex is possible (not a delta-only BSDF).
    pub fn connectible(&self) -> bool {
        match self.kind {
            VertexKind::Surface => self.bsdf.as_ref().is_some_and(|b| !b.is_delta_only()),
            _ => true,
        }
    }

    /// The light this vertex emits from: the light endpoint, or a surface vertex on an area light.
    pub fn emitter<'a>(&self, scene: &'a Scene) -> Option<(usize, &'a LightKind)> {
        match self.kind {
            VertexKind::Light { light } => Some((light as usize, &scene.lights[light as usize])),
            VertexKind::Surface => scene.light_at(self.point.primitive),
            VertexKind::Camera => None,
        }
    }

    /// Convert a solid-angle density at this vertex toward `next` into an area density at `next`.
    #[inline]
    pub fn to_area(&self, pdf_solid_angle: f64, next: &Vertex, scene: &Scene) -> f64 {
        let d = next.p() - self.p();
        let d2 = d.length_squared();
        if d2 == 0.0 {
            return 0.0;
        }
        let mut pdf = pdf_solid_angle / d2;
        if next.on_surface(scene) {
            pdf *= next.n().dot(d / d2.sqrt()).abs();
        }
        pdf
    }

    /// The factor shading normals put on this vertex's BSDF in the path integral, for a walk in
    /// `mode` that arrived from `wo` and leaves toward `wi` (Veach 1997 §5.3). The measurement
    /// contribution keeps geometric cosines in its geometry terms, so the scattering of light
    /// arriving along `w_l` carries `|w_l · n_s| / |w_l · n_g|`: the light side is `wi` for camera
    /// subpaths (radiance) and `wo` for light subpaths (importance), where it is the adjoint
    /// correction `|wo·n_s| |wi·n_g| / (|wo·n_g| |wi·n_s|)` of the walk's `|wi·n_s|`. 1 without
    /// shading normals. [`crate::scene::Scene::adjoint_correction`] off uses the radiance form in
    /// both modes (deliberately wrong, for tests).
    #[inline]
    pub fn shading_factor(&self, scene: &Scene, wo: DVec3, wi: DVec3, mode: TransportMode) -> f64 {
        let pt = &self.point;
        if !pt.shaded() {
            return 1.0;
        }
        let w = match mode {
            TransportMode::Importance if scene.adjoint_correction => wo,
            _ => wi,
        };
        let g = w.dot(pt.n).abs();
        if g > 0.0 { w.dot(pt.ns).abs() / g } else { 0.0 }
    }

    /// BSDF value at this vertex for light arriving from `next` (or the adjoint), times the
    /// shading-normal factor ([`Vertex::shading_factor`]): the vertex's factor of the measurement
    /// contribution, whose geometry terms use geometric cosines.
    #[inline]
    pub fn f(&self, scene: &Scene, next: &Vertex, mode: TransportMode) -> Rgb {
        self.f_local(scene, next, mode).0
    }

    /// [`Vertex::f`] toward `next`, with the pair of directions it evaluated the BSDF at in the
    /// BSDF's frame (`wo`, then the direction toward `next`; `None` where it evaluated none), from
    /// which [`Vertex::pdf_pair`] takes a connection's densities without bringing the
    /// directions into the frame again.
    #[inline]
    pub fn f_local(
        &self,
        scene: &Scene,
        next: &Vertex,
        mode: TransportMode,
    ) -> (Rgb, Option<LocalPair>) {
        let Some(b) = &self.bsdf else {
            return (Rgb::BLACK, None);
        };
        let wi = (next.p() - self.p()).normalize_or_zero();
        let Some(l) = b.local_pair(self.wo, wi) else {
            return (Rgb::BLACK, None);
        };
        (
            b.eval_local(l, mode) * self.shading_factor(scene, self.wo, wi, mode),
            Some(l),
        )
    }

    /// Area density at `next` of sampling `next` from this vertex, the walk having arrived from
    /// `prev` (`None`: this is an endpoint).
    pub fn pdf(&self, scene: &Scene, prev: Option<&Vertex>, next: &Vertex) -> f64 {
        let wn = (next.p() - self.p()).normalize_or_zero();
        let solid = match self.kind {
            VertexKind::Camera => scene.camera.importance(self.p(), wn).1,
            VertexKind::Light { light } => scene.lights[light as usize].pdf_direction(self.n(), wn),
            VertexKind::Surface => {
                let Some(b) = &self.bsdf else { return 0.0 };
                let wp = match prev {
                    Some(p) => (p.p() - self.p()).normalize_or_zero(),
                    None => self.wo,
                };
                b.pdf(wp, wn)
            }
        };
        self.to_area(solid, next, scene)
    }

    /// The area densities a connection through this vertex to `next` makes at its two
    /// neighbours, `(toward next, toward prev)`, `prev` being its predecessor in its walk (Veach
    /// 1997 §10.2: the reverse densities recomputed at a connection). A surface vertex takes them
    /// between the direction its walk arrived from (its `wo`, not one recomputed from the two
    /// positions) and the direction toward `next`, in its BSDF's frame: `local` where
    /// [`Vertex::f_local`] gave it, brought into the frame here when `None`. Other vertices
    /// take two [`Vertex::pdf`] calls.
    pub fn pdf_pair(
        &self,
        scene: &Scene,
        prev: &Vertex,
        next: &Vertex,
        local: Option<LocalPair>,
    ) -> (f64, f64) {
        match (&self.kind, &self.bsdf) {
            (VertexKind::Surface, Some(b)) => {
                let local = local
                    .or_else(|| b.local_pair(self.wo, (next.p() - self.p()).normalize_or_zero()));
                let (toward, back) =
                    local.map_or((0.0, 0.0), |l| (b.pdf_local(l), b.pdf_local(l.reversed())));
                (
                    self.to_area(toward, next, scene),
                    self.to_area(back, prev, scene),
                )
            }
            _ => (
                self.pdf(scene, Some(prev), next),
                self.pdf(scene, Some(next), prev),
            ),
        }
    }

    /// For a vertex on an emitter: area density at `next` of a light subpath leaving this point
    /// toward `next` (the emission direction density).
    pub fn pdf_light(&self, scene: &Scene, next: &Vertex) -> f64 {
        let Some((_, light)) = self.emitter(scene) else {
            return 0.0;
        };
        let w = (next.p() - self.p()).normalize_or_zero();
        self.to_area(light.pdf_direction(self.n(), w), next, scene)
    }

    /// For a vertex on an emitter: density of a light subpath starting here (light choice × area
    /// density of the position).
    pub fn pdf_light_origin(&self, scene: &Scene) -> f64 {
        let Some((i, light)) = self.emitter(scene) else {
            return 0.0;
        };
        scene.light_distribution.pdf(i) * light.pdf_position()
    }

    /// Radiance emitted from this vertex toward `toward` (zero if it is not on an emitter).
    pub fn le(&self, scene: &Scene, toward: &Vertex) -> Rgb {
        let Some((_, light)) = self.emitter(scene) else {
            return Rgb::BLACK;
        };
        let w = (toward.p() - self.p()).normalize_or_zero();
        match light {
            LightKind::Point { intensity, .. } => *intensity,
            _ => light.radiance(self.n(), w),
        }
    }
}
