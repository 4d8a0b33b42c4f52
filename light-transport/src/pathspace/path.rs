//! A complete light path `x̄ = v_0 … v_k` (light endpoint first, lens point last) as path-space MLT
//! sees it (Veach & Guibas 1997; overview paper §5.3), and its evaluation through every
//! bidirectional strategy.
//!
//! Every strategy `s` (light vertices `v_0 … v_{s−1}`, camera vertices `v_s … v_k`) that could have
//! produced the path gives an unweighted contribution `C*_s = f(x̄) / p_s(x̄)`, computed by
//! re-walking the path from both ends with the BDPT machinery (so delta factors cancel exactly as
//! they do in BDPT). Path-space mutations never need `f` or `p_s` on their own — only these
//! ratios — which keeps specular paths exact: `p_s / p_u = C*_u / C*_s`.

use crate::bsdf::TransportMode;
use crate::path::{Vertex, VertexKind, connect_unoccluded};
use crate::scene::Scene;
use crate::spectrum::Rgb;

/// A full path.
#[derive(Clone, Debug, Default)]
pub struct FullPath {
    /// Vertices from the light endpoint (`v_0`, kind [`VertexKind::Light`]) to the lens point
    /// (`v_k`, kind [`VertexKind::Camera`]); the scattering vertices in between carry their BSDF
    /// and whether they scatter through a delta lobe (`delta`).
    pub vertices: Vec<Vertex>,
}

/// Scratch space for evaluating paths (kept per thread to avoid allocation).
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    /// Light-side walk `v_0 … v_{k−1}`.
    pub light: Vec<Vertex>,
    /// Camera-side walk `v_k … v_0`.
    pub camera: Vec<Vertex>,
}

impl FullPath {
    /// Number of edges `k`.
    pub fn edges(&self) -> usize {
        self.vertices.len().saturating_sub(1)
    }

    /// The lens vertex `v_k`.
    pub fn lens(&self) -> &Vertex {
        &self.vertices[self.vertices.len() - 1]
    }

    /// Whether vertex `i` scatters through a delta lobe (endpoints never do).
    #[inline]
    pub fn specular(&self, i: usize) -> bool {
        self.vertices[i].delta
    }

    /// Where the path crosses the image: the raster position of the edge `v_k → v_{k−1}`.
    pub fn raster(&self, scene: &Scene) -> Option<[f64; 2]> {
        let n = self.vertices.len();
        if n < 2 {
            return None;
        }
        let lens = &self.vertices[n - 1];
        let w = (self.vertices[n - 2].p() - lens.p()).normalize_or_zero();
        scene.camera.importance(lens.p(), w).2
    }

    /// The path made by strategy `(s, t)` from a light and a camera subpath (in walk order). For
    /// `s = 0` the camera subpath's last vertex must lie on an area light and becomes the light
    /// endpoint; `None` otherwise. The two connection vertices are marked non-delta.
    pub fn from_subpaths(
        scene: &Scene,
        light: &[Vertex],
        camera: &[Vertex],
        s: usize,
        t: usize,
    ) -> Option<Self> {
        let mut path = Self::default();
        path.set_from_subpaths(scene, light, camera, s, t)?;
        Some(path)
    }

    /// [`FullPath::from_subpaths`] reusing this path's storage.
    pub fn set_from_subpaths(
        &mut self,
        scene: &Scene,
        light: &[Vertex],
        camera: &[Vertex],
        s: usize,
        t: usize,
    ) -> Option<()> {
        if s > light.len() || t > camera.len() || t == 0 || s + t < 2 {
            return None;
        }
        self.vertices.clear();
        self.vertices.extend_from_slice(&light[..s]);
        self.vertices.extend(camera[..t].iter().rev().cloned());
        if s == 0 {
            let v0 = &mut self.vertices[0];
            let (light, kind) = scene.light_at(v0.point.primitive)?;
            if kind.is_delta_position() {
                return None;
            }
            v0.kind = VertexKind::Light {
                light: light as u32,
            };
            v0.delta = false;
        } else {
            self.vertices[s - 1].delta = false;
        }
        self.vertices[s].delta = false;
        let k = self.vertices.len() - 1;
        (self.vertices[k].kind == VertexKind::Camera
            && matches!(self.vertices[0].kind, VertexKind::Light { .. }))
        .then_some(())
    }

    /// Whether strategy `s` (light vertices `v_0 … v_{s−1}`) could have produced this path: the
    /// connecting edge must join two vertices that do not scatter through delta lobes, and for
    /// `s = 0` the light endpoint must be an area light (paths cannot hit a point light).
    pub fn strategy_valid(&self, scene: &Scene, s: usize) -> bool {
        let n = self.vertices.len();
        if s >= n || n < 2 {
            return false;
        }
        if s == 0 {
            return match self.vertices[0].kind {
                VertexKind::Light { light } => !scene.lights[light as usize].is_delta_position(),
                _ => false,
            };
        }
        !self.vertices[s - 1].delta && !self.vertices[s].delta
    }

    /// `C*_s` for every strategy `s = 0 … k` into `out` (`None` where the strategy is invalid or
    /// contributes nothing), without visibility tests (the path's edges are known to be clear).
    pub fn strategies(&self, scene: &Scene, scratch: &mut Scratch, out: &mut Vec<Option<Rgb>>) {
        out.clear();
        let n = self.vertices.len();
        if n < 2 {
            return;
        }
        let k = n - 1;
        scratch.light.clear();
        scratch.light.extend_from_slice(&self.vertices[..k]);
        scratch.camera.clear();
        scratch.camera.extend(self.vertices.iter().rev().cloned());
        let lv = retrace(scene, &mut scratch.light, TransportMode::Importance);
        let cv = retrace(scene, &mut scratch.camera, TransportMode::Radiance);
        for s in 0..=k {
            let t = k + 1 - s;
            let c = (s <= lv && t <= cv && self.strategy_valid(scene, s))
                .then(|| connect_unoccluded(scene, &scratch.light, &scratch.camera, s, t))
                .flatten()
                .map(|c| c.value)
                .filter(|v| v.is_finite() && !v.is_black());
            out.push(c);
        }
    }
}

/// Recompute the throughputs, forward densities and directions of a subpath whose vertex
/// positions, BSDFs and delta flags are known, walking from its endpoint exactly as the random
/// walks of [`crate::path`] would. Returns how many leading vertices are valid (a zero density
/// cuts the subpath there).
pub fn retrace(scene: &Scene, sub: &mut [Vertex], mode: TransportMode) -> usize {
    let n = sub.len();
    if n == 0 {
        return 0;
    }
    match sub[0].kind {
        VertexKind::Light { light } => {
            let l = &scene.lights[light as usize];
            let p = scene.light_distribution.pdf(light as usize) * l.pdf_position();
            if !(p > 0.0) {
                return 0;
            }
            sub[0].pdf_fwd = p;
            sub[0].beta = Rgb::splat(1.0 / p);
        }
        VertexKind::Camera => {
            sub[0].pdf_fwd = scene.camera.pdf_lens();
            sub[0].beta = Rgb::WHITE;
        }
        VertexKind::Surface => return 0,
    }
    sub[0].wo = crate::math::DVec3::ZERO;
    sub[0].pdf_rev = 0.0;
    if n == 1 {
        return 1;
    }
    let w01 = (sub[1].p() - sub[0].p()).normalize_or_zero();
    let (weight, pdf_dir) = match sub[0].kind {
        VertexKind::Light { light } => {
            let l = &scene.lights[light as usize];
            let pdf = l.pdf_direction(sub[0].n(), w01);
            let cos = if l.is_delta_position() {
                1.0
            } else {
                sub[0].n().dot(w01).abs()
            };
            (
                sub[0].le(scene, &sub[1]) * (cos / (sub[0].pdf_fwd * pdf)),
                pdf,
            )
        }
        _ => {
            let (we, pdf, _) = scene.camera.importance(sub[0].p(), w01);
            let cos = scene.camera.forward().dot(w01).abs();
            (Rgb::splat(we * cos / (sub[0].pdf_fwd * pdf)), pdf)
        }
    };
    if !(pdf_dir > 0.0) || !weight.is_finite() {
        return 1;
    }
    let mut beta = weight;
    sub[1].pdf_fwd = sub[0].to_area(pdf_dir, &sub[1], scene);
    for i in 1..n {
        sub[i].wo = (sub[i - 1].p() - sub[i].p()).normalize_or_zero();
        sub[i].beta = beta;
        sub[i].pdf_rev = 0.0;
        if i + 1 == n {
            break;
        }
        let wi = (sub[i + 1].p() - sub[i].p()).normalize_or_zero();
        let Some(b) = sub[i].bsdf.as_ref() else {
            return i + 1;
        };
        let (f, pdf) = if sub[i].delta {
            match b.eval_delta(sub[i].wo, wi, mode) {
                Some(d) => (d.f, d.pdf),
                None => return i + 1,
            }
        } else {
            (b.eval(sub[i].wo, wi, mode), b.pdf(sub[i].wo, wi))
        };
        if !(pdf > 0.0) {
            return i + 1;
        }
        let shading = sub[i].shading_factor(scene, sub[i].wo, wi, mode);
        beta *= f * (shading * wi.dot(sub[i].n()).abs() / pdf);
        if !beta.is_finite() {
            return i + 1;
        }
        sub[i + 1].pdf_fwd = if sub[i].delta {
            0.0
        } else {
            sub[i].to_area(pdf, &sub[i + 1], scene)
        };
    }
    n
}
