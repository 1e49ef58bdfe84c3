//! Recursive least squares with a forgetting factor (seed 000 eq. 19): the equation-error rows
//! are taken in order (case by case, in time), and the parameters after each row are kept as
//! a trace, so an engineer sees when they settle and whether they drift.

use super::{EstimateError, Estimator, Fit, Options, Regression};
use nalgebra::{DMatrix, DVector};

pub struct Rls;

/// Trace points kept along the data.
const TRACE_POINTS: usize = 200;

impl Estimator for Rls {
    fn name(&self) -> &'static str {
        "rls"
    }

    fn fit(&self, problem: &Regression, opts: &Options) -> Result<Fit, EstimateError> {
        if opts.output_error.is_some() {
            return Err(EstimateError::NoOutputError("rls"));
        }
        super::ols::check_excitation(problem)?;
        let ones = problem.row_dof.iter().map(|d| (*d, 1.0)).collect();
        let first = super::ols::solve(problem, &ones)?;
        let sigma = super::ols::residual_sigma(problem, &first);
        let (n, p) = (problem.rows(), problem.cols());
        let lambda = opts.forgetting.clamp(0.9, 1.0);
        let mut theta = DVector::<f64>::zeros(p);
        let mut pm = DMatrix::<f64>::identity(p, p) * 1e6;
        let every = n.div_ceil(TRACE_POINTS).max(1);
        let mut trace = Vec::with_capacity(TRACE_POINTS + 1);
        for i in 0..n {
            let w = 1.0 / sigma[&problem.row_dof[i]];
            let phi = DVector::from_iterator(p, problem.row(i).iter().map(|x| x * w));
            let y = problem.y[i] * w;
            let pphi = &pm * &phi;
            let k = &pphi / (lambda + phi.dot(&pphi));
            theta += &k * (y - phi.dot(&theta));
            pm = (&pm - &k * pphi.transpose()) / lambda;
            pm = (&pm + pm.transpose()) * 0.5;
            if i % every == 0 || i + 1 == n {
                trace.push((i, theta.iter().copied().collect()));
            }
        }
        let theta: Vec<f64> = theta.iter().copied().collect();
        if !theta.iter().all(|x| x.is_finite()) {
            return Err(EstimateError::Singular);
        }
        let mut fit = super::ols::summarise(problem, &theta, &sigma);
        fit.trace = Some(trace);
        Ok(fit)
    }
}
