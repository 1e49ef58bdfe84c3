//! Recursive least squares with a forgetting factor (seed 000 eq. 19): the equation-error rows
//! are taken in order (case by case, in time), and the parameters after each row are kept as
//! a trace, so an engineer sees when they settle and whether they drift.

use super::{EstimateError, Estimator, Fit, Options, Regression};
use nalgebra::{DMatrix, DVector};

pub struct Rls;

/// The settings of `method: rls`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RlsSettings {
    /// Forgetting factor (seed 000 eq. 19), in (0, 1]; 1 keeps every row equally.
    pub forgetting: f64,
}

impl Default for RlsSettings {
    fn default() -> Self {
        RlsSettings { forgetting: 1.0 }
    }
}

/// Trace points kept along the data.
const TRACE_POINTS: usize = 200;

impl Estimator for Rls {
    fn name(&self) -> &'static str {
        "rls"
    }

    fn settings(
        &self,
        own: serde_json::Map<String, serde_json::Value>,
    ) -> Result<super::OwnSettings, String> {
        let s = super::own_settings::<RlsSettings>(own)?;
        let f = s.forgetting;
        if !(f > 0.0 && f <= 1.0) {
            return Err(format!(
                "forgetting = {f} is outside (0, 1]: 1 keeps every row, 0.99 forgets over ~100 rows"
            ));
        }
        Ok(super::OwnSettings::Rls(s))
    }

    fn fit(&self, problem: &Regression, opts: &Options) -> Result<Fit, EstimateError> {
        if opts.output_error.is_some() {
            return Err(EstimateError::NoOutputError("rls"));
        }
        super::ols::check_excitation(problem)?;
        let ones = problem.row_dof.iter().map(|d| (*d, 1.0)).collect();
        let first = super::ols::solve(
            problem,
            &ones,
            super::normal::Normal::for_problem(problem).as_ref(),
        )?;
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
