//! Rays, primitives and their intersections, in f64, with the differential geometry of every
//! surface point (what shading normals and manifold walks need).

mod ray;
mod sphere;
mod triangle;

pub use ray::{Ray, offset_origin};
pub use sphere::Sphere;
pub use triangle::{NO_SHADING, Triangle, TriangleShading};

use crate::math::DVec3;

/// A point on a surface found by a ray or by sampling, with its differential geometry.
///
/// The surface is parameterised by `(u, v)` (a triangle's texture coordinates when it has them,
/// else the default `(0,0), (1,0), (1,1)` at its vertices, as pbrt; a sphere's `(φ/2π, θ/π)`).
/// `dpdu`, `dpdv` are the derivatives of the position and `dndu`, `dndv` those of the *unit*
/// shading normal — for a triangle with vertex normals, of the normalised interpolated normal
/// (zero for flat shading).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Position.
    pub p: DVec3,
    /// Unit geometric normal (oriented as the primitive defines it; it decides the sides of the
    /// surface: emission, inside and outside of dielectrics).
    pub n: DVec3,
    /// Unit shading normal: the interpolated vertex normal where the mesh has normals, else `n`;
    /// always on the side of `n`.
    pub ns: DVec3,
    /// Texture coordinates.
    pub uv: [f64; 2],
    /// Shading tangent for anisotropic BSDFs: the interpolated vertex tangent (pbrt `"S"`) where
    /// given, else `dpdu`.
    pub tangent: DVec3,
    /// `∂p/∂u`.
    pub dpdu: DVec3,
    /// `∂p/∂v`.
    pub dpdv: DVec3,
    /// `∂n_s/∂u`.
    pub dndu: DVec3,
    /// `∂n_s/∂v`.
    pub dndv: DVec3,
    /// Index of the primitive in the scene.
    pub primitive: u32,
}

impl SurfacePoint {
    /// A point with flat geometry and no parameterisation: position `p`, normal `n` for both
    /// normals (camera lens points, point lights).
    pub fn flat(p: DVec3, n: DVec3, primitive: u32) -> Self {
        Self {
            p,
            n,
            ns: n,
            uv: [0.0; 2],
            tangent: crate::math::Frame::from_normal(n).s,
            dpdu: DVec3::ZERO,
            dpdv: DVec3::ZERO,
            dndu: DVec3::ZERO,
            dndv: DVec3::ZERO,
            primitive,
        }
    }

    /// Whether the shading normal differs from the geometric one.
    pub fn shaded(&self) -> bool {
        self.ns != self.n
    }
}

/// A ray–surface intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter.
    pub t: f64,
    /// The surface point.
    pub point: SurfacePoint,
}
