//! The normal equations of a regression whose rows are weighted per DOF, from one Gram matrix
//! of `[A y]` per DOF: any weighting is then a sum of six small matrices, and the solves, the
//! reweighting and the covariance need no further pass over the rows. For the coupled sets of
//! seed 003 (hundreds of terms, tens of thousands of rows) that pass is most of the cost.

use super::{EstimateError, Regression};
use crate::core::dof::Dof;
use faer::prelude::*;
use nalgebra::DMatrix;
use std::collections::BTreeMap;

/// Terms above which a least-squares solve goes through the normal equations instead of a QR
/// of the whole regressor (a dozen-term diagonal model keeps its QR: it costs nothing there).
pub const NORMAL_ABOVE_TERMS: usize = 40;

pub struct Normal {
    p: usize,
    /// Per DOF: `[A y]^T [A y]` over its rows, (p+1) x (p+1).
    blocks: BTreeMap<Dof, DMatrix<f64>>,
    pub rows: usize,
}

impl Normal {
    /// The Gram matrices of a problem large enough to want them (see [`NORMAL_ABOVE_TERMS`]).
    pub fn for_problem(problem: &Regression) -> Option<Normal> {
        (problem.cols() > NORMAL_ABOVE_TERMS).then(|| Normal::of(problem))
    }

    pub fn of(problem: &Regression) -> Normal {
        let (n, p) = (problem.rows(), problem.cols());
        let mut by_dof: BTreeMap<Dof, Vec<f64>> = BTreeMap::new();
        for i in 0..n {
            let buf = by_dof.entry(problem.row_dof[i]).or_default();
            buf.extend_from_slice(problem.row(i));
            buf.push(problem.y[i]);
        }
        let blocks = by_dof
            .into_iter()
            .map(|(d, buf)| {
                let a = MatRef::from_row_major_slice(&buf, buf.len() / (p + 1), p + 1);
                let g: Mat<f64> = a.transpose() * a;
                (d, DMatrix::from_fn(p + 1, p + 1, |i, j| g[(i, j)]))
            })
            .collect();
        Normal { p, blocks, rows: n }
    }

    /// `[A y]^T W [A y]` with each row weighted by 1 / sigma of its DOF (squared).
    pub fn weighted(&self, sigma: &BTreeMap<Dof, f64>) -> DMatrix<f64> {
        let mut g = DMatrix::zeros(self.p + 1, self.p + 1);
        for (d, b) in &self.blocks {
            let w = 1.0 / sigma.get(d).copied().unwrap_or(1.0);
            g += b * (w * w);
        }
        g
    }

    /// Least squares over the `free` columns (the others held at zero) from the weighted
    /// normal equations, columns equilibrated so that the squared condition number stays far
    /// from the precision limit; Cholesky, or an SVD when the matrix is not positive definite.
    pub fn solve(
        &self,
        sigma: &BTreeMap<Dof, f64>,
        free: &[bool],
    ) -> Result<Vec<f64>, EstimateError> {
        let g = self.weighted(sigma);
        let cols: Vec<usize> = (0..self.p).filter(|&j| free[j]).collect();
        let s: Vec<f64> = cols.iter().map(|&j| g[(j, j)].sqrt().max(1e-300)).collect();
        let k = cols.len();
        let m = DMatrix::from_fn(k, k, |a, b| g[(cols[a], cols[b])] / (s[a] * s[b]));
        let rhs = nalgebra::DVector::from_fn(k, |a, _| g[(cols[a], self.p)] / s[a]);
        let z = match m.clone().cholesky() {
            Some(c) => c.solve(&rhs),
            None => crate::core::numerics::svd(m, true, true)
                .ok_or(EstimateError::Singular)?
                .solve(&rhs, 1e-12)
                .map_err(|_| EstimateError::Singular)?,
        };
        let mut theta = vec![0.0; self.p];
        for (a, &j) in cols.iter().enumerate() {
            theta[j] = z[a] / s[a];
        }
        match theta.iter().all(|v| v.is_finite()) {
            true => Ok(theta),
            false => Err(EstimateError::Singular),
        }
    }
}
