//! Specular manifolds (Jakob & Marschner 2012, "Manifold exploration", §3.3 and §4): the
//! constraint that makes a chain of vertices specular, its block-tridiagonal Jacobian, the
//! generalised geometry term through a specular chain, and the manifold walk that moves one
//! endpoint of a chain while keeping it specular.
//!
//! * [`chain`] — a chain's vertices as the manifold sees them (differential geometry, reflection or
//!   refraction with its relative index, the glossy offset `o` of eq. 11) and the scattering
//!   direction that a given half vector prescribes;
//! * [`constraint`](mod@constraint) — the constraint `c_i` of eq. 6–7 and its Jacobian blocks;
//! * [`tridiagonal`] — the O(n) block-tridiagonal solve (2×2 blocks), with a dense fallback;
//! * [`geometry_term`] — the tangent map `−A⁻¹B` and the generalised geometry term (eq. 9);
//! * [`walk`] — the predictor–corrector walk of §4 and its statistics;
//! * [`specular_probability`] — the chance `ψ` that a glossy vertex joins a specular chain;
//! * [`vmf`] — the von Mises–Fisher distribution of the manifold perturbation's directions;
//! * [`probe`] — synthetic walks on a scene, for measuring success, iterations, reversibility.

pub mod chain;
pub mod constraint;
pub mod geometry_term;
pub mod probe;
pub mod specular_probability;
pub mod tridiagonal;
pub mod vmf;
pub mod walk;

pub use chain::{ChainVertex, Interaction, scatter};
pub use constraint::{Blocks, constraint, constraint_in, jacobian_blocks};
pub use geometry_term::{
    ChainJacobian, chain_jacobian, chain_jacobian_into, generalized_geometry,
    generalized_geometry_reverse, ordinary_geometry, tangent_map,
};
pub use specular_probability::SpecularProbability;
pub use tridiagonal::BlockTridiagonal;
pub use vmf::VonMisesFisher;
pub use walk::{
    ManifoldSettings, NO_MATERIAL, WalkFailure, WalkStats, Walked, endpoint_plane, trace_chain,
    walk_manifold, walk_manifold_into, walk_reversibly, walk_reversibly_into,
};

/// Vertices of a chain kept inline, endpoints included: a manifold walk or a Jacobian of a chain of
/// up to `CHAIN_INLINE − 2` specular vertices allocates nothing (a perturbation proposes many, and
/// chains of one or two specular vertices are the rule; a longer inline list costs every chain
/// its copies when it moves: six vertices copied 2.5% more of MEMLT's instructions on `pool`).
pub const CHAIN_INLINE: usize = 4;

/// A chain's vertices (up to [`CHAIN_INLINE`] inline).
pub type Chain = smallvec::SmallVec<[ChainVertex; CHAIN_INLINE]>;

/// One entry per vertex of a chain (Jacobian blocks, right-hand sides, steps), inline as
/// [`Chain`] is.
pub type PerVertex<T> = smallvec::SmallVec<[T; CHAIN_INLINE]>;

/// 2×2 blocks of the constraint Jacobian.
pub type Mat2 = nalgebra::Matrix2<f64>;
/// 2-vectors: a vertex's displacement in its tangent frame, or a constraint value.
pub type Vec2 = nalgebra::Vector2<f64>;
