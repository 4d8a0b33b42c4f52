//! The `(s, t)` connection of a light subpath prefix `y_0 … y_{s−1}` and a camera subpath prefix
//! `z_0 … z_{t−1}` (Veach 1997 §10.2): the unweighted contribution `C*_{s,t}` and, for `t = 1`,
//! the raster position it lands on. Endpoints are the subpaths' own: `s = 1` connects the light
//! endpoint `y_0`, `t = 1` the lens point `z_0` (no resampling), so each strategy is a deterministic
//! function of the two subpaths.

use super::vertex::{Vertex, VertexKind};
use crate::bsdf::{LocalPair, TransportMode};
use crate::geometry::SurfaceEnd;
use crate::scene::Scene;
use crate::spectrum::Rgb;

/// The contribution of one strategy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Connection {
    /// `C*_{s,t}`: path contribution over path density.
    pub value: Rgb,
    /// Raster position for `t = 1` (splatted); `None`: the camera sample's own pixel.
    pub raster: Option<[f64; 2]>,
    /// The ends' directions in their BSDFs' frames, for the strategy's MIS weight
    /// ([`crate::path::mis_weight`]).
    pub ends: EndPairs,
}

/// The pairs of directions ([`Vertex::f_local`]: the walk's arrival direction, then the
/// direction across the connection) at which a connection evaluated the BSDFs of its light end
/// (`light`) and its camera end (`camera`); `None` where it evaluated none (an endpoint, or
/// factors given by the caller), and the MIS weight brings the directions into the frames
/// itself.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EndPairs {
    /// At the light end.
    pub light: Option<LocalPair>,
    /// At the camera end.
    pub camera: Option<LocalPair>,
}

/// Cosines below this make a connection tangent to a surface: its side (reflection or
/// transmission) would be decided by rounding, so it is given no contribution (a set of measure
/// zero; keeping it would make paths depend on the last bit of their numbers).
pub const GRAZING_COSINE: f64 = 1e-9;

/// Geometry term between two vertices (cosines only where a vertex lies on a surface, and the lens
/// cosine for the camera endpoint); 0 for a connection tangent to a surface ([`GRAZING_COSINE`]).
pub fn geometry(scene: &Scene, a: &Vertex, b: &Vertex) -> f64 {
    let d = b.p() - a.p();
    let d2 = d.length_squared();
    if d2 == 0.0 {
        return 0.0;
    }
    let w = d / d2.sqrt();
    let cos = |v: &Vertex, w: crate::math::DVec3| -> f64 {
        match v.kind {
            VertexKind::Camera => v.n().dot(w).abs(),
            _ if v.on_surface(scene) => v.n().dot(w).abs(),
            _ => 1.0,
        }
    };
    let (ca, cb) = (cos(a, w), cos(b, w));
    if ca < GRAZING_COSINE || cb < GRAZING_COSINE {
        return 0.0;
    }
    ca * cb / d2
}

/// Evaluate strategy `(s, t)`; `None` when it contributes nothing (occluded, not connectible,
/// outside the image).
pub fn connect(
    scene: &Scene,
    light: &[Vertex],
    camera: &[Vertex],
    s: usize,
    t: usize,
) -> Option<Connection> {
    let c = connect_unoccluded(scene, light, camera, s, t)?;
    if s == 0 {
        return Some(c);
    }
    unoccluded(scene, &light[s - 1], &camera[t - 1]).then_some(c)
}

/// Whether the edge between the light side's vertex `light` and the camera side's vertex `camera`
/// is unoccluded (ends offset along the normals of the vertices that lie on surfaces).
///
/// The segment is traced from the camera side: a light's surroundings (a lamp shade, a
/// reflector) often fill the boxes around it and the light subpath's first vertices, and a
/// traversal that starts among them has to clear them first. The answer is the same either way
/// (images bit for bit alike); BDPT on `veach-bidir` ran 4.0% fewer instructions so (docs/performance.md).
pub fn unoccluded(scene: &Scene, light: &Vertex, camera: &Vertex) -> bool {
    scene.visible(
        camera.p(),
        surface_end(scene, camera),
        light.p(),
        surface_end(scene, light),
    )
}

/// [`connect`] without the visibility test, for paths whose connecting edge is known to be
/// unoccluded (path-space mutations re-evaluate every strategy of a path they traced).
pub fn connect_unoccluded(
    scene: &Scene,
    light: &[Vertex],
    camera: &[Vertex],
    s: usize,
    t: usize,
) -> Option<Connection> {
    if t == 0 || t > camera.len() || s > light.len() {
        return None;
    }
    let pt = &camera[t - 1];
    fn end(v: &Vertex) -> End<'_> {
        End {
            vertex: v,
            beta: v.beta,
            pdf_fwd: v.pdf_fwd,
        }
    }
    let qs = s.checked_sub(1).map(|i| &light[i]);
    join(
        scene,
        qs.map(end),
        end(pt),
        t.checked_sub(2).map(|i| &camera[i]),
        || {
            qs.map_or((Rgb::BLACK, None), |q| {
                q.f_local(scene, pt, TransportMode::Importance)
            })
        },
        || {
            qs.map_or((Rgb::BLACK, None), |q| {
                pt.f_local(scene, q, TransportMode::Radiance)
            })
        },
    )
}

/// One end of a connection: the last vertex of a subpath prefix, with the walk's throughput and
/// forward density there (which need not be the ones stored in the vertex: see
/// [`crate::pathspace::FullPath::strategies`]).
#[derive(Clone, Copy, Debug)]
pub struct End<'a> {
    /// The vertex.
    pub vertex: &'a Vertex,
    /// Throughput of the prefix up to it over its density.
    pub beta: Rgb,
    /// Its forward density (for the lens point: the lens density).
    pub pdf_fwd: f64,
}

/// The connection of a light prefix ending at `light` (`None`: `s = 0`) with a camera prefix
/// ending at `camera`, whose previous vertex is `before_camera` (`None`: `t = 1`, the lens
/// point). `f_light` gives the light end's factor toward the camera end (importance), `f_camera`
/// the camera end's toward the light end (radiance), each as [`Vertex::f`], with the end's
/// pair of directions in its BSDF's frame where it has one (kept in [`Connection::ends`]); they are
/// called only for strategies that need them. No visibility test.
pub fn join(
    scene: &Scene,
    light: Option<End<'_>>,
    camera: End<'_>,
    before_camera: Option<&Vertex>,
    f_light: impl FnOnce() -> (Rgb, Option<LocalPair>),
    f_camera: impl FnOnce() -> (Rgb, Option<LocalPair>),
) -> Option<Connection> {
    let pt = camera.vertex;
    let Some(q) = light else {
        // The camera subpath reached an emitter.
        let le = pt.le(scene, before_camera?);
        if le.is_black() {
            return None;
        }
        return Some(Connection {
            value: le * camera.beta,
            raster: None,
            ends: EndPairs::default(),
        });
    };
    let qs = q.vertex;
    if !qs.connectible() || !pt.connectible() {
        return None;
    }
    let (fq, light_pair) = if matches!(qs.kind, VertexKind::Light { .. }) {
        (qs.le(scene, pt), None)
    } else {
        f_light()
    };
    // A light end that sends nothing toward the camera end (the camera end behind its surface,
    // or outside its emission) makes the contribution zero: the camera end's factor, often a
    // BSDF evaluation, is not needed.
    if fq.is_black() {
        return None;
    }
    if before_camera.is_none() {
        let w = (qs.p() - pt.p()).normalize_or_zero();
        let (we, _, raster) = scene.camera.importance(pt.p(), w);
        let raster = raster?;
        let value = q.beta * fq * (we * geometry(scene, qs, pt) / camera.pdf_fwd);
        return (!value.is_black()).then_some(Connection {
            value,
            raster: Some(raster),
            ends: EndPairs {
                light: light_pair,
                camera: None,
            },
        });
    }
    let (fp, camera_pair) = f_camera();
    let value = q.beta * fq * fp * camera.beta * geometry(scene, qs, pt);
    (!value.is_black()).then_some(Connection {
        value,
        raster: None,
        ends: EndPairs {
            light: light_pair,
            camera: camera_pair,
        },
    })
}

/// The vertex as a segment end on a surface, if it lies on one.
fn surface_end(scene: &Scene, v: &Vertex) -> Option<SurfaceEnd> {
    v.on_surface(scene).then(|| SurfaceEnd::of(&v.point))
}
