//! The tangent space of a specular chain and its generalised geometry term (Jakob & Marschner
//! 2012, §3.3, eq. 9): for a chain `x_0, x_1 … x_m, x_{m+1}` with specular `x_1 … x_m`, the
//! derivative of the specular vertices with respect to an endpoint is `−A⁻¹ B`, `A` the
//! block-tridiagonal Jacobian of the constraints with respect to the specular vertices and `B` the
//! column of the endpoint. In orthonormal tangent frames the determinant of the block
//! `∂x_1/∂x_{m+1}` is the ratio of an area at `x_1` to the area at `x_{m+1}` it maps to, and
//!
//! `G(x_0 ↔ … ↔ x_{m+1}) = |det ∂x_1/∂x_{m+1}| G(x_0 ↔ x_1) = |det ∂x_m/∂x_0| G(x_m ↔ x_{m+1})`.

use super::chain::ChainVertex;
use super::constraint::jacobian_blocks;
use super::tridiagonal::BlockTridiagonal;
use super::{Mat2, PerVertex, Vec2};
use crate::math::DVec3;

/// The constraint Jacobian of a chain: `a` over its specular vertices, and the blocks of its
/// first and last vertex (`∂c_1/∂x_0`, `∂c_m/∂x_{m+1}`).
#[derive(Clone, Debug)]
pub struct ChainJacobian {
    /// `A`.
    pub a: BlockTridiagonal,
    /// `∂c_1/∂x_0` in the first vertex's basis.
    pub first: Mat2,
    /// `∂c_m/∂x_{m+1}` in the last vertex's basis.
    pub last: Mat2,
}

impl Default for ChainJacobian {
    /// No blocks (storage for [`chain_jacobian_into`]).
    fn default() -> Self {
        Self {
            a: BlockTridiagonal::default(),
            first: Mat2::zeros(),
            last: Mat2::zeros(),
        }
    }
}

/// The Jacobian of `chain` (`x_0 … x_{m+1}`, `m ≥ 1`), the endpoints displaced in the bases
/// `first_basis` and `last_basis` and every specular vertex in its own tangent frame.
pub fn chain_jacobian(
    chain: &[ChainVertex],
    first_basis: (DVec3, DVec3),
    last_basis: (DVec3, DVec3),
) -> Option<ChainJacobian> {
    let mut j = ChainJacobian::default();
    chain_jacobian_into(chain, first_basis, last_basis, &mut j).then_some(j)
}

/// [`chain_jacobian`] into `j`, whose storage it reuses (a walk computes one per iteration, and
/// moving each out of the call copied its blocks): `false`, `j` then undefined, where it has none.
pub fn chain_jacobian_into(
    chain: &[ChainVertex],
    first_basis: (DVec3, DVec3),
    last_basis: (DVec3, DVec3),
    j: &mut ChainJacobian,
) -> bool {
    let Some(m) = chain.len().checked_sub(2).filter(|&m| m >= 1) else {
        return false;
    };
    let a = &mut j.a;
    a.lower.clear();
    a.diagonal.clear();
    a.upper.clear();
    for i in 1..=m {
        let prev_basis = if i == 1 {
            first_basis
        } else {
            chain[i - 1].tangent_basis()
        };
        let next_basis = if i == m {
            last_basis
        } else {
            chain[i + 1].tangent_basis()
        };
        let Some(b) = jacobian_blocks(
            chain[i - 1].p(),
            prev_basis,
            &chain[i],
            chain[i + 1].p(),
            next_basis,
        ) else {
            return false;
        };
        if i == 1 {
            j.first = b.lower;
        }
        if i == m {
            j.last = b.upper;
        }
        a.lower.push(b.lower);
        a.diagonal.push(b.diagonal);
        a.upper.push(b.upper);
    }
    true
}

/// The tangent map of a chain: `(∂x_1/∂x_{m+1}, ∂x_m/∂x_0)`, each vertex in its geometric tangent
/// frame. `None` when the chain has no specular vertex or `A` is singular.
pub fn tangent_map(chain: &[ChainVertex]) -> Option<(Mat2, Mat2)> {
    let n = chain.len();
    let mut j = ChainJacobian::default();
    if !chain_jacobian_into(
        chain,
        chain[0].tangent_basis(),
        chain[n - 1].tangent_basis(),
        &mut j,
    ) {
        return None;
    }
    let m = j.a.len();
    // Columns 0–1: the last endpoint's column of −B; columns 2–3: the first endpoint's.
    let mut rhs: PerVertex<_> = smallvec::smallvec![nalgebra::SMatrix::<f64, 2, 4>::zeros(); m];
    rhs[m - 1]
        .fixed_view_mut::<2, 2>(0, 0)
        .copy_from(&(-j.last));
    rhs[0].fixed_view_mut::<2, 2>(0, 2).copy_from(&(-j.first));
    let x = j.a.solve::<4>(&rhs)?;
    Some((
        x[0].fixed_view::<2, 2>(0, 0).into_owned(),
        x[m - 1].fixed_view::<2, 2>(0, 2).into_owned(),
    ))
}

/// The ordinary geometry term seen from `near`, whose `|cos|` toward `far` is `cos_near`:
/// `cos_near |n_far · w| / |far − near|²` (`w` the unit direction from `near` to `far`,
/// `n_far` the geometric normal there); `None` for coincident points. The first factor of
/// [`generalized_geometry`], and all of it for a chain without specular vertices: path-space
/// code with two plain vertices calls it without building chain vertices.
#[inline]
pub fn ordinary_geometry(near: DVec3, cos_near: f64, far: DVec3, n_far: DVec3) -> Option<f64> {
    let d = far - near;
    let d2 = d.length_squared();
    if !(d2 > 0.0) {
        return None;
    }
    let w = d / d2.sqrt();
    Some(cos_near * n_far.dot(w).abs() / d2)
}

/// The generalised geometry term `G(x_0 ↔ … ↔ x_{m+1})` of eq. 9 from the first vertex's side:
/// `|det ∂x_1/∂x_{m+1}| |cos θ_0| |cos θ_1| / |x_1 − x_0|²`, where `cos_first` is `|cos θ_0|`
/// (1 for a point without a surface). The ordinary geometry term when the chain has no specular
/// vertex. 0 when the chain is singular (a caustic: the term is infinite there).
pub fn generalized_geometry(chain: &[ChainVertex], cos_first: f64) -> f64 {
    let Some(g) = ordinary_geometry(chain[0].p(), cos_first, chain[1].p(), chain[1].point.n) else {
        return 0.0;
    };
    if chain.len() == 2 {
        return g;
    }
    match tangent_map(chain) {
        Some((t, _)) => g * t.determinant().abs(),
        None => 0.0,
    }
}

/// The same term from the last vertex's side (`|det ∂x_m/∂x_0| G(x_m ↔ x_{m+1})`, with `cos_last`
/// the cosine at `x_{m+1}` and `x_0` on a surface): equal to [`generalized_geometry`] — the
/// symmetry the tests check.
pub fn generalized_geometry_reverse(chain: &[ChainVertex], cos_last: f64) -> f64 {
    let n = chain.len();
    let Some(g) = ordinary_geometry(
        chain[n - 1].p(),
        cos_last,
        chain[n - 2].p(),
        chain[n - 2].point.n,
    ) else {
        return 0.0;
    };
    if n == 2 {
        return g;
    }
    match tangent_map(chain) {
        Some((_, t)) => g * t.determinant().abs(),
        None => 0.0,
    }
}

/// The displacement of an endpoint in a basis: its coordinates `(e₁ · d, e₂ · d)`.
pub fn coordinates(d: DVec3, (e1, e2): (DVec3, DVec3)) -> Vec2 {
    Vec2::new(e1.dot(d), e2.dot(d))
}
