//! Least squares on an integrated regressor, and recursive least squares with a forgetting
//! factor (seed 000 sections 3 and 3.1). A model linear in its parameters,
//! `dy_i/dt = sum_j theta_ij phi_ij(x, delta)`, is integrated between two sample times, so no
//! acceleration is needed: `y_i(t_k) - y_i(t_{k-m}) = F_k theta_i` with
//! `F_k = integral of phi over [t_{k-m}, t_k]` (eq. 12-18, the trapezoidal rule on the
//! samples). LS solves the stacked windows (eq. 16); RLS updates the estimate window by
//! window (eq. 19), forgetting old windows by `lambda` so that it follows a parameter that
//! changes during the run.

pub mod report;
pub mod stage;
#[cfg(test)]
mod twin_tests;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// One equation: the state it differentiates and the regressor's columns, sampled; a column
/// that is `held` (a command, constant until the next sample) is integrated as a step, the
/// others (measured, continuous) by the trapezoidal rule.
#[derive(Debug, Clone)]
pub struct Equation {
    pub y: Vec<f64>,
    pub phi: Vec<Vec<f64>>,
    pub held: Vec<bool>,
}

/// The windows of one run for one equation: `Y` (increments) and `F` (integrated regressor
/// rows), and the time at each window's end.
#[derive(Debug, Clone, Default)]
pub struct Windows {
    pub t: Vec<f64>,
    pub y: Vec<f64>,
    pub f: Vec<Vec<f64>>,
}

/// Windows of `m` samples (non-overlapping) over a run sampled at `t`.
pub fn windows(t: &[f64], eq: &Equation, m: usize) -> Windows {
    let m = m.max(1);
    let mut w = Windows::default();
    let mut k0 = 0usize;
    while k0 + m < t.len() {
        let k1 = k0 + m;
        let row: Vec<f64> = eq
            .phi
            .iter()
            .zip(&eq.held)
            .map(|(c, held)| {
                (k0..k1)
                    .map(|k| {
                        let v = if *held { c[k] } else { 0.5 * (c[k] + c[k + 1]) };
                        v * (t[k + 1] - t[k])
                    })
                    .sum()
            })
            .collect();
        w.t.push(t[k1]);
        w.y.push(eq.y[k1] - eq.y[k0]);
        w.f.push(row);
        k0 = k1;
    }
    w
}

/// A least-squares estimate with standard errors and the residual's variance.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Estimate {
    pub theta: Vec<f64>,
    pub stderr: Vec<f64>,
    pub sigma2: f64,
    pub n: usize,
}

/// Eq. 16 with unit weights: `theta = (F'F)^-1 F'Y` over every window of `ws`.
pub fn least_squares(ws: &[&Windows]) -> Option<Estimate> {
    let d = ws.iter().find_map(|w| w.f.first().map(Vec::len))?;
    let n: usize = ws.iter().map(|w| w.y.len()).sum();
    if n <= d {
        return None;
    }
    let rows: Vec<f64> = ws
        .iter()
        .flat_map(|w| w.f.iter().flatten().copied())
        .collect();
    let a = DMatrix::from_row_slice(n, d, &rows);
    let y = DVector::from_iterator(n, ws.iter().flat_map(|w| w.y.iter().copied()));
    // Columns scaled to unit norm before the normal equations: the integrated regressors of
    // an angle and of a rate differ by orders of magnitude.
    let scale: Vec<f64> = (0..d)
        .map(|j| a.column(j).norm().max(f64::MIN_POSITIVE))
        .collect();
    let mut s = a.clone();
    for (j, sc) in scale.iter().enumerate() {
        s.column_mut(j).unscale_mut(*sc);
    }
    let chol = (s.transpose() * &s).cholesky()?;
    let z = chol.solve(&(s.transpose() * &y));
    let theta: Vec<f64> = z.iter().zip(&scale).map(|(z, s)| z / s).collect();
    let resid = &y - &a * DVector::from_column_slice(&theta);
    let sigma2 = resid.norm_squared() / (n - d) as f64;
    let inv = chol.inverse();
    let stderr = (0..d)
        .map(|j| (sigma2 * inv[(j, j)]).sqrt() / scale[j])
        .collect();
    Some(Estimate {
        theta,
        stderr,
        sigma2,
        n,
    })
}

/// The one-step prediction errors `Y_k - F_k theta` (eq. 10, 15).
pub fn prediction_errors(w: &Windows, theta: &[f64]) -> Vec<f64> {
    w.y.iter()
        .zip(&w.f)
        .map(|(y, f)| y - f.iter().zip(theta).map(|(a, b)| a * b).sum::<f64>())
        .collect()
}

/// The RLS trace of one equation: the estimate after each window.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Trace {
    pub t: Vec<f64>,
    pub theta: Vec<Vec<f64>>,
}

/// Eq. 19 over the windows of `w` from `theta0`, with forgetting factor `lambda` and
/// `P_0 = p0 diag(1 / mean F_j^2)` (scale-free: `p0` is the prior's weight in windows).
pub fn recursive(w: &Windows, theta0: &[f64], lambda: f64, p0: f64) -> Trace {
    let d = theta0.len();
    let n = w.f.len().max(1) as f64;
    let mut p = DMatrix::<f64>::zeros(d, d);
    for j in 0..d {
        let ms = w.f.iter().map(|r| r[j] * r[j]).sum::<f64>() / n;
        p[(j, j)] = p0 / ms.max(f64::MIN_POSITIVE);
    }
    let mut theta = DVector::from_column_slice(theta0);
    let mut out = Trace {
        t: Vec::new(),
        theta: Vec::new(),
    };
    for (k, row) in w.f.iter().enumerate() {
        let f = DVector::from_column_slice(row);
        let pf = &p * &f;
        let denom = lambda + f.dot(&pf);
        let gamma = &pf / denom;
        let e = w.y[k] - f.dot(&theta);
        theta += &gamma * e;
        p = (&p - &gamma * pf.transpose()) / lambda;
        // Symmetrised against round-off over thousands of updates.
        p = 0.5 * (&p + p.transpose());
        out.t.push(w.t[k]);
        out.theta.push(theta.iter().copied().collect());
    }
    out
}

/// The first time after `t_step` from which `trace` stays within `tol` of `target`, if it
/// settles at all.
pub fn settling_time(t: &[f64], x: &[f64], t_step: f64, target: f64, tol: f64) -> Option<f64> {
    let mut settled: Option<f64> = None;
    for (ti, xi) in t.iter().zip(x) {
        if *ti < t_step {
            continue;
        }
        if (xi - target).abs() <= tol {
            settled.get_or_insert(*ti);
        } else {
            settled = None;
        }
    }
    settled.map(|s| s - t_step)
}

/// Recursive least squares (seed 000 eq. 19).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rls {
    /// lambda in (0, 1]: the memory is `window / (1 - lambda)` seconds.
    pub forgetting: f64,
    /// Weight of the prior (theta_0 = 0) in windows: `P_0 = p0 diag(1 / mean F_j^2)`.
    #[serde(default = "thousand")]
    pub p0: f64,
}

fn thousand() -> f64 {
    1e3
}

/// One equation's least-squares estimate.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EquationFit {
    pub state: String,
    pub terms: Vec<String>,
    pub names: Vec<String>,
    #[serde(flatten)]
    pub estimate: Estimate,
}

/// One run's RLS traces, per equation (thinned to at most 500 points).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunTrace {
    pub run: String,
    pub traces: Vec<Trace>,
}

/// The one-step prediction of one state on one run, and its error's autocorrelation.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Prediction {
    pub run: String,
    pub state: String,
    pub t: Vec<f64>,
    pub measured: Vec<f64>,
    pub predicted: Vec<f64>,
    pub error: Vec<f64>,
    pub lag_s: Vec<f64>,
    pub acf: Vec<f64>,
    /// 95 % band of a white sequence, `1.96 / sqrt(N)`.
    pub band: f64,
}

/// What `integrated` stores in `detail`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Detail {
    pub window_s: f64,
    pub equations: Vec<EquationFit>,
    pub rls: Option<Rls>,
    pub traces: Vec<RunTrace>,
    pub predictions: Vec<Prediction>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::rng::Rng;

    /// A two-state linear system (w, q) with a pitch angle and a PRBS input, Euler at 1 ms,
    /// sampled at 10 Hz; `b_q` steps from `bq0` to `bq1` at `t_step`.
    fn system(n_s: f64, bq0: f64, bq1: f64, t_step: f64, noise: f64) -> (Vec<f64>, Vec<Equation>) {
        let mut rng = Rng::new(5);
        let (mut w, mut q, mut th) = (0.0, 0.0, 0.0);
        let mut delta = 0.1;
        let (mut t, mut ws, mut qs, mut ths, mut ds) = (vec![], vec![], vec![], vec![], vec![]);
        let steps = (n_s * 1000.0) as usize;
        for k in 0..=steps {
            let time = k as f64 * 1e-3;
            if k % 2000 == 0 && rng.uniform() < 0.5 {
                delta = -delta;
            }
            if k % 100 == 0 {
                t.push(time);
                ws.push(w + noise * rng.normal());
                qs.push(q + noise * rng.normal());
                ths.push(th);
                ds.push(delta);
            }
            let bq = if time < t_step { bq0 } else { bq1 };
            let dw = -0.7 * w + 0.9 * q + 0.4 * delta;
            let dq = 0.3 * w - 1.1 * q - 0.5 * th + bq * delta;
            w += 1e-3 * dw;
            q += 1e-3 * dq;
            th += 1e-3 * q;
        }
        let phi = vec![ws.clone(), qs.clone(), ths, ds];
        let held = vec![false, false, false, true];
        let eqs = vec![
            Equation {
                y: ws,
                phi: phi.clone(),
                held: held.clone(),
            },
            Equation { y: qs, phi, held },
        ];
        (t, eqs)
    }

    #[test]
    fn noise_free_integrated_least_squares_recovers_the_parameters() {
        let (t, eqs) = system(300.0, -0.8, -0.8, 1e9, 0.0);
        let truth = [[-0.7, 0.9, 0.0, 0.4], [0.3, -1.1, -0.5, -0.8]];
        for (eq, tr) in eqs.iter().zip(truth) {
            let w = windows(&t, eq, 1);
            let est = least_squares(&[&w]).unwrap();
            for (x, y) in est.theta.iter().zip(tr) {
                // Euler at 1 ms against the trapezoid at 0.1 s: agreement to a few 1e-3.
                assert!((x - y).abs() < 5e-3, "{:?} vs {tr:?}", est.theta);
            }
        }
    }

    #[test]
    fn rls_with_forgetting_tracks_a_step_and_without_it_does_not() {
        let (t, eqs) = system(600.0, -0.8, -0.5, 300.0, 0.002);
        // Windows of 0.5 s, lambda 0.975: a memory of 40 windows, 20 s.
        let w = windows(&t, &eqs[1], 5);
        let zero = [0.0; 4];
        let tr = recursive(&w, &zero, 0.975, 1e3);
        let bq: Vec<f64> = tr.theta.iter().map(|th| th[3]).collect();
        let before = bq[tr.t.iter().position(|x| *x >= 290.0).unwrap()];
        assert!((before + 0.8).abs() < 0.05, "before the step {before}");
        // Within 1/6 of the step for good within three memory lengths.
        let settle = settling_time(&tr.t, &bq, 300.0, -0.5, 0.05).expect("settles");
        assert!(settle < 60.0, "tracked the step in {settle} s");
        // Without forgetting, a minute after the step it still averages the old value in.
        let frozen = recursive(&w, &zero, 1.0, 1e3);
        let k = frozen.t.iter().position(|x| *x >= 360.0).unwrap();
        let at = frozen.theta[k][3];
        assert!(
            (at + 0.5).abs() > 0.1,
            "without forgetting {at} a minute after the step"
        );
    }
}
