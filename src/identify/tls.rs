//! Total least squares of the equation error (seed 003 section III-B): the regressor is noisy
//! too (acceleration and velocity come from the same CFD monitors as everything else), so the
//! fit perturbs [A b] as little as possible instead of b alone. Solved by SVD of the row- and
//! column-scaled [A b]; when the smallest singular value repeats, the minimum-norm solution
//! over its right singular subspace (seed 003, after Van Huffel & Vandewalle).

use super::{EstimateError, Estimator, Fit, Options, Regression};
use nalgebra::DMatrix;

pub struct Tls;

/// Singular values closer than this (relative) count as repeated.
const REPEAT_TOL: f64 = 1e-6;

impl Estimator for Tls {
    fn name(&self) -> &'static str {
        "tls"
    }

    fn fit(&self, problem: &Regression, opts: &Options) -> Result<Fit, EstimateError> {
        if opts.output_error.is_some() {
            return Err(EstimateError::NoOutputError("tls"));
        }
        super::ols::check_excitation(problem)?;
        // Rows weighted per DOF as in OLS (first pass), columns equilibrated to unit RMS so
        // that no column's units decide which one absorbs the error.
        let ones = problem.row_dof.iter().map(|d| (*d, 1.0)).collect();
        let normal = super::normal::Normal::of(problem);
        let big = (problem.cols() > super::normal::NORMAL_ABOVE_TERMS).then_some(&normal);
        let first = super::ols::solve(problem, &ones, big)?;
        let sigma = super::ols::residual_sigma(problem, &first);
        let (n, p) = (problem.rows(), problem.cols());
        // [A y]^T W [A y], then each column scaled to unit RMS: D^-1 G D^-1.
        let g = normal.weighted(&sigma);
        let scale: Vec<f64> = (0..=p)
            .map(|j| (g[(j, j)] / n as f64).sqrt().max(1e-300))
            .collect();
        let scaled = DMatrix::from_fn(p + 1, p + 1, |a, b| g[(a, b)] / (scale[a] * scale[b]));
        let theta_scaled = tls_solve(&scaled)?;
        let theta: Vec<f64> = (0..p)
            .map(|j| theta_scaled[j] * scale[p] / scale[j])
            .collect();
        let mut fit = super::ols::summarise_with(problem, &theta, &sigma, Some(&normal));
        for e in &mut fit.parameters {
            e.interval = None;
        }
        Ok(fit)
    }
}

/// TLS from the (p+1)x(p+1) Gram matrix of [A b]: its eigenvectors are the right singular
/// vectors of [A b]. Returns theta with A theta ~ b.
pub fn tls_solve(gram: &DMatrix<f64>) -> Result<Vec<f64>, EstimateError> {
    let q = gram.nrows();
    let p = q - 1;
    let eig =
        crate::core::numerics::symmetric_eigen(gram.clone()).ok_or(EstimateError::Singular)?;
    let mut order: Vec<usize> = (0..q).collect();
    order.sort_by(|a, b| eig.eigenvalues[*a].total_cmp(&eig.eigenvalues[*b]));
    // Singular values are square roots of the Gram matrix's eigenvalues.
    let sv: Vec<f64> = order
        .iter()
        .map(|&i| eig.eigenvalues[i].max(0.0).sqrt())
        .collect();
    let smax = sv[q - 1].max(f64::MIN_POSITIVE);
    let k = sv
        .iter()
        .take_while(|s| (**s - sv[0]) / smax <= REPEAT_TOL)
        .count()
        .max(1);
    // V2: the right singular vectors of the k smallest singular values; theta = -V12 V22' / (V22 V22').
    let v2: Vec<_> = order[..k]
        .iter()
        .map(|&i| eig.eigenvectors.column(i).into_owned())
        .collect();
    let v22: Vec<f64> = v2.iter().map(|v| v[p]).collect();
    let denom: f64 = v22.iter().map(|x| x * x).sum();
    if denom < 1e-24 {
        return Err(EstimateError::Singular);
    }
    let theta: Vec<f64> = (0..p)
        .map(|j| -v2.iter().zip(&v22).map(|(v, c)| v[j] * c).sum::<f64>() / denom)
        .collect();
    if theta.iter().all(|x| x.is_finite()) {
        Ok(theta)
    } else {
        Err(EstimateError::Singular)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_data_is_solved_and_a_repeated_singular_value_gives_the_minimum_norm_solution() {
        // b = 2 a1 - 3 a2 exactly: the smallest singular value is 0 and theta is exact.
        let rows = [[1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [2.0, -1.0]];
        let m = DMatrix::from_fn(4, 3, |i, j| {
            if j < 2 {
                rows[i][j]
            } else {
                2.0 * rows[i][0] - 3.0 * rows[i][1]
            }
        });
        let th = tls_solve(&(m.transpose() * &m)).unwrap();
        assert!(
            (th[0] - 2.0).abs() < 1e-9 && (th[1] + 3.0).abs() < 1e-9,
            "{th:?}"
        );
        // [A b] = [I | 0] padded: a Gram matrix diag(1, 1, 1) has one triple singular value; the
        // minimum-norm TLS over the whole space of V is theta = 0.
        let g = DMatrix::<f64>::identity(3, 3);
        let th = tls_solve(&g).unwrap();
        assert!(th.iter().all(|x| x.abs() < 1e-12), "{th:?}");
    }
}
