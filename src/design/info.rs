//! What a run tells about the parameters: the Fisher information of the equation-error problem
//! (seed 001 eq. 14) it adds, rows weighted by each DOF's residual level as the fit weighted
//! them. The recorded runs' information gives the covariance now; adding a candidate's gives
//! the covariance after it is flown. The prediction is the ratio of the two, applied to the
//! standard errors the fit reported, so it holds whatever scale the fit's own method used.

use crate::core::dof::Dof;
use crate::core::model::{ParamLayout, Vehicle};
use crate::core::response::Response;
use crate::identify::Regression;
use crate::identify::normal::Normal;
use nalgebra::DMatrix;
use std::collections::BTreeMap;

/// The information `Phi^T W Phi` of `responses` for the parameters of `layout`.
pub fn information(
    layout: &ParamLayout,
    vehicle: &Vehicle,
    responses: &[&Response],
    sigma: &BTreeMap<Dof, f64>,
    skip_start_s: f64,
) -> DMatrix<f64> {
    let p = layout.len();
    let r = Regression::build_with(layout, vehicle, responses, skip_start_s);
    if r.rows() == 0 {
        return DMatrix::zeros(p, p);
    }
    Normal::of(&r)
        .weighted(sigma)
        .view((0, 0), (p, p))
        .into_owned()
}

/// The information `J^T J` of the output-error problem (seed 001 eq. 9) the prediction-error
/// fit minimises: `J` the sensitivity of the weighted simulated velocities of `responses` to
/// each parameter at `theta`, by central differences, the commands through the fit's lag.
pub fn output_information(
    layout: &ParamLayout,
    vehicle: &Vehicle,
    responses: &[&Response],
    lag_s: f64,
    theta: &[f64],
) -> DMatrix<f64> {
    use crate::core::model::lanes::LANES;
    let p = theta.len();
    let oe = crate::identify::output_error::OutputError::with_lag(vehicle, responses, lag_s);
    let step: Vec<f64> = theta.iter().map(|t| 1e-3 * t.abs().max(1e-2)).collect();
    let shifted: Vec<Vec<f64>> = (0..2 * p)
        .map(|i| {
            let mut t = theta.to_vec();
            t[i / 2] += if i % 2 == 0 {
                step[i / 2]
            } else {
                -step[i / 2]
            };
            t
        })
        .collect();
    let refs: Vec<&[f64]> = shifted.iter().map(|t| t.as_slice()).collect();
    let res: Vec<Vec<f64>> = refs
        .chunks(LANES)
        .flat_map(|c| oe.residuals_many(layout, c))
        .collect();
    let n = res.first().map_or(0, Vec::len);
    let jac = DMatrix::from_fn(n, p, |k, j| {
        (res[2 * j][k] - res[2 * j + 1][k]) / (2.0 * step[j])
    });
    jac.transpose() * jac
}

/// What a parameter no run informs is given as variance (relative to its information scale).
const UNINFORMED_VARIANCE: f64 = 1e30;

/// The covariance (up to the fit's scale) of information `m`: its inverse, through an
/// equilibrated eigen-decomposition so that a direction the runs barely excite has a huge
/// variance rather than a failed inverse. A parameter with no information at all (a zero
/// diagonal) is left out of the inverse and given [`UNINFORMED_VARIANCE`].
pub fn covariance(m: &DMatrix<f64>) -> DMatrix<f64> {
    let p = m.nrows();
    let top = (0..p).fold(0.0f64, |a, i| a.max(m[(i, i)].abs()));
    let informed: Vec<usize> = (0..p).filter(|&i| m[(i, i)] > 1e-14 * top).collect();
    let k = informed.len();
    let d: Vec<f64> = informed.iter().map(|&i| m[(i, i)].sqrt()).collect();
    let scaled = DMatrix::from_fn(k, k, |a, b| m[(informed[a], informed[b])] / (d[a] * d[b]));
    let eig = nalgebra::SymmetricEigen::new(scaled);
    let floor = 1e-12 * eig.eigenvalues.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let inv_vals = eig.eigenvalues.map(|x| 1.0 / x.max(floor).max(1e-300));
    let inv = &eig.eigenvectors * DMatrix::from_diagonal(&inv_vals) * eig.eigenvectors.transpose();
    let mut out = DMatrix::zeros(p, p);
    for i in 0..p {
        out[(i, i)] = UNINFORMED_VARIANCE;
    }
    for (a, &i) in informed.iter().enumerate() {
        for (b, &j) in informed.iter().enumerate() {
            out[(i, j)] = inv[(a, b)] / (d[a] * d[b]);
        }
    }
    out
}

/// The D-optimal criterion on the parameters `targets`: log det of their covariance block
/// (smaller is better: the volume of their joint confidence region).
pub fn log_det_block(cov: &DMatrix<f64>, targets: &[usize]) -> f64 {
    let k = targets.len();
    let block = DMatrix::from_fn(k, k, |i, j| cov[(targets[i], targets[j])]);
    match block.cholesky() {
        Some(c) => 2.0 * c.l().diagonal().iter().map(|x| x.ln()).sum::<f64>(),
        None => f64::INFINITY,
    }
}

/// The A-optimal criterion on the parameters `targets`: log of the sum of their predicted
/// variances, each relative to its value squared (the coefficients carry different units, so
/// the trace is taken of the relative covariance; a value near zero is scaled by its standard
/// error instead). Smaller is better: the mean relative error of the targets.
pub fn log_relative_trace(se_after: &[f64], value: &[f64], targets: &[usize]) -> f64 {
    targets
        .iter()
        .map(|&j| {
            let scale = if value[j].abs() > 1e-9 {
                value[j].abs()
            } else {
                se_after[j].max(1e-12)
            };
            (se_after[j] / scale).powi(2)
        })
        .sum::<f64>()
        .ln()
}

/// The correlation of parameters `i` and `j` under `cov`.
pub fn correlation(cov: &DMatrix<f64>, i: usize, j: usize) -> f64 {
    cov[(i, j)] / (cov[(i, i)] * cov[(j, j)]).sqrt()
}

/// Per parameter: the standard error predicted after the run whose information is added to
/// `before`. For a parameter the recorded runs determine (a reported standard error below
/// its value), `se * sqrt(C_after / C_before)`; for one they do not (no standard error, or one
/// larger than the value: its variance then says more about how the fit regularised a
/// direction no run excites than about the data), `scale * sqrt(C_after)`, the scale the
/// median ratio of reported error to `sqrt(C_before)` over the determined ones (or the ratio
/// rule, where that is smaller).
pub fn predicted(
    reported: &[f64],
    value: &[f64],
    before: &DMatrix<f64>,
    after: &DMatrix<f64>,
) -> Vec<f64> {
    let p = reported.len();
    let determined =
        |j: usize| reported[j].is_finite() && reported[j] > 0.0 && reported[j] < value[j].abs();
    let mut scales: Vec<f64> = (0..p)
        .filter(|&j| determined(j))
        .map(|j| reported[j] / before[(j, j)].sqrt())
        .filter(|s| s.is_finite())
        .collect();
    scales.sort_by(f64::total_cmp);
    let scale = scales.get(scales.len() / 2).copied().unwrap_or(f64::NAN);
    (0..p)
        .map(|j| {
            let by_ratio = reported[j] * (after[(j, j)] / before[(j, j)]).sqrt();
            let by_scale = scale * after[(j, j)].sqrt();
            match (determined(j), by_ratio.is_finite() && reported[j] > 0.0) {
                (true, true) => by_ratio,
                (false, true) => by_ratio.min(by_scale),
                _ => by_scale,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_a_criterion_weighs_each_target_by_its_value() {
        // Halving the relative error of one of two equal targets: from 2 x 0.01 to 0.01 + 0.0025.
        let a = super::log_relative_trace(&[0.1, 10.0, 5.0], &[1.0, 100.0, 0.0], &[0, 1]);
        let b = super::log_relative_trace(&[0.05, 10.0, 5.0], &[1.0, 100.0, 0.0], &[0, 1]);
        assert!((a - 0.02f64.ln()).abs() < 1e-12 && (b - 0.0125f64.ln()).abs() < 1e-12);
        // A zero value is scaled by its own error.
        let c = super::log_relative_trace(&[0.1, 10.0, 5.0], &[1.0, 100.0, 0.0], &[2]);
        assert!(c.abs() < 1e-12);
    }

    use super::*;

    #[test]
    fn the_covariance_inverts_information_and_survives_a_direction_nothing_excites() {
        let m = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.0, 1.0, 3.0, 0.0, 0.0, 0.0, 0.0]);
        let c = covariance(&m);
        let top = m.view((0, 0), (2, 2)).into_owned().try_inverse().unwrap();
        for i in 0..2 {
            for j in 0..2 {
                assert!((c[(i, j)] - top[(i, j)]).abs() < 1e-9, "{i} {j}");
            }
        }
        assert!(c[(2, 2)] > 1e6 && c[(2, 2)].is_finite());
        // Doubling the information halves the variance: sqrt(1/2) on the standard error.
        let after = covariance(&(&m * 2.0));
        let se = predicted(&[0.5, 0.2, f64::NAN], &[2.0, -1.0, 0.0], &c, &after);
        assert!((se[0] - 0.5 / 2f64.sqrt()).abs() < 1e-9);
        assert!((se[1] - 0.2 / 2f64.sqrt()).abs() < 1e-9);
    }
}
