//! `Shape "trianglemesh"|"plymesh"|"sphere"` → world-space [`MeshDesc`] / [`SphereDesc`].
//!
//! Meshes: vertices are transformed by the CTM, normals by its inverse transpose (flipped by
//! `ReverseOrientation`, as pbrt-v4 does), tangents `"S"` as vectors. Normals and tangents must be
//! finite and non-zero, and one per vertex, or the file is refused at the parameter's line; the
//! renderer shades with the interpolated normals. `flip_normals` is pbrt's `reverseOrientation ^
//! transformSwapsHandedness`, relative to the winding normal `(p1 − p0) × (p2 − p0)`. When normals
//! are given, pbrt orients the geometric normal towards the shading normal; the loader reproduces
//! that by swapping the winding of triangles whose oriented winding normal disagrees with the sum
//! of their vertex normals, so that the renderer's geometric normals (which decide the emitting side
//! of area lights and the inside of glass) face where pbrt's do.
//!
//! Triangles of zero area (relative to their edge lengths: `|e1 × e2| ≤ 1e-12 · max |e|²`) or
//! with non-finite vertices are dropped with a warning; an area light left with no area is an
//! error. Spheres need a similarity transform (rotation, reflection, translation and uniform
//! scale); anything else would turn them into ellipsoids and is an error.

use super::params::{FloatArg, ParamList};
use super::ply;
use super::transform;
use crate::error::{Error, Location, Result};
use crate::math::{DMat4, DVec3};
use crate::scene::description::{AreaLightDesc, MeshDesc, SceneDescription, SphereDesc};
use std::path::Path;

/// What the graphics state gives a shape.
pub(crate) struct ShapeContext<'a> {
    /// Object to world.
    pub ctm: DMat4,
    /// `ReverseOrientation` parity.
    pub reverse_orientation: bool,
    /// Material index.
    pub material: usize,
    /// Area light of the block.
    pub area_light: Option<AreaLightDesc>,
    /// Where the `Shape` directive was.
    pub location: Location,
    /// Directory for relative file names.
    pub dir: &'a Path,
}

/// Mesh data in object space.
struct ObjectMesh {
    positions: Vec<DVec3>,
    normals: Option<Vec<DVec3>>,
    tangents: Option<Vec<DVec3>>,
    uvs: Option<Vec<[f64; 2]>>,
    triangles: Vec<[u32; 3]>,
}

/// `Shape kind params…`: appends to `desc.meshes` or `desc.spheres` (and warnings).
pub(crate) fn shape(
    kind: &str,
    params: &ParamList,
    ctx: &ShapeContext,
    desc: &mut SceneDescription,
) -> Result<()> {
    match kind {
        "trianglemesh" => {
            check_alpha(params)?;
            let mesh = triangle_mesh(params)?;
            params.finish(
                "Shape \"trianglemesh\"",
                &["faceIndices", "discarddegenerateUVs"],
            )?;
            build_mesh("Shape \"trianglemesh\"", mesh, ctx, desc)
        }
        "plymesh" => {
            check_alpha(params)?;
            let file = params.string("filename")?.ok_or_else(|| {
                Error::scene(&ctx.location, "Shape \"plymesh\" needs \"string filename\"")
            })?;
            if params.has("displacement") {
                return Err(params.error("displacement", "displacement maps are not supported"));
            }
            let path = ctx.dir.join(file);
            let at = params.location("filename");
            let data = std::fs::read(&path).map_err(|e| {
                Error::scene(&at, format!("cannot read PLY file {}: {e}", path.display()))
            })?;
            let m = ply::parse(&data)
                .map_err(|e| Error::scene(&at, format!("PLY file {}: {e}", path.display())))?;
            params.finish(
                "Shape \"plymesh\"",
                &[
                    "discarddegenerateUVs",
                    "edgelength",
                    "displacement.edgelength",
                ],
            )?;
            if let Some(ns) = &m.normals
                && let Some(i) = ns.iter().position(|v| !usable_direction(*v))
            {
                return Err(Error::scene(
                    &at,
                    format!(
                        "PLY file {}: vertex normal {i} is {} (normals must be finite and non-zero)",
                        path.display(),
                        ns[i]
                    ),
                ));
            }
            let mesh = ObjectMesh {
                positions: m.positions,
                normals: m.normals,
                tangents: None,
                uvs: m.uvs,
                triangles: m.triangles,
            };
            build_mesh(&format!("Shape \"plymesh\" ({file})"), mesh, ctx, desc)
        }
        "sphere" => {
            let sphere = sphere(params, ctx)?;
            params.finish("Shape \"sphere\"", &[])?;
            desc.spheres.push(sphere);
            Ok(())
        }
        _ => Err(Error::scene(
            &ctx.location,
            format!("unsupported shape \"{kind}\" (supported: trianglemesh, plymesh, sphere)"),
        )),
    }
}

/// Alpha cut-outs change what is visible; only the no-op value 1 is accepted.
fn check_alpha(params: &ParamList) -> Result<()> {
    for key in ["alpha", "shadowalpha"] {
        match params.float_arg(key)? {
            None => {}
            Some(FloatArg::Value(1.0)) => {}
            Some(_) => {
                return Err(params.error(key, format!("\"{key}\" cut-outs are not supported")));
            }
        }
    }
    Ok(())
}

fn triangle_mesh(params: &ParamList) -> Result<ObjectMesh> {
    let positions = params.points("P")?.ok_or_else(|| {
        Error::scene(
            &params.directive,
            "Shape \"trianglemesh\" needs \"point3 P\"",
        )
    })?;
    let n = positions.len();
    if u32::try_from(n).is_err() {
        return Err(params.error("P", "too many vertices"));
    }
    let indices: Vec<i64> = match params.ints("indices")? {
        Some(v) => v.to_vec(),
        None if n == 3 => vec![0, 1, 2],
        None => {
            return Err(Error::scene(
                &params.directive,
                "Shape \"trianglemesh\" needs \"integer indices\" (unless P has exactly 3 points)",
            ));
        }
    };
    if !indices.len().is_multiple_of(3) || indices.is_empty() {
        return Err(params.error(
            "indices",
            format!(
                "\"indices\" must hold a positive multiple of 3 values, found {}",
                indices.len()
            ),
        ));
    }
    if let Some(&bad) = indices.iter().find(|&&i| i < 0 || i as u64 >= n as u64) {
        return Err(params.error(
            "indices",
            format!("vertex index {bad} is out of range (\"P\" has {n} points)"),
        ));
    }
    let triangles = indices
        .chunks_exact(3)
        .map(|c| [c[0] as u32, c[1] as u32, c[2] as u32])
        .collect();
    let normals = params.normals("N")?;
    let tangents = params.vectors("S")?;
    for (name, what, v) in [("N", "normals", &normals), ("S", "tangents", &tangents)] {
        let Some(v) = v else { continue };
        if v.len() != n {
            return Err(params.error(
                name,
                format!("\"{name}\" has {} {what} but \"P\" has {n} points", v.len()),
            ));
        }
        if let Some(i) = v.iter().position(|d| !usable_direction(*d)) {
            return Err(params.error(
                name,
                format!(
                    "\"{name}\" entry {i} is {} ({what} must be finite and non-zero)",
                    v[i]
                ),
            ));
        }
    }
    if params.has("uv") && params.has("st") {
        return Err(params.error("st", "give either \"uv\" or \"st\", not both"));
    }
    let uv_name = if params.has("st") { "st" } else { "uv" };
    let uvs = params.uvs(uv_name)?;
    if let Some(uv) = &uvs
        && uv.len() != n
    {
        return Err(params.error(
            uv_name,
            format!(
                "\"{uv_name}\" has {} coordinate pairs but \"P\" has {n} points",
                uv.len()
            ),
        ));
    }
    Ok(ObjectMesh {
        positions,
        normals,
        tangents,
        uvs,
        triangles,
    })
}

/// Whether a normal or tangent can be normalised.
fn usable_direction(v: DVec3) -> bool {
    v.is_finite() && v.length_squared() > 0.0
}

fn build_mesh(
    what: &str,
    mesh: ObjectMesh,
    ctx: &ShapeContext,
    desc: &mut SceneDescription,
) -> Result<()> {
    if !transform::is_affine(&ctx.ctm) {
        return Err(Error::scene(
            &ctx.location,
            format!("{what} under a projective transform is not supported"),
        ));
    }
    let positions: Vec<DVec3> = mesh
        .positions
        .iter()
        .map(|&p| ctx.ctm.transform_point3(p))
        .collect();
    let flip = ctx.reverse_orientation ^ transform::swaps_handedness(&ctx.ctm);
    let normals = match (mesh.normals, transform::normal_matrix(&ctx.ctm)) {
        (None, _) => None,
        (Some(ns), Some(m)) => {
            let sign = if ctx.reverse_orientation { -1.0 } else { 1.0 };
            Some(
                ns.iter()
                    .map(|&n| (m * n).normalize_or_zero() * sign)
                    .collect::<Vec<_>>(),
            )
        }
        (Some(_), None) => {
            desc.warnings.push((
                format!("{what}: the transform is singular; its normals \"N\" were dropped"),
                ctx.location.clone(),
            ));
            None
        }
    };
    let tangents = mesh.tangents.map(|ts| {
        ts.iter()
            .map(|&t| ctx.ctm.transform_vector3(t).normalize_or_zero())
            .collect::<Vec<_>>()
    });
    let sign = if flip { -1.0 } else { 1.0 };
    let total = mesh.triangles.len();
    let mut kept = Vec::with_capacity(total);
    for mut t in mesh.triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let (e1, e2) = (b - a, c - a);
        let cross = e1.cross(e2);
        let len = cross.length();
        let scale = e1.length_squared().max(e2.length_squared());
        if !(len.is_finite() && len > 1e-12 * scale) {
            continue;
        }
        let ng = cross * (sign / len);
        if let Some(ns) = &normals {
            let n = t.map(|i| ns[i as usize]);
            if (n[0] + n[1] + n[2]).dot(ng) < 0.0 {
                t.swap(1, 2);
            }
        }
        kept.push(t);
    }
    let dropped = total - kept.len();
    if dropped > 0 {
        desc.warnings.push((
            format!(
                "{what}: dropped {dropped} of {total} triangles that are degenerate (zero area or \
                 non-finite vertices)"
            ),
            ctx.location.clone(),
        ));
    }

    if kept.is_empty() {
        if ctx.area_light.is_some() {
            return Err(Error::scene(
                &ctx.location,
                format!("{what} is an area light with zero total area (all triangles degenerate)"),
            ));
        }
        desc.warnings.push((
            format!("{what}: no triangle left; the shape is skipped"),
            ctx.location.clone(),
        ));
        return Ok(());
    }
    desc.meshes.push(MeshDesc {
        positions,
        normals,
        tangents,
        uvs: mesh.uvs,
        indices: kept,
        material: ctx.material,
        area_light: ctx.area_light,
        flip_normals: flip,
        location: Some(ctx.location.clone()),
    });
    Ok(())
}

fn sphere(params: &ParamList, ctx: &ShapeContext) -> Result<SphereDesc> {
    let radius = params.float("radius")?.unwrap_or(1.0);
    if radius <= 0.0 {
        return Err(params.error(
            "radius",
            if ctx.area_light.is_some() {
                "a sphere area light needs a positive radius (zero area)"
            } else {
                "sphere radius must be positive"
            },
        ));
    }
    let zmin = params.float("zmin")?.unwrap_or(-radius);
    let zmax = params.float("zmax")?.unwrap_or(radius);
    let phimax = params.float("phimax")?.unwrap_or(360.0);
    if zmin > -radius || zmax < radius || phimax < 360.0 {
        return Err(Error::scene(
            &ctx.location,
            "partial spheres (zmin, zmax, phimax) are not supported",
        ));
    }
    if !transform::is_affine(&ctx.ctm) {
        return Err(Error::scene(
            &ctx.location,
            "Shape \"sphere\" under a projective transform is not supported",
        ));
    }
    let s = transform::similarity_scale(&ctx.ctm).map_err(|f| {
        Error::scene(
            &ctx.location,
            format!(
                "Shape \"sphere\" needs a similarity transform (rotation, translation, uniform \
                 scale); the current transform scales the axes by {:.6}, {:.6}, {:.6} or shears \
                 them, which would make an ellipsoid",
                f[0], f[1], f[2]
            ),
        )
    })?;
    let center = ctx.ctm.transform_point3(DVec3::ZERO);
    let radius = radius * s;
    if !center.is_finite() || !radius.is_finite() {
        return Err(Error::scene(&ctx.location, "sphere is not finite"));
    }
    Ok(SphereDesc {
        center,
        radius,
        material: ctx.material,
        area_light: ctx.area_light,
        flip_normals: ctx.reverse_orientation ^ transform::swaps_handedness(&ctx.ctm),
        location: Some(ctx.location.clone()),
    })
}
