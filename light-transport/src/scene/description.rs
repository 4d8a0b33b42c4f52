//! The scene model: plain data produced by the loaders (pbrt-v3 files, built-in scenes) and
//! turned into a renderable [`crate::scene::Scene`] by [`crate::scene::Scene::new`]. Everything is
//! in world space.

use crate::error::Location;
use crate::math::{DMat4, DVec3};
use crate::spectrum::Rgb;

/// A complete scene description.
#[derive(Clone, Debug, Default)]
pub struct SceneDescription {
    /// The camera.
    pub camera: Option<CameraDesc>,
    /// Image size and name.
    pub film: FilmDesc,
    /// Triangle meshes.
    pub meshes: Vec<MeshDesc>,
    /// Spheres.
    pub spheres: Vec<SphereDesc>,
    /// Materials, referenced by index.
    pub materials: Vec<MaterialDesc>,
    /// Image textures, referenced by index.
    pub textures: Vec<TextureDesc>,
    /// Point and infinite lights (area lights are attached to shapes).
    pub lights: Vec<LightDesc>,
    /// Directives that were read and deliberately ignored (pbrt's own integrator, sampler, filter
    /// choices), with where they were.
    pub ignored: Vec<(String, Location)>,
    /// Non-fatal findings (dropped degenerate triangles, …), with where they were.
    pub warnings: Vec<(String, Location)>,
}

/// Camera models.
#[derive(Clone, Debug, PartialEq)]
pub enum Projection {
    /// Perspective with full field of view (radians) along the image's shorter axis (pbrt's
    /// convention), a lens radius (0 for a pinhole) and a focal distance.
    Perspective {
        /// Field of view along the shorter image axis, in radians.
        fov: f64,
        /// Lens radius (0: pinhole).
        lens_radius: f64,
        /// Distance of the plane in focus.
        focal_distance: f64,
    },
}

/// A camera.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDesc {
    /// Camera-to-world transform. Camera space has `+x` towards the image's right edge (growing
    /// pixel column), `+y` towards its top edge (shrinking pixel row) and `+z` forward; so the
    /// columns of this matrix are, in world space, the image's right axis, its up axis, the viewing
    /// direction and the camera position. For a `W×H` film with `a = tan(fov/2)` and
    /// `(sx, sy) = (a·W/H, a)` when `W ≥ H`, else `(a, a·H/W)`, the pinhole ray through the film
    /// point `(px, py)` (pixels from the left and top edges) has the camera-space direction
    /// `((2·px/W − 1)·sx, (1 − 2·py/H)·sy, 1)`, mapped to the world with `transform_vector3`; the
    /// thin lens lies in the camera's `z = 0` plane and focuses on `z = focal_distance`.
    ///
    /// This is exactly pbrt's camera frame (the pbrt loader stores the inverse of the transform
    /// in effect at `Camera`, which pbrt defines as world-to-camera). That frame is left-handed
    /// (`x` right, `y` up, `z` into the image), so the 3×3 part may have a negative determinant,
    /// e.g. for the Cornell box scene: use the columns as given and never rebuild the right axis
    /// from `forward × up`, or images come out mirrored relative to pbrt's.
    pub camera_to_world: DMat4,
    /// Projection.
    pub projection: Projection,
}

/// Image size.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmDesc {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Output name requested by the scene (informational).
    pub filename: Option<String>,
}

impl Default for FilmDesc {
    fn default() -> Self {
        Self {
            width: 640,
            height: 480,
            filename: None,
        }
    }
}

/// A diffuse area light attached to a shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaLightDesc {
    /// Emitted radiance.
    pub radiance: Rgb,
    /// Emit from both sides (pbrt `twosided`).
    pub two_sided: bool,
}

/// A triangle mesh in world space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshDesc {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Optional shading normals per vertex (world space, unit length or zero). The pbrt loader
    /// flips them under `ReverseOrientation` (pbrt-v4 behaviour) and winds every triangle so that
    /// its oriented geometric normal lies on the same side as the sum of its vertex normals, as
    /// pbrt orients geometric normals towards shading normals.
    pub normals: Option<Vec<DVec3>>,
    /// Optional shading tangents per vertex (pbrt `"S"`, world space), the direction of
    /// anisotropy of BSDFs.
    pub tangents: Option<Vec<DVec3>>,
    /// Optional texture coordinates per vertex.
    pub uvs: Option<Vec<[f64; 2]>>,
    /// Triangles (indices into the vertex arrays).
    pub indices: Vec<[u32; 3]>,
    /// Material index.
    pub material: usize,
    /// Emission, when the mesh is an area light.
    pub area_light: Option<AreaLightDesc>,
    /// Swap the geometric normal's orientation (pbrt `ReverseOrientation` / handedness): the
    /// geometric normal of triangle `[i0, i1, i2]` is `normalize((p1 − p0) × (p2 − p0))`, negated
    /// when this is set. The pbrt loader sets it to `ReverseOrientation` xor "the object-to-world
    /// transform mirrors space", as pbrt does.
    pub flip_normals: bool,
    /// Where it was declared.
    pub location: Option<Location>,
}

/// A sphere in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereDesc {
    /// Centre.
    pub center: DVec3,
    /// Radius (> 0).
    pub radius: f64,
    /// Material index.
    pub material: usize,
    /// Emission, when the sphere is an area light.
    pub area_light: Option<AreaLightDesc>,
    /// Normals point inwards (pbrt `ReverseOrientation`, xor a mirroring object-to-world
    /// transform, as pbrt does).
    pub flip_normals: bool,
    /// Where it was declared.
    pub location: Option<Location>,
}

/// A reflectance that is either constant or looked up in an image texture.
#[derive(Clone, Debug, PartialEq)]
pub enum RgbTexture {
    /// A constant.
    Constant(Rgb),
    /// An image texture (index into [`SceneDescription::textures`]) scaled component-wise.
    Image {
        /// Texture index.
        texture: usize,
        /// Scale.
        scale: Rgb,
    },
}

/// An image texture.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureDesc {
    /// Linear RGB texels, row 0 at the top (v = 1).
    pub texels: Vec<Rgb>,
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// `uv` scale and offset: `(u·su + du, v·sv + dv)`.
    pub uv_scale: [f64; 2],
    /// `uv` offset.
    pub uv_offset: [f64; 2],
    /// Where the image came from.
    pub name: String,
}

/// Materials.
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialDesc {
    /// Lambertian (pbrt `matte`).
    Matte {
        /// Diffuse reflectance.
        kd: RgbTexture,
    },
    /// Rough conductor: GGX with visible-normal sampling, anisotropic (pbrt `metal`); roughness is
    /// the GGX `α` (after pbrt's remapping when `remaproughness` was true).
    Metal {
        /// Index of refraction (real part).
        eta: Rgb,
        /// Absorption coefficient.
        k: Rgb,
        /// `α_u`.
        alpha_u: f64,
        /// `α_v`.
        alpha_v: f64,
    },
    /// Perfect mirror (pbrt `mirror`).
    Mirror {
        /// Reflectance.
        kr: Rgb,
    },
    /// Dielectric: smooth when both roughnesses are 0, otherwise rough GGX (pbrt `glass`).
    Glass {
        /// Index of refraction inside over outside.
        eta: f64,
        /// `α_u` (0: smooth).
        alpha_u: f64,
        /// `α_v` (0: smooth).
        alpha_v: f64,
        /// Reflection tint.
        kr: Rgb,
        /// Transmission tint.
        kt: Rgb,
    },
    /// A diffuse base under a GGX dielectric coating with Fresnel-weighted lobe choice (pbrt
    /// `plastic` and `substrate`): the layered material of the charted-MLT paper.
    Layered {
        /// Diffuse base reflectance.
        kd: RgbTexture,
        /// Specular tint of the coating.
        ks: Rgb,
        /// Coating `α_u`.
        alpha_u: f64,
        /// Coating `α_v`.
        alpha_v: f64,
        /// Coating index of refraction.
        eta: f64,
    },
    /// A choice between two materials: `amount · a + (1 − amount) · b` (pbrt `mix`).
    Mix {
        /// First material (weight `amount`).
        a: usize,
        /// Second material.
        b: usize,
        /// Weight of `a` per channel.
        amount: Rgb,
    },
}

/// Lights that are not attached to shapes.
#[derive(Clone, Debug, PartialEq)]
pub enum LightDesc {
    /// An isotropic point light.
    Point {
        /// Position.
        position: DVec3,
        /// Radiant intensity.
        intensity: Rgb,
    },
    /// A uniform infinite environment.
    Infinite {
        /// Radiance from every direction.
        radiance: Rgb,
    },
}
