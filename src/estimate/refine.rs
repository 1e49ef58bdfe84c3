//! Local least-squares refinement of an output-error fit (Levenberg-Marquardt on the simulated
//! velocities), from the best answer of a population search.
//!
//! A population method finds the basin; its restarts' spread is a poor uncertainty, and none
//! at all when a time limit leaves one restart. Near the optimum the output error is smooth,
//! so a damped Gauss-Newton step finishes the job. The Jacobian of the simulated velocities
//! with respect to the coefficients then gives standard errors,
//! `s^2 (J^T J)^-1` with `s^2` the residual variance: conditional on the model being right,
//! as for the equation error.

use super::output_error::OutputError;
use crate::model::ParamLayout;
use nalgebra::{DMatrix, DVector};

/// The refined coefficients and their standard errors (NaN where `J^T J` is singular).
pub struct Refined {
    pub theta: Vec<f64>,
    pub stderr: Vec<f64>,
    /// Weighted mean square velocity error before and after.
    pub cost_before: f64,
    pub cost_after: f64,
}

/// Levenberg-Marquardt from `theta0`, at most `iterations` accepted steps. Coefficients with a
/// physical sign stay on it.
pub fn output_error_lm(
    oe: &OutputError,
    layout: &ParamLayout,
    theta0: &[f64],
    iterations: usize,
) -> Refined {
    let p = theta0.len();
    let signs: Vec<Option<f64>> = (0..p).map(|j| layout.slot(j).0.physical_sign()).collect();
    let keep_sign = |theta: &mut [f64]| {
        for (x, s) in theta.iter_mut().zip(&signs) {
            if let Some(s) = s
                && *x * s < 0.0
            {
                *x = 0.0;
            }
        }
    };
    let sq = |r: &[f64]| r.iter().map(|x| x * x).sum::<f64>();
    let mut theta = theta0.to_vec();
    let mut r = oe.residuals(layout, &theta);
    let mut cost = sq(&r);
    let cost_before = cost / r.len().max(1) as f64;
    let mut lambda = 1e-3;
    let mut a = DMatrix::<f64>::zeros(p, p);
    for _ in 0..iterations {
        let jac = jacobian(oe, layout, &theta, &r);
        a = DMatrix::from_fn(p, p, |i, j| {
            jac[i].iter().zip(&jac[j]).map(|(x, y)| x * y).sum()
        });
        let g = DVector::from_fn(p, |i, _| jac[i].iter().zip(&r).map(|(x, y)| x * y).sum());
        let mut improved = false;
        for _ in 0..8 {
            let mut damped = a.clone();
            for i in 0..p {
                damped[(i, i)] += lambda * a[(i, i)].max(1e-12);
            }
            let Some(step) = damped.lu().solve(&(-&g)) else {
                break;
            };
            let mut next: Vec<f64> = theta.iter().zip(step.iter()).map(|(x, d)| x + d).collect();
            keep_sign(&mut next);
            let rn = oe.residuals(layout, &next);
            let cn = sq(&rn);
            if cn.is_finite() && cn < cost {
                let gain = (cost - cn) / cost;
                (theta, r, cost) = (next, rn, cn);
                lambda = (lambda / 3.0).max(1e-9);
                improved = gain > 1e-7;
                break;
            }
            lambda *= 4.0;
        }
        if !improved {
            break;
        }
    }
    let n = r.len();
    // The velocity errors of a simulation are correlated from sample to sample (a fused
    // recording is smoothed, a model error persists), so n samples carry the information of
    // fewer: the variance grows by the AR(1) long-run factor (1 + rho) / (1 - rho) of the
    // residual's lag-1 autocorrelation.
    let rho = {
        let (num, den) = r
            .windows(2)
            .fold((0.0, 0.0), |(a, b), w| (a + w[0] * w[1], b + w[0] * w[0]));
        if den > 0.0 {
            (num / den).clamp(0.0, 0.999)
        } else {
            0.0
        }
    };
    let s2 = cost / (n.saturating_sub(p)).max(1) as f64 * (1.0 + rho) / (1.0 - rho);
    let stderr = match a.try_inverse() {
        Some(inv) => (0..p).map(|j| (s2 * inv[(j, j)]).max(0.0).sqrt()).collect(),
        None => vec![f64::NAN; p],
    };
    Refined {
        theta,
        stderr,
        cost_before,
        cost_after: cost / n.max(1) as f64,
    }
}

/// Columns of d(residual)/d(theta_j) by forward differences.
fn jacobian(oe: &OutputError, layout: &ParamLayout, theta: &[f64], r0: &[f64]) -> Vec<Vec<f64>> {
    use rayon::prelude::*;
    (0..theta.len())
        .into_par_iter()
        .map(|j| {
            let h = 1e-4 * theta[j].abs().max(1e-2);
            let mut t = theta.to_vec();
            t[j] += h;
            let rj = oe.residuals(layout, &t);
            rj.iter().zip(r0).map(|(a, b)| (a - b) / h).collect()
        })
        .collect()
}
