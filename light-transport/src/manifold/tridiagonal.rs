//! Block-tridiagonal linear systems with 2×2 blocks: the Jacobian of a specular chain with respect
//! to its specular vertices (Jakob & Marschner 2012, §3.3 and §4: "a block tridiagonal LU
//! factorization ... reduces the time complexity from O(n³) to O(n)").
//!
//! Block elimination without pivoting (the block Thomas algorithm) can meet a singular leading
//! block in a non-singular matrix; then the system is solved again densely with full pivoting
//! (nalgebra), so that only a singular matrix fails.

use super::{Mat2, PerVertex, Vec2};
use nalgebra::DMatrix;

/// `A` with `diagonal[i]` at block `(i, i)`, `lower[i]` at `(i, i−1)` (`lower[0]` unused) and
/// `upper[i]` at `(i, i+1)` (the last unused).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BlockTridiagonal {
    /// Sub-diagonal blocks.
    pub lower: PerVertex<Mat2>,
    /// Diagonal blocks.
    pub diagonal: PerVertex<Mat2>,
    /// Super-diagonal blocks.
    pub upper: PerVertex<Mat2>,
}

/// Relative size below which a pivot block counts as singular.
const SINGULAR: f64 = 1e-12;

impl BlockTridiagonal {
    /// Number of block rows.
    pub fn len(&self) -> usize {
        self.diagonal.len()
    }

    /// Whether the system is empty.
    pub fn is_empty(&self) -> bool {
        self.diagonal.is_empty()
    }

    /// Solve `A X = R` for `R` with `2 × k` blocks per row (one column block per right-hand side
    /// pair); `None` when `A` is singular.
    pub fn solve<const K: usize>(
        &self,
        rhs: &[nalgebra::SMatrix<f64, 2, K>],
    ) -> Option<PerVertex<nalgebra::SMatrix<f64, 2, K>>> {
        self.solve_blocks(rhs).or_else(|| self.solve_dense(rhs))
    }

    /// Solve for one right-hand side vector per block row.
    pub fn solve_vec(&self, rhs: &[Vec2]) -> Option<PerVertex<Vec2>> {
        self.solve::<1>(rhs)
    }

    fn scale(&self) -> f64 {
        self.diagonal
            .iter()
            .chain(&self.lower)
            .chain(&self.upper)
            .map(|m| m.abs().max())
            .fold(0.0, f64::max)
    }

    fn solve_blocks<const K: usize>(
        &self,
        rhs: &[nalgebra::SMatrix<f64, 2, K>],
    ) -> Option<PerVertex<nalgebra::SMatrix<f64, 2, K>>> {
        let n = self.len();
        if n == 0 || rhs.len() != n {
            return None;
        }
        let tiny = SINGULAR * self.scale().powi(2);
        let invert = |m: &Mat2| {
            let det = m.determinant();
            (det.abs() > tiny && det.is_finite())
                .then(|| Mat2::new(m[(1, 1)], -m[(0, 1)], -m[(1, 0)], m[(0, 0)]) / det)
        };
        // Forward elimination: D'_i = D_i − L_i D'_{i−1}⁻¹ U_{i−1}, R'_i likewise.
        let mut inv = PerVertex::<Mat2>::new();
        let mut r = PerVertex::from_slice(rhs);
        let mut d = self.diagonal[0];
        for i in 0..n {
            if i > 0 {
                let f = self.lower[i] * inv[i - 1];
                d = self.diagonal[i] - f * self.upper[i - 1];
                let prev = r[i - 1];
                r[i] -= f * prev;
            }
            inv.push(invert(&d)?);
        }
        // Back substitution.
        let mut x = r.clone();
        x[n - 1] = inv[n - 1] * r[n - 1];
        for i in (0..n - 1).rev() {
            let next = x[i + 1];
            x[i] = inv[i] * (r[i] - self.upper[i] * next);
        }
        x.iter()
            .all(|b| b.iter().all(|v| v.is_finite()))
            .then_some(x)
    }

    fn solve_dense<const K: usize>(
        &self,
        rhs: &[nalgebra::SMatrix<f64, 2, K>],
    ) -> Option<PerVertex<nalgebra::SMatrix<f64, 2, K>>> {
        let n = self.len();
        if n == 0 || rhs.len() != n {
            return None;
        }
        let a = self.to_dense();
        let mut b = DMatrix::<f64>::zeros(2 * n, K);
        for (i, r) in rhs.iter().enumerate() {
            b.fixed_view_mut::<2, K>(2 * i, 0).copy_from(r);
        }
        let lu = a.full_piv_lu();
        // Full pivoting puts the pivots in decreasing order: the last over the first measures
        // the distance to singularity.
        let u = lu.u();
        let (first, last) = (u[(0, 0)].abs(), u[(2 * n - 1, 2 * n - 1)].abs());
        if !(last > SINGULAR * first) || !first.is_finite() {
            return None;
        }
        let x = lu.solve(&b)?;
        let out: PerVertex<_> = (0..n)
            .map(|i| x.fixed_view::<2, K>(2 * i, 0).into_owned())
            .collect();
        out.iter()
            .all(|b| b.iter().all(|v| v.is_finite()))
            .then_some(out)
    }

    /// The dense matrix (for tests).
    pub fn to_dense(&self) -> DMatrix<f64> {
        let n = self.len();
        let mut a = DMatrix::<f64>::zeros(2 * n, 2 * n);
        for i in 0..n {
            a.fixed_view_mut::<2, 2>(2 * i, 2 * i)
                .copy_from(&self.diagonal[i]);
            if i > 0 {
                a.fixed_view_mut::<2, 2>(2 * i, 2 * i - 2)
                    .copy_from(&self.lower[i]);
            }
            if i + 1 < n {
                a.fixed_view_mut::<2, 2>(2 * i, 2 * i + 2)
                    .copy_from(&self.upper[i]);
            }
        }
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mcmc_core::rng::{stream, uniform};

    fn random(n: usize, seed: u64) -> BlockTridiagonal {
        let mut rng = stream(seed, 0);
        let mut m = || Mat2::from_fn(|_, _| uniform(&mut rng) * 2.0 - 1.0);
        BlockTridiagonal {
            lower: (0..n).map(|_| m()).collect(),
            diagonal: (0..n).map(|_| m() + Mat2::identity() * 3.0).collect(),
            upper: (0..n).map(|_| m()).collect(),
        }
    }

    #[test]
    fn block_solve_matches_dense_lu() {
        for n in [1, 2, 5, 20] {
            let a = random(n, n as u64);
            let rhs: Vec<Vec2> = (0..n)
                .map(|i| Vec2::new(i as f64, 1.0 - i as f64))
                .collect();
            let x = a.solve_vec(&rhs).unwrap();
            let dense = a.to_dense();
            let mut xv = nalgebra::DVector::zeros(2 * n);
            for i in 0..n {
                xv[2 * i] = x[i][0];
                xv[2 * i + 1] = x[i][1];
            }
            let r = dense * xv;
            for i in 0..n {
                assert!((r[2 * i] - rhs[i][0]).abs() < 1e-12);
                assert!((r[2 * i + 1] - rhs[i][1]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn a_singular_leading_block_falls_back_to_pivoting() {
        // [[0 I], [I 0]] has a singular first block but is a permutation.
        let z = Mat2::zeros();
        let a = BlockTridiagonal {
            lower: smallvec::smallvec![z, Mat2::identity()],
            diagonal: smallvec::smallvec![z, z],
            upper: smallvec::smallvec![Mat2::identity(), z],
        };
        let x = a
            .solve_vec(&[Vec2::new(1.0, 2.0), Vec2::new(3.0, 4.0)])
            .unwrap();
        assert_eq!(x[..], [Vec2::new(3.0, 4.0), Vec2::new(1.0, 2.0)]);
        // A truly singular matrix fails.
        let s = BlockTridiagonal {
            lower: smallvec::smallvec![z],
            diagonal: smallvec::smallvec![Mat2::new(1.0, 2.0, 2.0, 4.0)],
            upper: smallvec::smallvec![z],
        };
        assert!(s.solve_vec(&[Vec2::new(1.0, 0.0)]).is_none());
    }
}
