//! Ordinary least squares of the equation error (seed 003 section III-A; seed 001's LS baseline),
//! weighted per DOF so that newtons and newton-metres are comparable (two-step feasible GLS).

use super::normal::Normal;
use super::{Estimate, EstimateError, Estimator, Fit, Options, Regression};
use crate::core::dof::Dof;
use faer::prelude::*;
use nalgebra::DMatrix;
use std::collections::BTreeMap;

pub struct Ols;

impl Estimator for Ols {
    fn name(&self) -> &'static str {
        "ols"
    }

    fn fit(&self, problem: &Regression, opts: &Options) -> Result<Fit, EstimateError> {
        if opts.output_error.is_some() {
            return Err(EstimateError::NoOutputError("ols"));
        }
        check_excitation(problem)?;
        let ones: BTreeMap<Dof, f64> = problem.row_dof.iter().map(|d| (*d, 1.0)).collect();
        let normal = Normal::for_problem(problem);
        let (first, _) = solve_signed(problem, &ones, normal.as_ref())?;
        let sigma = residual_sigma(problem, &first);
        let (theta, held) = solve_signed(problem, &sigma, normal.as_ref())?;
        let mut fit = summarise_with(problem, &theta, &sigma, normal.as_ref());
        for (j, free_value) in held {
            let p = &mut fit.parameters[j];
            p.identifiable = false;
            p.note = Some(format!(
                "the data push {} past its physical sign (unconstrained {:.4}): held at 0; it stands in for something the model lacks (a constant force, a lag, a current) or the runs do not excite it",
                p.name, free_value
            ));
        }
        Ok(fit)
    }
}

/// Parameters held at zero by [`solve_signed`]: (index, unconstrained value when held).
pub(crate) type Held = Vec<(usize, f64)>;

/// Least squares with every added-mass and drag coefficient kept on its physical side of zero
/// (an active set: the worst offender is held at 0 and the rest refitted, until none is left;
/// Lawson & Hanson's NNLS without the release step, which these few parameters rarely need).
/// Returns the solution and the held parameters with the value they had when released.
pub(crate) fn solve_signed(
    problem: &Regression,
    sigma: &BTreeMap<Dof, f64>,
    normal: Option<&Normal>,
) -> Result<(Vec<f64>, Held), EstimateError> {
    let p = problem.cols();
    let mut free = vec![true; p];
    let mut held = Vec::new();
    loop {
        let theta = match normal {
            Some(n) => n.solve(sigma, &free)?,
            None => solve_cols(problem, sigma, &free)?,
        };
        let worst = (0..p)
            .filter(|&j| free[j])
            .filter_map(|j| {
                problem.layout.terms[j]
                    .physical_sign()
                    .map(|s| (j, theta[j] * s))
            })
            .filter(|(_, signed)| *signed < 0.0)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match worst {
            None => return Ok((theta, held)),
            Some((j, _)) => {
                free[j] = false;
                held.push((j, theta[j]));
            }
        }
    }
}

/// Least squares over the `free` columns, the others held at zero.
fn solve_cols(
    problem: &Regression,
    sigma: &BTreeMap<Dof, f64>,
    free: &[bool],
) -> Result<Vec<f64>, EstimateError> {
    let cols: Vec<usize> = (0..problem.cols()).filter(|&j| free[j]).collect();
    let n = problem.rows();
    let w = row_weights(problem, sigma);
    let a = weighted(problem, &w, &cols);
    let b = Mat::<f64>::from_fn(n, 1, |i, _| problem.y[i] * w[i]);
    let x = a.qr().solve_lstsq(&b);
    let mut theta = vec![0.0; problem.cols()];
    for (k, &j) in cols.iter().enumerate() {
        theta[j] = x[(k, 0)];
    }
    if theta.iter().all(|v| v.is_finite()) {
        Ok(theta)
    } else {
        Err(EstimateError::Singular)
    }
}

/// A DOF whose regressor columns are all zero was never moved by the cases.
pub(crate) fn check_excitation(problem: &Regression) -> Result<(), EstimateError> {
    if problem.rows() == 0 {
        return Err(EstimateError::NoData);
    }
    let layout = &problem.layout;
    for d in &layout.dofs {
        let cols: Vec<usize> = (0..layout.len())
            .filter(|j| layout.slot(*j).1 == *d)
            .collect();
        let moved =
            (0..problem.rows()).any(|i| cols.iter().any(|j| problem.row(i)[*j].abs() > 1e-9));
        if !moved {
            let params = cols
                .iter()
                .map(|j| layout.name(*j))
                .collect::<Vec<_>>()
                .join(", ");
            return Err(EstimateError::Unexcited {
                dof: d.to_string(),
                params,
            });
        }
    }
    Ok(())
}

/// Least squares with each row divided by its DOF's residual standard deviation (faer QR).
pub(crate) fn solve(
    problem: &Regression,
    sigma: &BTreeMap<Dof, f64>,
    normal: Option<&Normal>,
) -> Result<Vec<f64>, EstimateError> {
    if let Some(nm) = normal {
        return nm.solve(sigma, &vec![true; problem.cols()]);
    }
    let (n, p) = (problem.rows(), problem.cols());
    let w = row_weights(problem, sigma);
    let a = weighted(problem, &w, &(0..p).collect::<Vec<_>>());
    let b = Mat::<f64>::from_fn(n, 1, |i, _| problem.y[i] * w[i]);
    let x = a.qr().solve_lstsq(&b);
    let theta: Vec<f64> = (0..p).map(|j| x[(j, 0)]).collect();
    if theta.iter().all(|v| v.is_finite()) {
        Ok(theta)
    } else {
        Err(EstimateError::Singular)
    }
}

/// 1 / sigma of each row's DOF.
pub(crate) fn row_weights(problem: &Regression, sigma: &BTreeMap<Dof, f64>) -> Vec<f64> {
    problem.row_dof.iter().map(|d| 1.0 / sigma[d]).collect()
}

/// The Gram matrix of the row-weighted regressor (faer's blocked product).
fn gram(problem: &Regression, w: &[f64]) -> DMatrix<f64> {
    let a = weighted(problem, w, &(0..problem.cols()).collect::<Vec<_>>());
    let g: Mat<f64> = a.transpose() * &a;
    DMatrix::from_fn(g.nrows(), g.ncols(), |i, j| g[(i, j)])
}

/// The regressor's columns `cols` with each row times `w`: filled row by row from the
/// row-major rows, then laid out by faer's blocked copy.
fn weighted(problem: &Regression, w: &[f64], cols: &[usize]) -> Mat<f64> {
    let mut buf = Vec::with_capacity(problem.rows() * cols.len());
    for (i, wi) in w.iter().enumerate() {
        let row = problem.row(i);
        buf.extend(cols.iter().map(|&j| wi * row[j]));
    }
    MatRef::from_row_major_slice(&buf, problem.rows(), cols.len()).to_owned()
}

fn residuals(problem: &Regression, theta: &[f64]) -> Vec<f64> {
    (0..problem.rows())
        .map(|i| {
            problem.y[i]
                - problem
                    .row(i)
                    .iter()
                    .zip(theta)
                    .map(|(a, t)| a * t)
                    .sum::<f64>()
        })
        .collect()
}

pub(crate) fn residual_sigma(problem: &Regression, theta: &[f64]) -> BTreeMap<Dof, f64> {
    let res = residuals(problem, theta);
    let mut acc: BTreeMap<Dof, (f64, usize)> = BTreeMap::new();
    for (r, d) in res.iter().zip(&problem.row_dof) {
        let e = acc.entry(*d).or_default();
        e.0 += r * r;
        e.1 += 1;
    }
    // A floor keeps a noise-free DOF from taking infinite weight.
    acc.into_iter()
        .map(|(d, (s, n))| (d, (s / n as f64).sqrt().max(1e-9)))
        .collect()
}

/// Standard errors from the weighted normal matrix: cov = s^2 (A^T W A)^-1, with s^2 the
/// weighted residual variance (about 1 after reweighting; kept for honesty).
pub(crate) fn summarise(problem: &Regression, theta: &[f64], sigma: &BTreeMap<Dof, f64>) -> Fit {
    summarise_with(problem, theta, sigma, Normal::for_problem(problem).as_ref())
}

/// [`summarise`] with the per-DOF Gram matrices already formed.
pub(crate) fn summarise_with(
    problem: &Regression,
    theta: &[f64],
    sigma: &BTreeMap<Dof, f64>,
    blocks: Option<&Normal>,
) -> Fit {
    let (n, p) = (problem.rows(), problem.cols());
    let w = row_weights(problem, sigma);
    let normal = match blocks {
        Some(b) => b.weighted(sigma).view((0, 0), (p, p)).into_owned(),
        None => gram(problem, &w),
    };
    let res = residuals(problem, theta);
    let ss: f64 = res.iter().zip(&w).map(|(r, w)| (r * w).powi(2)).sum();
    let s2 = ss / (n.saturating_sub(p).max(1)) as f64;
    let (smax, smin) = match crate::core::numerics::svd(normal.clone(), false, false) {
        Some(svd) => (svd.singular_values.max(), svd.singular_values.min()),
        None => (f64::INFINITY, 0.0),
    };
    // The normal matrix squares the regressor's condition number.
    let condition_number = (smax / smin.max(f64::MIN_POSITIVE)).sqrt();
    let cov = normal
        .try_inverse()
        .unwrap_or_else(|| DMatrix::from_element(p, p, f64::INFINITY));
    let parameters = (0..p)
        .map(|j| {
            let stderr = (s2 * cov[(j, j)]).sqrt();
            Estimate {
                name: problem.layout.name(j),
                value: theta[j],
                unit: problem.layout.unit(j).to_string(),
                stderr,
                interval: None,
                identifiable: stderr.is_finite()
                    && stderr < 0.5 * theta[j].abs()
                    && condition_number < 1e8,
                note: None,
            }
        })
        .collect();
    Fit {
        parameters,
        residual_sigma: sigma
            .iter()
            .map(|(d, s)| (d.name().to_string(), *s))
            .collect(),
        samples: n,
        condition_number,
        ..Fit::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::model::ParamLayout;

    /// y = 2 a - 3 b with known noise: OLS must return the truth within its stated error.
    #[test]
    fn recovers_a_linear_model_with_honest_errors() {
        let mut rng = crate::core::rng::Rng::new(3);
        let layout = ParamLayout::new(&[Dof::Surge]);
        let mut r = Regression {
            layout,
            phi: vec![],
            y: vec![],
            row_dof: vec![],
        };
        let truth = [-2.0, -3.0, -0.5];
        for _ in 0..2000 {
            let row = [rng.normal(), rng.normal(), rng.normal()];
            r.y.push(row.iter().zip(truth).map(|(a, t)| a * t).sum::<f64>() + 0.1 * rng.normal());
            r.phi.extend(row);
            r.row_dof.push(Dof::Surge);
        }
        let fit = Ols.fit(&r, &Options::default()).unwrap();
        for (e, t) in fit.parameters.iter().zip(truth) {
            assert!((e.value - t).abs() < 4.0 * e.stderr, "{e:?}");
            assert!((e.stderr - 0.1 / 2000f64.sqrt()).abs() < 0.001, "{e:?}");
            assert!(e.identifiable);
        }
        assert!((fit.residual_sigma["surge"] - 0.1).abs() < 0.01);
    }

    /// Data generated with a positive "drag" (energy fed in) must not come back positive and
    /// identifiable: it is held at zero and flagged with the reason.
    #[test]
    fn a_coefficient_pushed_past_its_sign_is_held_and_flagged() {
        let mut rng = crate::core::rng::Rng::new(5);
        let layout = ParamLayout::new(&[Dof::Surge]);
        let mut r = Regression {
            layout,
            phi: vec![],
            y: vec![],
            row_dof: vec![],
        };
        let truth = [-2.0, 0.8, -0.5];
        for _ in 0..2000 {
            let row = [rng.normal(), rng.normal(), rng.normal()];
            r.y.push(row.iter().zip(truth).map(|(a, t)| a * t).sum::<f64>() + 0.1 * rng.normal());
            r.phi.extend(row);
            r.row_dof.push(Dof::Surge);
        }
        let fit = Ols.fit(&r, &Options::default()).unwrap();
        let x_u = &fit.parameters[1];
        assert_eq!(x_u.value, 0.0, "{x_u:?}");
        assert!(
            !x_u.identifiable
                && x_u
                    .note
                    .as_deref()
                    .is_some_and(|n| n.contains("physical sign")),
            "{x_u:?}"
        );
        assert!(
            (fit.parameters[0].value + 2.0).abs() < 0.05
                && (fit.parameters[2].value + 0.5).abs() < 0.05,
            "{fit:?}"
        );
    }

    #[test]
    fn an_unexcited_dof_is_named() {
        let layout = ParamLayout::new(&[Dof::Surge, Dof::Heave]);
        let r = Regression {
            layout,
            phi: vec![1.0, 0.0, 2.0, 0.0, 3.0, 0.0],
            y: vec![1.0],
            row_dof: vec![Dof::Surge],
        };
        let e = Ols.fit(&r, &Options::default()).unwrap_err().to_string();
        assert!(e.contains("never excite heave: Z_wdot, Z_w, Z_ww"), "{e}");
    }
}
