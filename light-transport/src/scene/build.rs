//! The renderable scene: primitives in a BVH, materials, lights chosen by power, the camera.

use super::description::*;
use crate::accel::{Bvh, Compact, Primitive};
use crate::bsdf::{Bsdf, PrebuiltLobes};
use crate::camera::Camera;
use crate::geometry::{
    Hit, NO_PRIMITIVE, NO_SHADING, Ray, Sphere, SurfaceEnd, SurfacePoint, Triangle,
    TriangleShading, offset_origin,
};
use crate::light::{LightDistribution, LightKind};
use crate::math::{DVec3, Frame};
use crate::spectrum::Rgb;
use crate::{Error, Result};
use std::borrow::Cow;

/// Sentinel for "no light" / "no material".
pub const NONE: u32 = u32::MAX;

/// A scene ready to render.
pub struct Scene {
    /// Geometry.
    pub bvh: Bvh,
    /// Material of each primitive.
    pub primitive_material: Vec<u32>,
    /// Light of each primitive ([`NONE`] if not emissive).
    pub primitive_light: Vec<u32>,
    /// Materials. The lobes of those without image textures are built from them once, when the
    /// scene is built: a change made here afterwards does not reach them.
    pub materials: Vec<MaterialDesc>,
    /// Textures.
    pub textures: Vec<TextureDesc>,
    /// Lights.
    pub lights: Vec<LightKind>,
    /// Light choice by power.
    pub light_distribution: LightDistribution,
    /// The camera.
    pub camera: Camera,
    /// Bounding box of the geometry.
    pub bounds: (DVec3, DVec3),
    /// Warnings and ignored directives from loading, for the user.
    pub notes: Vec<String>,
    /// Whether light subpaths carry the adjoint correction of shading normals (Veach 1997 §5.3;
    /// see [`crate::path::Vertex::shading_factor`]). Always on; off only to show that the
    /// unbiasedness tests see its absence.
    pub adjoint_correction: bool,
    /// The lobes of the materials that are the same at every surface point.
    lobes: PrebuiltLobes,
}

impl Scene {
    /// Build from a description; the image size is the description's unless overridden.
    pub fn new(desc: &SceneDescription, resolution: Option<(usize, usize)>) -> Result<Self> {
        Self::with_bvh(desc, resolution, Compact::No)
    }

    /// As [`Scene::new`], with the BVH built `compact` or not (see [`Compact`]).
    pub fn with_bvh(
        desc: &SceneDescription,
        resolution: Option<(usize, usize)>,
        compact: Compact,
    ) -> Result<Self> {
        Self::build(Cow::Borrowed(desc), resolution, compact)
    }

    /// As [`Scene::with_bvh`], consuming the description: its meshes are released as soon as the
    /// primitives are made from them, before the BVH's packets exist, so that a large mesh is
    /// never held three times (the benchmarks' 1M-triangle terrain: 25 MB less at the peak).
    pub fn from_description(
        desc: SceneDescription,
        resolution: Option<(usize, usize)>,
        compact: Compact,
    ) -> Result<Self> {
        Self::build(Cow::Owned(desc), resolution, compact)
    }

    fn build(
        mut desc: Cow<'_, SceneDescription>,
        resolution: Option<(usize, usize)>,
        compact: Compact,
    ) -> Result<Self> {
        let cam = desc
            .camera
            .as_ref()
            .ok_or_else(|| Error::InvalidScene("no camera".into()))?;
        let (w, h) = resolution.unwrap_or((desc.film.width, desc.film.height));
        validate_resolution(w, h)?;
        let camera = Camera::new(cam, w, h)?;
        // Geometry is built in two phases (`Bvh::topology`, `Bvh::assemble`): the primitives are
        // first only named, `(mesh, triangle)` or `(SPHERE, sphere)`, and created once the tree
        // is known, directly in leaf order, so a large mesh never exists twice in memory.
        // Sized once (an upper bound: degenerate triangles are dropped), so that growing them
        // does not briefly hold two copies of a large mesh's lists.
        let count =
            desc.meshes.iter().map(|m| m.indices.len()).sum::<usize>() + desc.spheres.len() + 1;
        let mut prims: Vec<[u32; 2]> = Vec::with_capacity(count);
        let mut prim_mat = Vec::with_capacity(count);
        let mut emissive: Vec<(u32, AreaLightDesc)> = Vec::new();
        let material_index = |m: usize, what: &str| -> Result<u32> {
            let n = desc.materials.len() + 1;
            if m < n {
                Ok(m as u32)
            } else {
                Err(Error::InvalidScene(format!(
                    "{what} refers to material {m}, but only {n} exist"
                )))
            }
        };
        for (k, mesh) in desc.meshes.iter().enumerate() {
            let m = material_index(mesh.material, "a mesh")?;
            let mut area = 0.0;
            let first = prims.len();
            for (j, tri) in mesh.indices.iter().enumerate() {
                let t = mesh_triangle(mesh, *tri)?;
                let a = t.area();
                if !(a > 0.0 && a.is_finite()) {
                    continue; // loaders drop and report degenerate triangles; never trace them
                }
                // Checked here so that errors come before the build.
                triangle_shading(mesh, *tri, t.normal())?;
                area += a;
                prims.push([k as u32, j as u32]);
                prim_mat.push(m);
            }
            if let Some(al) = mesh.area_light {
                if !(area > 0.0) {
                    return Err(Error::InvalidScene(format!(
                        "an area light mesh{} has zero area",
                        at(&mesh.location)
                    )));
                }
                for i in first..prims.len() {
                    emissive.push((i as u32, al));
                }
            }
        }
        // A uniform infinite light is represented exactly by an enclosing sphere that emits the same
        // radiance inward (radiance is constant along rays, so every ray leaving the scene sees L
        // whichever point of the sphere it reaches); the sphere absorbs.
        let mut spheres = desc.spheres.clone();
        let mut materials = desc.materials.clone();
        let infinite: Vec<Rgb> = desc
            .lights
            .iter()
            .filter_map(|l| {
                if let LightDesc::Infinite { radiance } = l {
                    Some(*radiance)
                } else {
                    None
                }
            })
            .collect();
        if infinite.len() > 1 {
            return Err(Error::InvalidScene("more than one infinite light".into()));
        }
        if let Some(&radiance) = infinite.first() {
            let (lo, hi) = scene_extent(&desc, camera.position());
            let center = (lo + hi) / 2.0;
            let radius = ((hi - lo).length() / 2.0).max(1e-3) * 2.0;
            materials.push(MaterialDesc::Matte {
                kd: RgbTexture::Constant(Rgb::BLACK),
            });
            spheres.push(SphereDesc {
                center,
                radius,
                material: materials.len() - 1,
                area_light: Some(AreaLightDesc {
                    radiance,
                    two_sided: false,
                }),
                flip_normals: true,
                location: None,
            });
        }
        let _ = nmat_check(&materials)?;
        let first_sphere = prims.len() as u32;
        for s in &spheres {
            if !(s.radius > 0.0 && s.radius.is_finite() && s.center.is_finite()) {
                return Err(Error::InvalidScene(format!(
                    "sphere{} has radius {} at {}",
                    at(&s.location),
                    s.radius,
                    s.center
                )));
            }
            let m = material_index(s.material, "a sphere")?;
            let i = prims.len() as u32;
            prims.push([SPHERE, i - first_sphere]);
            prim_mat.push(m);
            if let Some(al) = s.area_light {
                emissive.push((i, al));
            }
        }
        let primitive = |[k, j]: [u32; 2]| -> Result<Primitive> {
            Ok(if k == SPHERE {
                let s = &spheres[j as usize];
                Primitive::Sphere(Sphere {
                    center: s.center,
                    radius: s.radius,
                    flip: s.flip_normals,
                })
            } else {
                let mesh = &desc.meshes[k as usize];
                Primitive::Triangle(mesh_triangle(mesh, mesh.indices[j as usize])?)
            })
        };
        let topology = Bvh::topology(prims.len(), compact, |i, out| match primitive(prims[i]) {
            Ok(p) => p.references(out),
            Err(_) => unreachable!("every primitive was checked above"),
        });
        let mut shading: Vec<TriangleShading> = Vec::new();
        let mut leaf_order = Vec::with_capacity(prims.len());
        for &i in topology.original() {
            let mut p = primitive(prims[i as usize])?;
            if let Primitive::Triangle(t) = &mut p {
                let [k, j] = prims[i as usize];
                let mesh = &desc.meshes[k as usize];
                if let Some(sh) = triangle_shading(mesh, mesh.indices[j as usize], t.normal())? {
                    t.shading = shading.len() as u32;
                    shading.push(sh);
                }
            }
            leaf_order.push(p);
        }
        drop(prims);
        if let Cow::Owned(d) = &mut desc {
            d.meshes = Vec::new();
        }
        release_free_memory();
        let bvh = Bvh::assemble(topology, leaf_order, shading);
        // The BVH stores primitives in its leaf order: carry the per-primitive tables over.
        let mut new_index = vec![0u32; bvh.original.len()];
        for (new, &old) in bvh.original.iter().enumerate() {
            new_index[old as usize] = new as u32;
        }
        let prim_mat: Vec<u32> = bvh
            .original
            .iter()
            .map(|&old| prim_mat[old as usize])
            .collect();
        let emissive: Vec<(u32, AreaLightDesc)> = emissive
            .into_iter()
            .map(|(old, al)| (new_index[old as usize], al))
            .collect();
        let bounds = if bvh.primitives.is_empty() {
            (DVec3::ZERO, DVec3::ZERO)
        } else {
            bvh.bounds()
        };
        let mut lights = Vec::new();
        let mut prim_light = vec![NONE; bvh.primitives.len()];
        for (i, al) in emissive {
            if !al.radiance.is_finite() || al.radiance.0.iter().any(|&v| v < 0.0) {
                return Err(Error::InvalidScene(format!(
                    "area light radiance {:?} is negative or not finite",
                    al.radiance.0
                )));
            }
            if al.radiance.is_black() {
                continue;
            }
            let area = match bvh.primitives[i as usize] {
                Primitive::Triangle(t) => t.area(),
                Primitive::Sphere(s) => s.area(),
            };
            prim_light[i as usize] = lights.len() as u32;
            lights.push(LightKind::Area {
                primitive: i,
                radiance: al.radiance,
                two_sided: al.two_sided,
                area,
            });
        }
        for l in &desc.lights {
            if let LightDesc::Point {
                position,
                intensity,
            } = *l
            {
                if !position.is_finite()
                    || !intensity.is_finite()
                    || intensity.0.iter().any(|&v| v < 0.0)
                {
                    return Err(Error::InvalidScene("a point light has a non-finite position or a negative or non-finite intensity".into()));
                }
                lights.push(LightKind::Point {
                    position,
                    intensity,
                });
            }
        }
        let powers: Vec<f64> = lights.iter().map(|l| l.power()).collect();
        if !(powers.iter().sum::<f64>() > 0.0) {
            return Err(Error::InvalidScene(
                "the scene has no light with positive power: the image would be black".into(),
            ));
        }
        let mut notes: Vec<String> = desc
            .ignored
            .iter()
            .map(|(d, l)| format!("{l}: ignored {d}"))
            .collect();
        notes.extend(desc.warnings.iter().map(|(w, l)| format!("{l}: {w}")));
        Ok(Self {
            bvh,
            primitive_material: prim_mat,
            primitive_light: prim_light,
            lobes: PrebuiltLobes::new(&materials, &desc.textures),
            materials,
            textures: desc.textures.clone(),
            light_distribution: LightDistribution::new(&powers),
            lights,
            camera,
            bounds,
            notes,
            adjoint_correction: true,
        })
    }

    /// The closest surface along a ray.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.bvh
            .closest_hit_leaving(ray.o, ray.d, ray.t_max, ray.leaves)
    }

    /// Whether two points see each other (each end on a surface offset from it toward the other;
    /// an end's triangle is not tested when the offset segment cannot cross it, [`SurfaceEnd`]).
    pub fn visible(
        &self,
        a: DVec3,
        on_a: Option<SurfaceEnd>,
        b: DVec3,
        on_b: Option<SurfaceEnd>,
    ) -> bool {
        let d = b - a;
        let o = on_a.map_or(a, |s| offset_origin(a, s.n, d));
        let e = on_b.map_or(b, |s| offset_origin(b, s.n, -d));
        let v = e - o;
        let dist = v.length();
        if !(dist > 0.0) {
            return true;
        }
        // An end's triangle is skipped when the offset segment lies on one side of its plane: not
        // so when the other end lies within the offset of that plane, e.g. on the same triangle.
        let skip = |end: Option<SurfaceEnd>, p: DVec3| {
            end.filter(|s| (o - p).dot(s.n) * (e - p).dot(s.n) > 0.0)
                .map_or(NO_PRIMITIVE, |s| s.primitive)
        };
        !self
            .bvh
            .occluded_between(o, v / dist, dist, [skip(on_a, a), skip(on_b, b)])
    }

    /// The BSDF at a surface point: in the shading frame (shading normal, shading tangent), the
    /// geometric normal deciding the sides of the surface.
    pub fn bsdf(&self, point: &SurfacePoint) -> Result<Bsdf> {
        let frame = Frame::from_normal_tangent(point.ns, point.tangent);
        let mut b = Bsdf::empty(frame);
        self.rebuild_bsdf(point, frame, &mut b)?;
        Ok(b)
    }

    /// Make `b` the BSDF at `point` in the shading frame `frame`: copied from the material's
    /// prebuilt lobes where it has them, built from its tree otherwise.
    #[inline]
    fn rebuild_bsdf(&self, point: &SurfacePoint, frame: Frame, b: &mut Bsdf) -> Result<()> {
        let m = self.primitive_material[point.primitive as usize] as usize;
        match self.lobes.get(m) {
            Some(lobes) => b.rebuild_from(lobes, frame),
            None => b.rebuild(
                &self.materials,
                &self.textures,
                m,
                self.bvh.texture_coordinates(point),
                frame,
            )?,
        }
        b.ng = point.n;
        Ok(())
    }

    /// [`Scene::bsdf`] in place, reusing the storage of the BSDF `out` holds: afterwards `out`
    /// is the BSDF at `point`, or `None` where [`Scene::bsdf`] fails.
    pub fn bsdf_into(&self, point: &SurfacePoint, out: &mut Option<Bsdf>) {
        let frame = Frame::from_normal_tangent(point.ns, point.tangent);
        let b = out.get_or_insert_with(|| Bsdf::empty(frame));
        if self.rebuild_bsdf(point, frame, b).is_err() {
            *out = None;
        }
    }

    /// The light at a primitive, if it is emissive.
    pub fn light_at(&self, primitive: u32) -> Option<(usize, &LightKind)> {
        let l = *self.primitive_light.get(primitive as usize)?;
        (l != NONE).then(|| (l as usize, &self.lights[l as usize]))
    }

    /// Number of triangles and spheres.
    pub fn primitive_counts(&self) -> (usize, usize) {
        let t = self
            .bvh
            .primitives
            .iter()
            .filter(|p| matches!(p, Primitive::Triangle(_)))
            .count();
        (t, self.bvh.primitives.len() - t)
    }
}

fn nmat_check(materials: &[MaterialDesc]) -> Result<usize> {
    for (i, m) in materials.iter().enumerate() {
        if let MaterialDesc::Mix { a, b, .. } = m
            && (*a >= materials.len() || *b >= materials.len())
        {
            return Err(Error::InvalidScene(format!(
                "mix material {i} refers to a missing material"
            )));
        }
    }
    Ok(materials.len())
}

/// Bounding box of the geometry and the camera position.
fn scene_extent(desc: &SceneDescription, camera: DVec3) -> (DVec3, DVec3) {
    let mut lo = camera;
    let mut hi = camera;
    for m in &desc.meshes {
        for p in &m.positions {
            if p.is_finite() {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
    }
    for s in &desc.spheres {
        lo = lo.min(s.center - DVec3::splat(s.radius));
        hi = hi.max(s.center + DVec3::splat(s.radius));
    }
    for l in &desc.lights {
        if let LightDesc::Point { position, .. } = l {
            lo = lo.min(*position);
            hi = hi.max(*position);
        }
    }
    (lo, hi)
}

fn at(loc: &Option<crate::error::Location>) -> String {
    loc.as_ref().map(|l| format!(" ({l})")).unwrap_or_default()
}

/// Refuse absurd image sizes.
pub fn validate_resolution(w: usize, h: usize) -> Result<()> {
    const MAX: usize = 16_384;
    if w == 0 || h == 0 || w > MAX || h > MAX {
        return Err(Error::InvalidParameter {
            name: "resolution".into(),
            reason: format!("{w}×{h} is outside 1×1 … {MAX}×{MAX}"),
        });
    }
    Ok(())
}

/// `Scene::new`'s name of a sphere primitive: `[SPHERE, index]`.
const SPHERE: u32 = u32::MAX;

/// Triangle `tri` of `mesh`, flat (its shading data comes from [`triangle_shading`]).
fn mesh_triangle(mesh: &MeshDesc, tri: [u32; 3]) -> Result<Triangle> {
    let get = |i: u32| {
        mesh.positions.get(i as usize).copied().ok_or_else(|| {
            Error::InvalidScene(format!(
                "triangle index {i} out of range ({} vertices)",
                mesh.positions.len()
            ))
        })
    };
    let p = [get(tri[0])?, get(tri[1])?, get(tri[2])?];
    let uv = match &mesh.uvs {
        Some(uvs) => [tri[0], tri[1], tri[2]].map(|i| {
            let [u, v] = uvs.get(i as usize).copied().unwrap_or([0.0, 0.0]);
            [u as f32, v as f32]
        }),
        None => [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]],
    };
    Ok(Triangle {
        p,
        uv,
        flip: mesh.flip_normals,
        shading: NO_SHADING,
    })
}

/// The shading data of triangle `tri` of `mesh` (`None` when the mesh has no normals, or they
/// are the flat normal `n` at every vertex). The loader winds triangles so that the sum of their
/// vertex normals lies on the side of `n`; where an interpolated normal does not, the hit point
/// flips it (see [`Triangle::point_shaded`]).
fn triangle_shading(mesh: &MeshDesc, tri: [u32; 3], n: DVec3) -> Result<Option<TriangleShading>> {
    let Some(normals) = &mesh.normals else {
        return Ok(None);
    };
    let get = |v: &[DVec3], i: u32, what: &str| {
        v.get(i as usize).copied().ok_or_else(|| {
            Error::InvalidScene(format!(
                "mesh{}: {what} index {i} out of range ({} given)",
                at(&mesh.location),
                v.len()
            ))
        })
    };
    let mut ns = [DVec3::ZERO; 3];
    for (k, &i) in tri.iter().enumerate() {
        let v = get(normals, i, "normal")?;
        let v = v.try_normalize().ok_or_else(|| {
            Error::InvalidScene(format!(
                "mesh{}: vertex normal {i} is zero or not finite ({v})",
                at(&mesh.location)
            ))
        })?;
        ns[k] = v;
    }
    if ns.iter().all(|v| (*v - n).length() < 1e-12) {
        return Ok(None);
    }
    let s = match &mesh.tangents {
        Some(t) => Some([
            get(t, tri[0], "tangent")?,
            get(t, tri[1], "tangent")?,
            get(t, tri[2], "tangent")?,
        ]),
        None => None,
    };
    Ok(Some(TriangleShading { n: ns, s }))
}

/// Return the allocator's free pages to the system (glibc's `malloc_trim`). Between the tree's
/// build and its packets, most of what the parser and the builder allocated is free, but glibc
/// keeps freed blocks of its main heap resident: on the benchmarks' 1M-triangle terrain 60 MB,
/// which the packets would then have come on top of (peak 233 MB instead of the build's 200 MB).
/// Elsewhere a no-op.
fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `malloc_trim` only releases memory no allocation holds.
    unsafe {
        libc::malloc_trim(0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin::SceneBuilder;
    use mcmc_core::rng::{stream, uniform};

    /// The BSDF at every hit is the one its material's tree gives at that point, whether the
    /// scene copied prebuilt lobes (untextured materials) or built them there (textured ones),
    /// also into a BSDF that last held another material's lobes.
    #[test]
    fn the_bsdf_at_a_hit_is_its_materials_at_that_point() {
        let mut b = SceneBuilder::new(48, 32, DVec3::new(0.0, 1.0, 3.0), DVec3::ZERO, 60.0);
        let textured = b.material(MaterialDesc::Matte {
            kd: RgbTexture::Image {
                texture: 0,
                scale: Rgb::WHITE,
            },
        });
        let white = b.matte(0.7, 0.7, 0.7);
        let plastic = b.material(MaterialDesc::Layered {
            kd: RgbTexture::Constant(Rgb::new(0.5, 0.4, 0.3)),
            ks: Rgb::splat(0.2),
            alpha_u: 0.1,
            alpha_v: 0.1,
            eta: 1.5,
        });
        let amount = Rgb::new(0.2, 0.5, 0.8);
        let two = b.material(MaterialDesc::Mix {
            a: plastic,
            b: plastic,
            amount,
        });
        let spilled = b.material(MaterialDesc::Mix {
            a: two,
            b: plastic,
            amount,
        });
        let textured_mix = b.material(MaterialDesc::Mix {
            a: textured,
            b: spilled,
            amount,
        });
        let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
        b.quad(
            DVec3::new(-2.0, 0.0, -2.0),
            z * 4.0,
            x * 2.0,
            textured,
            None,
        );
        b.quad(
            DVec3::new(0.0, 0.0, -2.0),
            z * 4.0,
            x * 2.0,
            textured_mix,
            None,
        );
        b.quad(DVec3::new(-2.0, 0.0, -1.0), x * 2.0, y * 2.0, spilled, None);
        b.quad(DVec3::new(0.0, 0.0, -1.0), x * 2.0, y * 2.0, white, None);
        b.sphere(DVec3::new(0.0, 0.4, 0.0), 0.4, two);
        let light = Some(Rgb::splat(5.0));
        b.quad(DVec3::new(-0.5, 3.0, -0.5), z, x, white, light);
        let mut d = b.finish();
        d.textures.push(crate::bsdf::prebuilt::tests::checker(3.0));
        let scene = Scene::new(&d, None).unwrap();
        assert!(scene.lobes.get(textured).is_none() && scene.lobes.get(textured_mix).is_none());
        assert!(scene.lobes.get(spilled).is_some() && scene.lobes.get(white).is_some());
        let mut rng = stream(3, 0);
        let mut slot = None;
        let mut seen = vec![0; scene.materials.len()];
        for _ in 0..2000 {
            let film = [uniform(&mut rng), uniform(&mut rng)];
            let ray = scene.camera.sample_ray(film, [0.5, 0.5]).ray;
            let Some(hit) = scene.intersect(&ray) else {
                continue;
            };
            let p = &hit.point;
            let m = scene.primitive_material[p.primitive as usize] as usize;
            let frame = Frame::from_normal_tangent(p.ns, p.tangent);
            let expected = Bsdf::from_material(
                &scene.materials,
                &scene.textures,
                m,
                scene.bvh.texture_coordinates(p),
                frame,
            )
            .unwrap()
            .with_geometric_normal(p.n);
            scene.bsdf_into(p, &mut slot);
            assert_eq!(
                slot.as_ref(),
                Some(&expected),
                "material {m} at {:?}",
                scene.bvh.texture_coordinates(p)
            );
            assert_eq!(scene.bsdf(p).unwrap(), expected);
            seen[m] += 1;
        }
        for m in [textured, white, two, spilled, textured_mix] {
            assert!(seen[m] > 20, "material {m} hit {} times", seen[m]);
        }
    }
}
