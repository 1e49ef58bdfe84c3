//! Two-step least squares for bodies whose drag depends on the motion's history (a wake that
//! builds up): the added mass from the first seconds of each run from rest, while drag is
//! still negligible, then the drag with that added mass held.

use super::{Fit, Regression};
use std::collections::BTreeMap;

/// The samples of a response up to `t_end`.
pub fn truncate(
    r: &crate::core::response::Response,
    t_end: f64,
) -> crate::core::response::Response {
    let n = r.t.iter().take_while(|t| **t <= t_end).count();
    let mut out = r.clone();
    out.t.truncate(n);
    for s in out.dofs.values_mut() {
        s.force.truncate(n);
        s.velocity.truncate(n);
        s.accel.truncate(n);
    }
    out
}

/// Least squares over the columns `cols` of `reg`, with the other parameters held at `held`:
/// values, standard errors and the condition number of that sub-problem.
fn subset_lstsq(
    reg: &Regression,
    cols: &[usize],
    held: &[f64],
) -> anyhow::Result<(Vec<f64>, Vec<f64>, f64)> {
    use nalgebra::{DMatrix, DVector};
    let (n, c) = (reg.rows(), cols.len());
    anyhow::ensure!(
        n > c,
        "{n} equation rows cannot determine {c} parameters: lengthen the window"
    );
    let a = DMatrix::from_fn(n, c, |i, j| reg.row(i)[cols[j]]);
    let b = DVector::from_fn(n, |i, _| {
        reg.y[i]
            - (0..reg.cols())
                .filter(|j| !cols.contains(j))
                .map(|j| reg.row(i)[j] * held[j])
                .sum::<f64>()
    });
    let svd = crate::core::numerics::svd(a.clone(), true, true).ok_or_else(|| {
        anyhow::anyhow!(
            "least squares: the regressor has a non-finite entry or its SVD does not converge"
        )
    })?;
    let (smax, smin) = (svd.singular_values.max(), svd.singular_values.min());
    let x = svd
        .solve(&b, 1e-12 * smax)
        .map_err(|e| anyhow::anyhow!("least squares: {e}"))?;
    let res = &b - &a * &x;
    let s2 = res.norm_squared() / (n - c) as f64;
    let cov = (a.transpose() * &a)
        .try_inverse()
        .unwrap_or_else(|| DMatrix::from_element(c, c, f64::INFINITY));
    Ok((
        x.iter().copied().collect(),
        (0..c).map(|j| (s2 * cov[(j, j)]).sqrt()).collect(),
        smax / smin.max(f64::MIN_POSITIVE),
    ))
}

/// Added mass from the acceleration window (drag neglected there), then the drag from every
/// sample with that added mass held.
pub fn two_step(early: &Regression, all: &Regression) -> anyhow::Result<Fit> {
    use crate::core::model::params::Group;
    let layout = &all.layout;
    let p = layout.len();
    let (added, drag): (Vec<usize>, Vec<usize>) =
        (0..p).partition(|&j| layout.slot(j).0 == Group::AddedMass);
    // Step 1: drag held at zero over the window.
    let (am, am_se, k1) = subset_lstsq(early, &added, &vec![0.0; p])?;
    let mut theta = vec![0.0; p];
    let mut se = vec![0.0; p];
    for (k, &j) in added.iter().enumerate() {
        theta[j] = am[k];
        se[j] = am_se[k];
    }
    let (dr, dr_se, k2) = subset_lstsq(all, &drag, &theta)?;
    for (k, &j) in drag.iter().enumerate() {
        theta[j] = dr[k];
        se[j] = dr_se[k];
    }
    let condition_number = k1.max(k2);
    Ok(Fit {
        parameters: (0..p)
            .map(|j| super::Estimate {
                name: layout.name(j),
                value: theta[j],
                unit: layout.unit(j).to_string(),
                stderr: se[j],
                interval: None,
                identifiable: se[j].is_finite()
                    && se[j] < 0.5 * theta[j].abs()
                    && condition_number < 1e8,
                note: None,
            })
            .collect(),
        residual_sigma: residual_sigma(all, &theta),
        samples: all.rows(),
        condition_number,
        ..Fit::default()
    })
}

/// Residual standard deviation of `reg`'s rows at `theta`, per DOF.
fn residual_sigma(reg: &Regression, theta: &[f64]) -> BTreeMap<String, f64> {
    let mut sigma: BTreeMap<String, (f64, usize)> = BTreeMap::new();
    for i in 0..reg.rows() {
        let r = reg.y[i]
            - reg
                .row(i)
                .iter()
                .zip(theta)
                .map(|(a, t)| a * t)
                .sum::<f64>();
        let e = sigma.entry(reg.row_dof[i].name().to_string()).or_default();
        e.0 += r * r;
        e.1 += 1;
    }
    sigma
        .into_iter()
        .map(|(d, (ss, n))| (d, (ss / n.max(1) as f64).sqrt()))
        .collect()
}
