//! Rays, primitives and their intersections, in f64.

mod ray;
mod sphere;
mod triangle;

pub use ray::{Ray, offset_origin};
pub use sphere::Sphere;
pub use triangle::Triangle;

use crate::math::DVec3;

/// A point on a surface found by a ray or by sampling.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Position.
    pub p: DVec3,
    /// Unit geometric normal (oriented as the primitive defines it).
    pub n: DVec3,
    /// Texture coordinates.
    pub uv: [f64; 2],
    /// A tangent (for anisotropic BSDFs).
    pub dpdu: DVec3,
    /// Index of the primitive in the scene.
    pub primitive: u32,
}

/// A ray–surface intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter.
    pub t: f64,
    /// The surface point.
    pub point: SurfacePoint,
}
