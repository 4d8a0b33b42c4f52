//! The specular constraint of one vertex and its Jacobian blocks (Jakob & Marschner 2012, §3.3,
//! eq. 6–7 and 11).
//!
//! At vertex `x_i` with neighbours `x_{i−1}`, `x_{i+1}`: `w_i`, `w_o` are the unit directions
//! toward them, `H = w_i + η w_o` the generalised half vector (`η = η_o/η_i`), `h = H/|H|`, and
//!
//! `c_i = (s₁(x_i) · h − o₁, s₂(x_i) · h − o₂)`,
//!
//! where `s_k(x) = a_k − (a_k · n_s(x)) n_s(x)` projects the shading basis `a_k` of the linearisation
//! point onto the tangent plane of the shading normal at `x`; at the linearisation point
//! `s_k = a_k`. The derivatives, for a displacement `δ` of one vertex in its tangent frame:
//!
//! * `∂w/∂x_neighbour · δ = (δ − w (w · δ)) / ℓ` and `∂w/∂x_i · δ = −(δ − w (w · δ)) / ℓ`;
//! * `∂h = (∂H − h (h · ∂H)) / |H|`;
//! * `∂c_k/∂x_i · δ = s_k · ∂h + ∂s_k · h` with the frame's own motion
//!   `∂s₁ = −(s₁ · ∂n_s) n_s + ω s₂`, `∂s₂ = −(s₂ · ∂n_s) n_s − ω s₁`: it tilts with the normal
//!   (`∂n_s = δ_a ∂n_s/∂e₁ + δ_b ∂n_s/∂e₂`) and turns within its plane at the rate `ω` of
//!   [`ChainVertex::frame_turn`]; the neighbours enter through `∂h` only.
//!
//! Index-matched refractions use `H` unnormalised (see [`ChainVertex::normalized`]).
//!
//! The constraint the walk solves is [`constraint`], with each vertex's own shading basis; the
//! blocks are its exact derivatives. The in-plane turn `ω` multiplies `s₂ · h` and `s₁ · h`, which
//! vanish on ideal specular manifolds (`o = 0`, where any frame gives the same manifold and tangent
//! map) and matter on offset manifolds (§5.2). [`constraint_in`] holds a given basis fixed
//! instead (the frame of a linearisation point, projected): its derivatives lack the `ω` terms.

use super::chain::ChainVertex;
use super::{Mat2, Vec2};
use crate::math::DVec3;

/// The 2×2 blocks of the Jacobian row of one constraint: derivatives with respect to the previous
/// vertex (`lower`), the vertex itself (`diagonal`) and the next one (`upper`), each in the
/// corresponding vertex's tangent frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blocks {
    /// `∂c_i/∂x_{i−1}`.
    pub lower: Mat2,
    /// `∂c_i/∂x_i`.
    pub diagonal: Mat2,
    /// `∂c_i/∂x_{i+1}`.
    pub upper: Mat2,
}

/// The half vector `h` (or `H` at index-matched refractions) of `v` between `prev` and `next`.
fn half(prev: DVec3, v: &ChainVertex, next: DVec3) -> Option<(DVec3, f64, DVec3, f64, DVec3, f64)> {
    let (di, dout) = (prev - v.p(), next - v.p());
    let (li, lo) = (di.length(), dout.length());
    if !(li > 0.0 && lo > 0.0) {
        return None;
    }
    let (wi, wo) = (di / li, dout / lo);
    let eta = v.relative_eta(wi);
    let big_h = wi + wo * eta;
    let len = if v.normalized() { big_h.length() } else { 1.0 };
    if !(len > 0.0) || !len.is_finite() {
        return None;
    }
    Some((wi, li, wo, lo, big_h / len, eta))
}

/// The constraint value `c_i` of vertex `v` between the positions `prev` and `next`, in `v`'s
/// shading basis. `None` when a direction or the half vector is undefined.
pub fn constraint(prev: DVec3, v: &ChainVertex, next: DVec3) -> Option<Vec2> {
    constraint_in(prev, v, next, v.shading_basis())
}

/// The constraint with the frame `s_k = a_k − (a_k · n_s) n_s` built from a given basis
/// `(a₁, a₂)` (that of a linearisation point): the function [`jacobian_blocks`] differentiates.
pub fn constraint_in(
    prev: DVec3,
    v: &ChainVertex,
    next: DVec3,
    (a1, a2): (DVec3, DVec3),
) -> Option<Vec2> {
    let (_, _, _, _, h, _) = half(prev, v, next)?;
    let ns = v.point.ns;
    let (s1, s2) = (a1 - ns * a1.dot(ns), a2 - ns * a2.dot(ns));
    Some(Vec2::new(s1.dot(h) - v.offset[0], s2.dot(h) - v.offset[1]))
}

/// The Jacobian blocks of `v`'s constraint. The previous and next vertices are displaced in the
/// bases `prev_basis` and `next_basis` (their geometric tangent frames, or a walk's endpoint
/// plane); `v` in its own geometric tangent frame.
pub fn jacobian_blocks(
    prev: DVec3,
    prev_basis: (DVec3, DVec3),
    v: &ChainVertex,
    next: DVec3,
    next_basis: (DVec3, DVec3),
) -> Option<Blocks> {
    let (wi, li, wo, lo, h, eta) = half(prev, v, next)?;
    let normalized = v.normalized();
    let big_len = if normalized {
        (wi + wo * eta).length()
    } else {
        1.0
    };
    let (s1, s2) = v.shading_basis();
    let ns = v.point.ns;
    // The change of h for changes dwi, dwo of the two directions.
    let dh = |dwi: DVec3, dwo: DVec3| {
        let d = dwi + dwo * eta;
        if normalized {
            (d - h * h.dot(d)) / big_len
        } else {
            d
        }
    };
    let tangent = |w: DVec3, l: f64, e: DVec3| (e - w * w.dot(e)) / l;
    // dc_k = s_k · dh + ds_k · h, the frame tilting with the normal by dn and turning in its
    // plane by ω (zero for the neighbours, whose frames do not enter).
    let row = |d: DVec3, dn: DVec3, omega: f64| {
        let tilt = ns.dot(h);
        (
            s1.dot(d) - s1.dot(dn) * tilt + omega * s2.dot(h),
            s2.dot(d) - s2.dot(dn) * tilt - omega * s1.dot(h),
        )
    };
    let block = |c1: (f64, f64), c2: (f64, f64)| Mat2::new(c1.0, c2.0, c1.1, c2.1);
    let lower = {
        let (e1, e2) = prev_basis;
        let c1 = row(dh(tangent(wi, li, e1), DVec3::ZERO), DVec3::ZERO, 0.0);
        let c2 = row(dh(tangent(wi, li, e2), DVec3::ZERO), DVec3::ZERO, 0.0);
        block(c1, c2)
    };
    let upper = {
        let (e1, e2) = next_basis;
        let c1 = row(dh(DVec3::ZERO, tangent(wo, lo, e1)), DVec3::ZERO, 0.0);
        let c2 = row(dh(DVec3::ZERO, tangent(wo, lo, e2)), DVec3::ZERO, 0.0);
        block(c1, c2)
    };
    let diagonal = {
        let (e1, e2) = v.tangent_basis();
        let (dn1, dn2) = v.normal_derivatives(e1, e2);
        let c1 = row(
            dh(-tangent(wi, li, e1), -tangent(wo, lo, e1)),
            dn1,
            v.frame_turn(dn1),
        );
        let c2 = row(
            dh(-tangent(wi, li, e2), -tangent(wo, lo, e2)),
            dn2,
            v.frame_turn(dn2),
        );
        block(c1, c2)
    };
    Some(Blocks {
        lower,
        diagonal,
        upper,
    })
}
