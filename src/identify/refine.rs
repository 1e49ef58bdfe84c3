//! Local least-squares refinement of an output-error fit (Levenberg-Marquardt on the simulated
//! velocities), from the best answer of a population search.
//!
//! A population method finds the basin; its restarts' spread is a poor uncertainty, and none
//! at all when a time limit leaves one restart. Near the optimum the output error is smooth,
//! so a damped Gauss-Newton step finishes the job. The Jacobian of the simulated velocities
//! with respect to the coefficients then gives standard errors,
//! `s^2 (J^T J)^-1` with `s^2` the residual variance: conditional on the model being right,
//! as for the equation error.

use super::attitude_rows::{in_attitude_rows, is_attitude_coupling};
use super::output_error::OutputError;
use crate::core::model::ParamLayout;
use crate::core::model::lanes::LANES;
use nalgebra::{DMatrix, DVector};

/// The refined coefficients and their standard errors (NaN where `J^T J` is singular).
pub struct Refined {
    pub theta: Vec<f64>,
    /// The per-run nuisance parameters' values, in the order of the objective's `nuisance`.
    pub nuisance: Vec<f64>,
    pub stderr: Vec<f64>,
    /// The coefficients' correlation matrix from `(J^T J)^-1` (empty where it is singular).
    pub correlation: Vec<Vec<f64>>,
    /// Levenberg-Marquardt steps taken.
    pub steps: usize,
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
    output_error_lm_within(oe, layout, theta0, iterations, &Bounds::signs(layout))
}

/// The range each coefficient may take during a refinement: its physical sign and, where the
/// caller states one, a plausibility prior (added mass at most a multiple of the rigid-body
/// term).
#[derive(Debug, Clone)]
pub struct Bounds {
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
}

impl Bounds {
    /// Only the physical signs: a coefficient with one stays on its side of zero.
    pub fn signs(layout: &ParamLayout) -> Bounds {
        let (lo, hi) = layout
            .terms
            .iter()
            .map(|t| match t.physical_sign() {
                Some(s) if s < 0.0 => (f64::NEG_INFINITY, 0.0),
                Some(_) => (0.0, f64::INFINITY),
                None => (f64::NEG_INFINITY, f64::INFINITY),
            })
            .unzip();
        Bounds { lo, hi }
    }

    /// `x` moved into the range.
    pub fn clamp(&self, x: &mut [f64]) {
        for ((x, lo), hi) in x.iter_mut().zip(&self.lo).zip(&self.hi) {
            *x = x.clamp(*lo, *hi);
        }
    }

    /// Whether coefficient `j` is held: its two bounds meet.
    pub fn held(&self, j: usize) -> bool {
        j < self.lo.len() && self.lo[j] == self.hi[j]
    }

    /// Whether coefficient `j` at `x` sits on a finite, non-zero end of its range (zero is a
    /// sign's end, said apart).
    pub fn at_prior(&self, j: usize, x: f64) -> bool {
        let on = |b: f64| b.is_finite() && b != 0.0 && (x - b).abs() <= 1e-6 * b.abs();
        on(self.lo[j]) || on(self.hi[j])
    }
}

/// [`output_error_lm`] with every coefficient kept within `bounds` (one whose two bounds meet
/// is held). `theta0` may carry the objective's nuisance values after the coefficients;
/// without them they start at zero. Standard errors and correlations are the coefficients'
/// (the nuisance parameters', estimated alongside, are marginalised out). A model with a
/// translational velocity's drag in roll or pitch is fitted in two stages
/// ([`super::attitude_rows`]): first with the couplings held at zero, then roll's and pitch's
/// own coefficients and the couplings with every other coefficient held.
pub fn output_error_lm_within(
    oe: &OutputError,
    layout: &ParamLayout,
    theta0: &[f64],
    iterations: usize,
    bounds: &Bounds,
) -> Refined {
    let couplings: Vec<usize> = (0..layout.len())
        .filter(|&j| is_attitude_coupling(layout.terms[j]) && !bounds.held(j))
        .collect();
    if couplings.is_empty() {
        return lm_within(oe, layout, theta0, iterations, bounds);
    }
    let mut first_bounds = bounds.clone();
    for &j in &couplings {
        (first_bounds.lo[j], first_bounds.hi[j]) = (0.0, 0.0);
    }
    let first = lm_within(oe, layout, theta0, iterations, &first_bounds);
    let mut rows = bounds.clone();
    for j in (0..layout.len()).filter(|&j| !in_attitude_rows(layout.terms[j])) {
        (rows.lo[j], rows.hi[j]) = (first.theta[j], first.theta[j]);
    }
    let from = [first.theta.as_slice(), &first.nuisance].concat();
    let second = lm_within(oe, layout, &from, iterations, &rows);
    // A second stage that did not lower the error (or diverged) is not taken.
    let order = second.cost_after.partial_cmp(&first.cost_after);
    if order.is_none_or(std::cmp::Ordering::is_gt) {
        return first;
    }
    Refined {
        steps: first.steps + second.steps,
        cost_before: first.cost_before,
        ..second
    }
}

/// [`output_error_lm_within`] in one stage.
fn lm_within(
    oe: &OutputError,
    layout: &ParamLayout,
    theta0: &[f64],
    iterations: usize,
    bounds: &Bounds,
) -> Refined {
    let m = layout.len();
    let mut theta = theta0.to_vec();
    theta.resize(m + oe.nuisance.len(), 0.0);
    let p = theta.len();
    bounds.clamp(&mut theta);
    let r = oe.residuals(layout, &theta);
    let cost = sum_sq(&r);
    let cost_before = cost / r.len().max(1) as f64;
    let mut lm = Lm {
        oe,
        layout,
        bounds,
        theta,
        r,
        cost,
        lambda: 1e-3,
    };
    let mut a = DMatrix::<f64>::zeros(p, p);
    let mut steps = 0;
    for _ in 0..iterations {
        if crate::core::interrupt::requested() {
            break;
        }
        // A held coefficient's column is not needed for the step.
        let jac = jacobian(oe, layout, &lm.theta, &lm.r, &|j| bounds.held(j));
        let g;
        (a, g) = normal_equations(&jac, &lm.r);
        if !lm.step(&a, &g) {
            break;
        }
        steps += 1;
    }
    if (0..m).any(|j| bounds.held(j)) {
        // The errors are every coefficient's, held or not, as if all were fitted here.
        a = normal_equations(&jacobian(oe, layout, &lm.theta, &lm.r, &|_| false), &lm.r).0;
    }
    let n = lm.r.len();
    let (mut stderr, mut correlation) = standard_errors(&lm.r, lm.cost, a);
    stderr.truncate(m);
    correlation.truncate(m);
    correlation.iter_mut().for_each(|row| row.truncate(m));
    let nuisance = lm.theta.split_off(m);
    Refined {
        theta: lm.theta,
        nuisance,
        stderr,
        correlation,
        cost_before,
        cost_after: lm.cost / n.max(1) as f64,
        steps,
    }
}

/// The relative drop of the output error below which a step ends the refinement: what is
/// left is well inside the run-to-run scatter of any cost the fit is compared on.
const MIN_GAIN: f64 = 1e-5;

/// Levenberg-Marquardt's state: the coefficients, their residuals and cost, and the damping.
struct Lm<'a, 'o> {
    oe: &'a OutputError<'o>,
    layout: &'a ParamLayout,
    /// The range of each coefficient.
    bounds: &'a Bounds,
    theta: Vec<f64>,
    r: Vec<f64>,
    cost: f64,
    lambda: f64,
}

impl Lm<'_, '_> {
    /// Tries up to 8 steps on the normal equations `a`, `g`, the damping raised after each that
    /// fails to lower the cost and lowered after the one that does, which is taken. Whether a
    /// step was taken and lowered the cost by more than a relative 1e-7.
    fn step(&mut self, a: &DMatrix<f64>, g: &DVector<f64>) -> bool {
        let p = self.theta.len();
        // A held coefficient takes no step, and the others' step is taken without it.
        let held: Vec<usize> = (0..p).filter(|&j| self.bounds.held(j)).collect();
        let mut g = g.clone();
        held.iter().for_each(|&j| g[j] = 0.0);
        for _ in 0..8 {
            let mut damped = a.clone();
            for i in 0..p {
                damped[(i, i)] += self.lambda * a[(i, i)].max(1e-12);
            }
            for &j in &held {
                damped.row_mut(j).fill(0.0);
                damped.column_mut(j).fill(0.0);
                damped[(j, j)] = 1.0;
            }
            let Some(step) = damped.lu().solve(&(-&g)) else {
                return false;
            };
            let mut next: Vec<f64> = self
                .theta
                .iter()
                .zip(step.iter())
                .map(|(x, d)| x + d)
                .collect();
            self.bounds.clamp(&mut next);
            let rn = self.oe.residuals(self.layout, &next);
            let cn = sum_sq(&rn);
            if cn.is_finite() && cn < self.cost {
                let gain = (self.cost - cn) / self.cost;
                (self.theta, self.r, self.cost) = (next, rn, cn);
                self.lambda = (self.lambda / 3.0).max(1e-9);
                return gain > MIN_GAIN;
            }
            self.lambda *= 4.0;
        }
        false
    }
}

/// Sum of squares.
fn sum_sq(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum::<f64>()
}

/// One column of the Jacobian, zero outside its segments (a nuisance parameter moves its own
/// run's residuals, a contrast the first run's too): each segment's start and values.
struct Column(Vec<(usize, Vec<f64>)>);

impl Column {
    fn dense(values: Vec<f64>) -> Column {
        Column(vec![(0, values)])
    }

    fn dot(&self, other: &Column) -> f64 {
        let mut s = 0.0;
        for (a0, a) in &self.0 {
            for (b0, b) in &other.0 {
                let (lo, hi) = ((*a0).max(*b0), (a0 + a.len()).min(b0 + b.len()));
                if lo < hi {
                    s += a[lo - a0..hi - a0]
                        .iter()
                        .zip(&b[lo - b0..hi - b0])
                        .map(|(x, y)| x * y)
                        .sum::<f64>();
                }
            }
        }
        s
    }

    /// The column's values, when it is one run of values as long as `like`'s and starting
    /// where it does (the model's coefficients' columns; a per-run nuisance column is not).
    fn dense_like(&self, like: &Column) -> Option<&[f64]> {
        match (&self.0[..], &like.0[..]) {
            ([(a0, a)], [(b0, b)]) if a0 == b0 && a.len() == b.len() => Some(a),
            _ => None,
        }
    }

    fn dot_dense(&self, r: &[f64]) -> f64 {
        self.0
            .iter()
            .map(|(a0, a)| a.iter().zip(&r[*a0..]).map(|(x, y)| x * y).sum::<f64>())
            .sum()
    }
}

/// Columns of `J^T J` summed side by side.
const BATCH: usize = 8;

/// `a`'s dot product with each of `bs` (at most [`BATCH`], each as long as `a`), every sum in
/// the order a single one takes (so the normal equations are the same to the last bit),
/// several at once: one sum is a chain of dependent additions, and the Gram matrix of the
/// Jacobian took a fifth of a fit's time so.
fn dots(a: &[f64], bs: &[&[f64]]) -> Vec<f64> {
    let n = a.len();
    let mut b: [&[f64]; BATCH] = [a; BATCH];
    for (k, x) in bs.iter().enumerate() {
        b[k] = &x[..n];
    }
    let b = b.map(|x| &x[..n]);
    let mut s = [-0.0f64; BATCH];
    for i in 0..n {
        let x = a[i];
        for k in 0..BATCH {
            s[k] += x * b[k][i];
        }
    }
    s[..bs.len()].to_vec()
}

/// The coefficients of a refined fit with one more parameter beside them, which the fit held
/// fixed (the command lag): see [`errors_with`].
pub struct Joint {
    /// The coefficients' standard errors, then the extra parameter's.
    pub stderr: Vec<f64>,
    /// Their correlations, the extra parameter's last (empty where `J^T J` is singular).
    pub correlation: Vec<Vec<f64>>,
    /// The joint Gauss-Newton step: the coefficients', the nuisance values' and the extra
    /// parameter's, last (empty where `J^T J` is singular).
    pub step: Vec<f64>,
}

/// The standard errors and correlations of the coefficients of `refined` (fitted on `oe`) and
/// of one more parameter held fixed in the fit, whose residuals' derivative is `extra` (the
/// command lag's): the coefficients' uncertainty then includes what they trade with it, as
/// MATLAB's `pem` reports for every free parameter of a grey-box model. The nuisance
/// parameters are marginalised out.
pub fn errors_with(
    oe: &OutputError,
    layout: &ParamLayout,
    refined: &Refined,
    extra: Vec<f64>,
) -> Joint {
    let m = layout.len();
    let theta = [refined.theta.as_slice(), &refined.nuisance].concat();
    let r = oe.residuals(layout, &theta);
    let mut jac = jacobian(oe, layout, &theta, &r, &|_| false);
    jac.push(Column::dense(extra));
    let (a, g) = normal_equations(&jac, &r);
    let last = jac.len() - 1;
    let step = a
        .clone()
        .lu()
        .solve(&g)
        .map_or(Vec::new(), |d| d.iter().map(|x| -x).collect());
    let (stderr, correlation) = standard_errors(&r, sum_sq(&r), a);
    let keep: Vec<usize> = (0..m).chain([last]).collect();
    let pick = |row: &[f64]| keep.iter().map(|&k| row[k]).collect::<Vec<f64>>();
    let correlation = if correlation.is_empty() {
        correlation
    } else {
        keep.iter().map(|&k| pick(&correlation[k])).collect()
    };
    Joint {
        stderr: pick(&stderr),
        correlation,
        step,
    }
}

/// The Gauss-Newton normal equations from the Jacobian's columns `jac`: `J^T J` and `J^T r`.
/// The rows are summed side by side, each entry in its own fixed order.
fn normal_equations(jac: &[Column], r: &[f64]) -> (DMatrix<f64>, DVector<f64>) {
    use rayon::prelude::*;
    let p = jac.len();
    let rows: Vec<Vec<f64>> = (0..p).into_par_iter().map(|i| gram_row(jac, i)).collect();
    let mut a = DMatrix::zeros(p, p);
    for (i, row) in rows.iter().enumerate() {
        for (j, x) in (i..p).zip(row) {
            (a[(i, j)], a[(j, i)]) = (*x, *x);
        }
    }
    let g = DVector::from_fn(p, |i, _| jac[i].dot_dense(r));
    (a, g)
}

/// Row `i` of `J^T J` from its diagonal on: column `i`'s dot product with each later one.
fn gram_row(jac: &[Column], i: usize) -> Vec<f64> {
    let p = jac.len();
    let own = jac[i].dense_like(&jac[i]);
    let mut out = Vec::with_capacity(p - i);
    while i + out.len() < p {
        let j = i + out.len();
        // Dense columns side by side, BATCH at a time (see `dots`); the others one by one.
        let batch: Vec<&[f64]> = (jac[j..].iter())
            .map_while(|c| c.dense_like(&jac[i]))
            .take(BATCH)
            .collect();
        if let (Some(own), true) = (own, batch.len() > 1) {
            out.extend(dots(own, &batch));
        } else {
            out.push(jac[i].dot(&jac[j]));
        }
    }
    out
}

/// Standard errors from `J^T J` (`a`) and the residuals `r` whose sum of squares is `cost`.
///
/// The velocity errors of a simulation are correlated from sample to sample (a fused
/// recording is smoothed, a model error persists), so n samples carry the information of
/// fewer: the variance grows by the AR(1) long-run factor (1 + rho) / (1 - rho) of the
/// residual's lag-1 autocorrelation.
fn standard_errors(r: &[f64], cost: f64, a: DMatrix<f64>) -> (Vec<f64>, Vec<Vec<f64>>) {
    let (n, p) = (r.len(), a.nrows());
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
    match a.try_inverse() {
        Some(inv) => {
            let sd: Vec<f64> = (0..p).map(|j| inv[(j, j)].max(0.0).sqrt()).collect();
            let corr = (0..p)
                .map(|i| {
                    (0..p)
                        .map(|j| {
                            let c = inv[(i, j)] / (sd[i] * sd[j]);
                            if c.is_finite() {
                                c.clamp(-1.0, 1.0)
                            } else {
                                0.0
                            }
                        })
                        .collect()
                })
                .collect();
            (sd.iter().map(|s| s2.sqrt() * s).collect(), corr)
        }
        None => (vec![f64::NAN; p], vec![]),
    }
}

/// Columns of d(residual)/d(theta_j) by forward differences, the perturbed models simulated
/// [`LANES`] at a time; then the nuisance parameters', each over the runs it moves.
/// The coefficients `skip` names get an empty column (zero).
fn jacobian(
    oe: &OutputError,
    layout: &ParamLayout,
    theta: &[f64],
    r0: &[f64],
    skip: &dyn Fn(usize) -> bool,
) -> Vec<Column> {
    let mut cols = model_columns(oe, layout, theta, r0, skip);
    cols.extend(nuisance_columns(oe, layout, theta, r0));
    cols
}

/// The Jacobian's columns of the nuisance parameters: a run's residuals, simulated alone. A
/// contrast moves the first run's residuals too, against its own, alike for every run of
/// its kind and DOF: that segment is simulated once per kind and DOF and shared.
fn nuisance_columns(
    oe: &OutputError,
    layout: &ParamLayout,
    theta: &[f64],
    r0: &[f64],
) -> Vec<Column> {
    use rayon::prelude::*;
    let (m, starts) = (layout.len(), oe.case_starts());
    // The segment of case `c`'s residuals when nuisance value `q` moves.
    let segment = |q: usize, c: usize| {
        let h = 1e-4 * theta[m + q].abs().max(1e-3);
        let mut t = theta.to_vec();
        t[m + q] += h;
        let rc = oe.case_residuals(layout, &t, c);
        let base = &r0[starts[c]..starts[c + 1]];
        let d: Vec<f64> = rc.iter().zip(base).map(|(a, b)| (a - b) / h).collect();
        (starts[c], d)
    };
    let first_run: Vec<_> = oe
        .nuisance
        .iter()
        .enumerate()
        .filter(|(q, n)| {
            n.kind.contrast()
                && !oe.nuisance[..*q]
                    .iter()
                    .any(|p| (p.kind, p.dof) == (n.kind, n.dof))
        })
        .map(|(q, n)| ((n.kind, n.dof), segment(q, 0)))
        .collect();
    oe.nuisance
        .par_iter()
        .enumerate()
        .map(|(q, n)| {
            let mut segs = vec![segment(q, n.case)];
            if let Some((_, s)) = first_run.iter().find(|(k, _)| *k == (n.kind, n.dof)) {
                segs.push(s.clone());
            }
            Column(segs)
        })
        .collect()
}

/// The model coefficients' columns of the Jacobian.
fn model_columns(
    oe: &OutputError,
    layout: &ParamLayout,
    theta: &[f64],
    r0: &[f64],
    skip: &dyn Fn(usize) -> bool,
) -> Vec<Column> {
    use rayon::prelude::*;
    let m = layout.len();
    let moved: Vec<usize> = (0..m).filter(|&j| !skip(j)).collect();
    let steps: Vec<f64> = (moved.iter())
        .map(|&j| 1e-4 * theta[j].abs().max(1e-2))
        .collect();
    let perturbed: Vec<Vec<f64>> = (moved.iter().zip(&steps))
        .map(|(&j, h)| {
            let mut t = theta.to_vec();
            t[j] += h;
            t
        })
        .collect();
    let columns: Vec<Column> = perturbed
        .par_chunks(LANES)
        .enumerate()
        .flat_map_iter(|(c, chunk)| {
            let refs: Vec<&[f64]> = chunk.iter().map(Vec::as_slice).collect();
            let steps = &steps;
            oe.residuals_many(layout, &refs)
                .into_iter()
                .enumerate()
                .map(move |(q, rj)| {
                    let h = steps[c * LANES + q];
                    Column::dense(rj.iter().zip(r0).map(|(a, b)| (a - b) / h).collect())
                })
        })
        .collect();
    let mut out: Vec<Column> = (0..m).map(|_| Column(Vec::new())).collect();
    for (&j, c) in moved.iter().zip(columns) {
        out[j] = c;
    }
    out
}
