//! The vertices of a specular chain as the manifold sees them (Jakob & Marschner 2012, §3.3, §5.2).
//!
//! Every vertex is parameterised locally by an orthonormal basis `(e₁, e₂)` of its geometric
//! tangent plane, so that determinants of the tangent map are ratios of areas (the footnote to
//! eq. 9). Moving a vertex by `a e₁ + b e₂` moves its shading normal by `a ∂n_s/∂e₁ + b ∂n_s/∂e₂`,
//! obtained from the surface's `∂n_s/∂u, ∂n_s/∂v` through its `∂p/∂u, ∂p/∂v`.

use crate::geometry::{Derivatives, SurfacePoint};
use crate::math::{DVec3, Frame};
use crate::scene::Scene;

/// The fixed direction whose projection onto the shading tangent plane is the first axis of
/// every chain vertex's shading basis ([`ChainVertex::shading_basis`]); unit, chosen off the
/// coordinate axes and diagonals so that no axis-aligned surface has a normal along it.
pub const FRAME_REFERENCE: DVec3 = DVec3::new(
    0.267_261_241_912_424_4,
    0.534_522_483_824_848_8,
    0.801_783_725_737_273_2,
);

/// How light leaves a specular vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Interaction {
    /// Reflection.
    Reflect,
    /// Refraction through an interface of index `eta` (inside over outside; the geometric normal
    /// points outside).
    Refract {
        /// Index of refraction, inside over outside.
        eta: f64,
    },
}

/// A vertex of a chain: its surface point, the material it belongs to (a walk that lands on
/// another material has changed the path's configuration), how it scatters, and its offset `o`
/// (the microfacet normal projected into the shading tangent frame; zero for ideal specular
/// vertices, eq. 11).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChainVertex {
    /// Position and normals.
    pub point: SurfacePoint,
    /// The point's differential geometry ([`ChainVertex::new`] computes it; a vertex built by
    /// hand must bring its own, and a vertex whose point moves needs the new point's).
    pub derivatives: Derivatives,
    /// Material index (`u32::MAX` for endpoints that are not on a scene surface).
    pub material: u32,
    /// Reflection or refraction (ignored at the chain's endpoints).
    pub interaction: Interaction,
    /// Offset `o` of the offset manifold.
    pub offset: [f64; 2],
}

impl ChainVertex {
    /// The vertex at `point`, a point of `scene` (or off its surfaces: lens, point lights), with
    /// its differential geometry.
    pub fn new(
        scene: &Scene,
        point: SurfacePoint,
        material: u32,
        interaction: Interaction,
        offset: [f64; 2],
    ) -> Self {
        Self {
            derivatives: scene.bvh.derivatives(&point),
            point,
            material,
            interaction,
            offset,
        }
    }

    /// Position.
    #[inline]
    pub fn p(&self) -> DVec3 {
        self.point.p
    }

    /// An orthonormal basis `(e₁, e₂)` of the geometric tangent plane (along `∂p/∂u` where there
    /// is one).
    pub fn tangent_basis(&self) -> (DVec3, DVec3) {
        let f = Frame::from_normal_tangent(self.point.n, self.derivatives.dpdu);
        (f.s, f.t)
    }

    /// `∂n_s/∂e₁` and `∂n_s/∂e₂` for the basis of [`ChainVertex::tangent_basis`]: the direction
    /// `e` is written as `du ∂p/∂u + dv ∂p/∂v` (least squares; exact for tangent directions) and
    /// the normal's derivative is `du ∂n_s/∂u + dv ∂n_s/∂v`. Zero without a parameterisation.
    pub fn normal_derivatives(&self, e1: DVec3, e2: DVec3) -> (DVec3, DVec3) {
        let pt = &self.derivatives;
        let (a, b, c) = (
            pt.dpdu.dot(pt.dpdu),
            pt.dpdu.dot(pt.dpdv),
            pt.dpdv.dot(pt.dpdv),
        );
        let det = a * c - b * b;
        if !(det > 1e-30 * (a * c).max(1e-300)) || !det.is_finite() {
            return (DVec3::ZERO, DVec3::ZERO);
        }
        let along = |e: DVec3| {
            let (ru, rv) = (pt.dpdu.dot(e), pt.dpdv.dot(e));
            let du = (c * ru - b * rv) / det;
            let dv = (a * rv - b * ru) / det;
            pt.dndu * du + pt.dndv * dv
        };
        (along(e1), along(e2))
    }

    /// An orthonormal basis `(s₁, s₂)` of the shading tangent plane (perpendicular to `n_s`): the
    /// constraint's frame `T(x)` of eq. 6, in which a glossy vertex's offset `o` is written.
    ///
    /// It is a function of the shading normal alone — `s₁` the projection of the fixed direction
    /// [`FRAME_REFERENCE`] onto the shading tangent plane, `s₂ = n_s × s₁` — so that it turns
    /// with the point in a way the Jacobian knows exactly ([`ChainVertex::frame_turn`]) on any
    /// surface, and does not jump between the triangles of a mesh (a frame built from `∂p/∂u`
    /// would do both). Singular only where `n_s` is parallel to the reference.
    pub fn shading_basis(&self) -> (DVec3, DVec3) {
        let f = Frame::from_normal_tangent(self.point.ns, FRAME_REFERENCE);
        (f.s, f.t)
    }

    /// The rate at which the shading basis turns within its own plane when the shading normal
    /// changes by `dn`: `ω = ∂s₁ · s₂`, so that `∂s₁ = −(s₁ · dn) n_s + ω s₂` and
    /// `∂s₂ = −(s₂ · dn) n_s − ω s₁`. With `u = r − (r · n_s) n_s` (`r` the reference),
    /// `s₁ = u/|u|` and `ω = −(r · n_s)(dn · s₂)/|u|`. Only offset manifolds (`o ≠ 0`) feel it.
    pub fn frame_turn(&self, dn: DVec3) -> f64 {
        let ns = self.point.ns;
        let r = FRAME_REFERENCE;
        let u = r - ns * r.dot(ns);
        let len = u.length();
        if !(len > 1e-10) {
            return 0.0;
        }
        let (_, s2) = self.shading_basis();
        -r.dot(ns) * dn.dot(s2) / len
    }

    /// The relative index `η = η_o/η_i` for light arriving from direction `wi` (pointing away
    /// from the vertex) and leaving on the other side: the generalised half vector is
    /// `wi + η wo`. 1 for reflection.
    pub fn relative_eta(&self, wi: DVec3) -> f64 {
        match self.interaction {
            Interaction::Reflect => 1.0,
            Interaction::Refract { eta } => {
                if wi.dot(self.point.n) > 0.0 {
                    eta
                } else {
                    1.0 / eta
                }
            }
        }
    }

    /// Whether the half vector is normalised in the constraint: always except at index-matched
    /// refractions (`η = 1`), where `wi + wo` vanishes on the manifold and the unnormalised
    /// vector is the constraint.
    pub fn normalized(&self) -> bool {
        match self.interaction {
            Interaction::Reflect => true,
            Interaction::Refract { eta } => (eta - 1.0).abs() > 1e-9,
        }
    }

    /// The unit half vector this vertex prescribes for light arriving from `wi`: its offset `o`
    /// in the shading basis, completed to a unit vector on the side that `wi + η wo` takes (`wi`'s
    /// side for reflection; for refraction the denser side).
    pub fn half_vector(&self, wi: DVec3) -> Option<DVec3> {
        let (s1, s2) = self.shading_basis();
        let [o1, o2] = self.offset;
        let z2 = 1.0 - o1 * o1 - o2 * o2;
        if !(z2 > 0.0) {
            return None;
        }
        let ns = self.point.ns;
        let wi_side = wi.dot(ns).signum();
        let sign = match self.interaction {
            Interaction::Reflect => wi_side,
            Interaction::Refract { .. } => {
                let eta = self.relative_eta(wi);
                if eta > 1.0 { -wi_side } else { wi_side }
            }
        };
        Some(s1 * o1 + s2 * o2 + ns * (sign * z2.sqrt()))
    }
}

/// The direction `wo` leaving a vertex for light arriving from `wi` (unit, pointing away from the
/// vertex) such that `wi + η wo` is parallel to the unit half vector `h`: reflection when `refract`
/// is false (`wo` on `wi`'s side of the geometric normal `ng`), refraction otherwise (the other
/// side). Solves `|α h − wi| = η` for `α` and keeps the root on the wanted side. `None` at total
/// internal reflection or when no root lies on the wanted side.
pub fn scatter(wi: DVec3, h: DVec3, eta: f64, refract: bool, ng: DVec3) -> Option<DVec3> {
    if refract && (eta - 1.0).abs() <= 1e-9 {
        return Some(-wi); // index-matched: straight through
    }
    let c = h.dot(wi);
    let disc = c * c - 1.0 + eta * eta;
    if disc < 0.0 {
        return None; // total internal reflection
    }
    let r = disc.sqrt();
    let wanted = |wo: DVec3| {
        let (a, b) = (wi.dot(ng), wo.dot(ng));
        if refract { a * b < 0.0 } else { a * b > 0.0 }
    };
    [c + r, c - r]
        .into_iter()
        .map(|alpha| (h * alpha - wi) / eta)
        .filter(|wo| wo.length_squared() > 0.5)
        .find(|&wo| wanted(wo))
        .map(|wo| wo.normalize())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scatter_reflects_and_refracts_by_snell() {
        let n = DVec3::Y;
        let wi = DVec3::new(0.6, 0.8, 0.0);
        let r = scatter(wi, n, 1.0, false, n).unwrap();
        assert!((r - DVec3::new(-0.6, 0.8, 0.0)).length() < 1e-15);
        // Entering glass of index 1.5: sin θ_t = 0.6 / 1.5; h points into the glass.
        let t = scatter(wi, -n, 1.5, true, n).unwrap();
        assert!((t.x + 0.4).abs() < 1e-15 && t.y < 0.0);
        // Leaving it beyond the critical angle: total internal reflection.
        let inside = DVec3::new(0.8, -0.6, 0.0);
        assert!(scatter(inside, -n, 1.0 / 1.5, true, n).is_none());
    }
}
