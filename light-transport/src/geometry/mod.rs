//! Rays, primitives and their intersections, in f64: surface points with their shading normals
//! and texture coordinates, and on demand their differential geometry (what manifold walks need).

mod ray;
mod sphere;
mod triangle;

pub use ray::{Ray, SurfaceEnd, offset_origin};
pub use sphere::Sphere;
pub use triangle::{NO_SHADING, Triangle, TriangleFrame, TriangleShading};

use crate::math::DVec3;

/// The primitive index of points on no primitive ([`SurfacePoint::flat`]'s lens and point-light
/// points) and of rays that leave none ([`Ray::new`]).
pub const NO_PRIMITIVE: u32 = u32::MAX;

/// A point on a surface found by a ray or by sampling.
///
/// The surface is parameterised by `(u, v)` (a triangle's texture coordinates when it has them,
/// else the default `(0,0), (1,0), (1,1)` at its vertices, as pbrt; a sphere's `(φ/2π, θ/π)`).
/// Neither the texture coordinates nor the derivatives of that parameterisation
/// ([`Derivatives`]) are carried: only textured materials read the first and only manifold walks
/// the second, while every hit's point is built and moved (at 120 bytes a move is an inline copy;
/// above 128 it is a call to `memcpy`). `Bvh::texture_coordinates` and `Bvh::derivatives`
/// compute them from the point's primitive and `local` coordinates.
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
    /// Shading tangent for anisotropic BSDFs: the interpolated vertex tangent (pbrt `"S"`) where
    /// given, else the direction of `∂p/∂u`.
    pub tangent: DVec3,
    /// The point's coordinates on its primitive, from which its [`Derivatives`] and its texture
    /// coordinates are computed (`Bvh::derivatives`, `Bvh::texture_coordinates`): a triangle's
    /// barycentrics `(b1, b2)`; zero on spheres (whose `(φ, cos θ)`, `Sphere::local`, follow from
    /// the normal) and off the scene's surfaces.
    pub local: [f64; 2],
    /// Index of the primitive in the scene.
    pub primitive: u32,
}

/// The differential geometry of a surface point: `dpdu`, `dpdv` the derivatives of the position
/// and `dndu`, `dndv` those of the *unit* shading normal — for a triangle with vertex normals, of
/// the normalised interpolated normal (zero for flat shading; a point sampled on a light gets
/// its triangle's, though it carries the geometric normal). All zero for points off the scene's
/// surfaces (lens, point lights).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Derivatives {
    /// `∂p/∂u`.
    pub dpdu: DVec3,
    /// `∂p/∂v`.
    pub dpdv: DVec3,
    /// `∂n_s/∂u`.
    pub dndu: DVec3,
    /// `∂n_s/∂v`.
    pub dndv: DVec3,
}

impl SurfacePoint {
    /// A point with flat geometry and no parameterisation: position `p`, normal `n` for both
    /// normals (camera lens points, point lights).
    pub fn flat(p: DVec3, n: DVec3, primitive: u32) -> Self {
        Self {
            p,
            n,
            ns: n,
            tangent: crate::math::Frame::from_normal(n).s,
            local: [0.0; 2],
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A surface point takes 120 bytes, within the 128 that baseline x86-64 code copies inline:
    /// at 136 (texture coordinates carried in f64) every move of one (a walk's hit into its
    /// vertex, a hit returned, a vertex copied) was a call to `memcpy` (docs/performance.md,
    /// *Small copies and calls*).
    #[test]
    fn surface_points_are_120_bytes() {
        assert_eq!(std::mem::size_of::<SurfacePoint>(), 120);
    }
}
