//! Weighting sources against each other: CFD rows and pool rows in one problem, each divided
//! by its own residual level per DOF.

use super::Regression;
use crate::core::dof::Dof;
use std::collections::BTreeMap;

/// One problem from CFD rows and pool rows. When both are there each source's rows are divided
/// by that source's own residual level per DOF (from a least-squares fit on it alone), so the
/// noisier source cannot swamp the other: then a residual of 1 means "as good as that source's
/// own fit" in either.
pub fn combine(mut cfd: Regression, mut pool: Regression, notes: &mut Vec<String>) -> Regression {
    if cfd.rows() == 0 {
        return pool;
    }
    if pool.rows() == 0 {
        return cfd;
    }
    for (name, reg) in [("CFD", &mut cfd), ("pool", &mut pool)] {
        let sigma = source_sigma(reg);
        let levels: Vec<String> = sigma.iter().map(|(d, s)| format!("{d} {s:.3}")).collect();
        notes.push(format!(
            "{name} rows weighted by their own residual level ({})",
            levels.join(", ")
        ));
        reg.scale_rows(&sigma);
    }
    cfd.append(pool);
    cfd
}

/// Residual standard deviation per DOF of an unweighted least-squares fit on `reg` alone;
/// the RMS of its targets where that fit is not possible.
pub fn source_sigma(reg: &Regression) -> BTreeMap<Dof, f64> {
    let ones: BTreeMap<Dof, f64> = reg.row_dof.iter().map(|d| (*d, 1.0)).collect();
    match super::ols::solve(reg, &ones, super::normal::Normal::for_problem(reg).as_ref()) {
        Ok(theta) => super::ols::residual_sigma(reg, &theta),
        Err(_) => {
            let mut acc: BTreeMap<Dof, (f64, usize)> = BTreeMap::new();
            for (y, d) in reg.y.iter().zip(&reg.row_dof) {
                let e = acc.entry(*d).or_default();
                e.0 += y * y;
                e.1 += 1;
            }
            acc.into_iter()
                .map(|(d, (s, n))| (d, (s / n as f64).sqrt().max(1e-9)))
                .collect()
        }
    }
}
