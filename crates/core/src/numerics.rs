//! Decompositions that cannot hang: the input is checked for non-finite entries and every
//! iterative decomposition has an iteration limit. nalgebra's `svd`, `symmetric_eigen` and
//! `complex_eigenvalues` iterate until convergence with no limit, and a NaN or an overflowed
//! entry never converges: a solver fed `1e300` spun at full CPU for as long as it was let.
//! Each function here returns `None` instead, and the caller says what that means.

use nalgebra::{DMatrix, DVector, Dyn, SVD, Schur, SymmetricEigen};

/// Sweeps allowed per decomposition: far beyond what a finite matrix of this tool's sizes
/// (at most a few hundred columns) needs, which is a few dozen.
pub const MAX_ITERATIONS: usize = 100_000;

/// Whether every entry of `m` is finite.
pub fn finite(m: &DMatrix<f64>) -> bool {
    m.iter().all(|x| x.is_finite())
}

/// The singular value decomposition, or `None` when `m` has a non-finite entry or the
/// iteration does not converge.
pub fn svd(m: DMatrix<f64>, u: bool, v: bool) -> Option<SVD<f64, Dyn, Dyn>> {
    if !finite(&m) {
        return None;
    }
    m.try_svd(u, v, f64::EPSILON, MAX_ITERATIONS)
}

/// The eigen-decomposition of the symmetric `m`, or `None` as for [`svd`].
pub fn symmetric_eigen(m: DMatrix<f64>) -> Option<SymmetricEigen<f64, Dyn>> {
    if !finite(&m) {
        return None;
    }
    m.try_symmetric_eigen(f64::EPSILON, MAX_ITERATIONS)
}

/// The (complex) eigenvalues of the square `m`, or `None` as for [`svd`].
pub fn complex_eigenvalues(m: DMatrix<f64>) -> Option<DVector<nalgebra::Complex<f64>>> {
    if !finite(&m) {
        return None;
    }
    Schur::try_new(m, f64::EPSILON, MAX_ITERATIONS).map(|s| s.complex_eigenvalues())
}

/// The minimiser of `f` on [a, b] by golden section, to within `tol` (f taken unimodal there).
pub fn golden_min(mut f: impl FnMut(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (a, b);
    let (mut x1, mut x2) = (b - g * (b - a), a + g * (b - a));
    let (mut f1, mut f2) = (f(x1), f(x2));
    while b - a > tol {
        if f1 < f2 {
            (b, x2, f2) = (x2, x1, f1);
            x1 = b - g * (b - a);
            f1 = f(x1);
        } else {
            (a, x1, f1) = (x1, x2, f2);
            x2 = a + g * (b - a);
            f2 = f(x2);
        }
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_section_finds_the_minimiser_to_its_tolerance() {
        let x = golden_min(
            |x| (x - 1.3).powi(2) + (3.0 * x).sin() * 0.01,
            0.0,
            3.0,
            1e-9,
        );
        // d/dx: 2 (x - 1.3) + 0.03 cos(3x) = 0 near x = 1.3.
        let slope = 2.0 * (x - 1.3) + 0.03 * (3.0 * x).cos();
        assert!(slope.abs() < 1e-7, "x {x}, slope {slope}");
        assert!((x - 1.3).abs() < 0.02, "x {x}");
    }

    #[test]
    fn a_non_finite_matrix_is_refused_not_iterated_forever() {
        let mut m = DMatrix::<f64>::identity(4, 4);
        assert!(svd(m.clone(), true, true).is_some());
        assert!(symmetric_eigen(m.clone()).is_some());
        assert_eq!(complex_eigenvalues(m.clone()).unwrap().len(), 4);
        m[(1, 2)] = f64::NAN;
        assert!(svd(m.clone(), true, true).is_none());
        assert!(symmetric_eigen(m.clone()).is_none());
        assert!(complex_eigenvalues(m.clone()).is_none());
        // Finite but overflowing products: still an answer or a refusal, never a hang.
        let mut big = DMatrix::<f64>::identity(3, 3);
        big[(0, 1)] = 1e300;
        big[(1, 0)] = 1e300;
        let _ = svd(big.clone(), true, true);
        let _ = symmetric_eigen(big);
    }
}
