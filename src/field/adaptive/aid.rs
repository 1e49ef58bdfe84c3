//! The adaptive identifier (seed 004 section 5), its persistence-of-excitation check and the
//! forward simulation that validates it.
//!
//! Identifier plant, integrated alongside the data: `M(th) a_hat = -k M(th) dnu - R(nu, 0) th`
//! with `dnu = nu_hat - nu`; update law `th' = Gamma R(nu, a_hat)^T dnu`. With the true `M`,
//! `M dnu' = -k M(th) dnu - R(nu, a_hat) (th - th*)`, and `V = dnu'M dnu/2 +
//! (th - th*)'Gamma^-1 (th - th*)/2` has `V' = -k dnu'M(th)dnu <= 0` for every positive
//! multiple `th*` of the truth: no acceleration is needed, and under persistent excitation
//! `th` converges to the line of true parameter vectors.

use super::{Actuators, P, Regressor, Sample, apply, down, regressor};
use nalgebra::{DMatrix, SymmetricEigen};
use serde::{Deserialize, Serialize};

/// A record the identifier runs on: times, body velocities, roll and pitch, fin angles and
/// propeller speed per sample.
#[derive(Debug, Clone)]
pub struct Record {
    pub name: String,
    pub t: Vec<f64>,
    pub nu: Vec<[f64; 6]>,
    pub roll_pitch: Vec<[f64; 2]>,
    pub fins: Vec<Vec<f64>>,
    pub prop: Vec<f64>,
}

impl Record {
    fn sample(&self, k: usize, acc: [f64; 6]) -> Sample<'_> {
        Sample {
            nu: self.nu[k],
            acc,
            down: down(self.roll_pitch[k][0], self.roll_pitch[k][1]),
            fins: &self.fins[k],
            prop: self.prop[k],
        }
    }

    /// Accelerations by central differences of the (fused, smooth) velocities: for the
    /// excitation check only, never for the identification.
    pub fn accelerations(&self) -> Vec<[f64; 6]> {
        let n = self.t.len();
        (0..n)
            .map(|k| {
                let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
                let dt = (self.t[b] - self.t[a]).max(1e-9);
                std::array::from_fn(|i| (self.nu[b][i] - self.nu[a][i]) / dt)
            })
            .collect()
    }
}

/// The identifier's gains: the velocity error's rate `k` (1/s) and the adaptation gain
/// `gamma` in `Gamma = gamma diag(s_j^2) / mean_j(s_j^2 |R_j|^2)`, `s_j` each parameter's
/// typical size and `|R_j|^2` its regressor column's mean square over the record: relative
/// changes of every parameter adapt alike, and one number sets the speed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gains {
    pub velocity: f64,
    pub adaptation: f64,
}

/// The parameter estimate through the record (thinned), and the final one.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Run {
    pub t: Vec<f64>,
    pub theta: Vec<Vec<f64>>,
    pub last: Vec<f64>,
    /// RMS of the velocity error per DOF over the last quarter of the record.
    pub velocity_error_rms: [f64; 6],
}

/// Mean square of each regressor column over `rec` (with measured accelerations).
pub fn column_power(act: &Actuators, rec: &Record) -> Vec<f64> {
    let acc = rec.accelerations();
    let mut p = [0.0; P];
    for (k, a) in acc.iter().enumerate() {
        let r = regressor(act, &rec.sample(k, *a));
        for (j, pj) in p.iter_mut().enumerate() {
            *pj += (0..6).map(|i| r[i][j] * r[i][j]).sum::<f64>();
        }
    }
    p.iter()
        .map(|x| (x / acc.len().max(1) as f64).max(1e-12))
        .collect()
}

/// Runs the identifier over `rec` from `theta0`, one Heun step per sample interval (the paper
/// used Euler steps on its logs). Masses are kept above 1 % of their start (a projection that keeps
/// the identifier plant invertible).
pub fn identify(
    act: &Actuators,
    rec: &Record,
    theta0: &[f64],
    g: Gains,
    power: &[f64],
    size: &[f64],
) -> Run {
    let norm = size.iter().zip(power).map(|(s, p)| s * s * p).sum::<f64>() / P as f64;
    let gamma: Vec<f64> = size.iter().map(|s| g.adaptation * s * s / norm).collect();
    let floor: Vec<f64> = theta0[..6].iter().map(|m| 0.01 * m.abs()).collect();
    let mut th = theta0.to_vec();
    let mut nu_hat = rec.nu[0];
    let n = rec.t.len();
    let stride = n.div_ceil(600).max(1);
    let mut out = Run {
        t: vec![],
        theta: vec![],
        last: vec![],
        velocity_error_rms: [0.0; 6],
    };
    let mut sq = [0.0; 6];
    let mut count = 0usize;
    for k in 0..n.saturating_sub(1) {
        if crate::core::interrupt::requested() {
            break;
        }
        let dt = rec.t[k + 1] - rec.t[k];
        // Heun's method over the sample interval, the commands of sample k held through it
        // and the measured state taken at both ends: the identifier plant's own truncation
        // error would otherwise correlate with the regressor and bias the estimate.
        let dnu: [f64; 6] = std::array::from_fn(|i| nu_hat[i] - rec.nu[k][i]);
        let (a0, r0) = step_terms(act, &rec.sample(k, [0.0; 6]), &th, &dnu, g.velocity);
        let pred: [f64; 6] = std::array::from_fn(|i| nu_hat[i] + dt * a0[i]);
        let dnu1: [f64; 6] = std::array::from_fn(|i| pred[i] - rec.nu[k + 1][i]);
        let end = Sample {
            nu: rec.nu[k + 1],
            acc: [0.0; 6],
            down: down(rec.roll_pitch[k + 1][0], rec.roll_pitch[k + 1][1]),
            fins: &rec.fins[k],
            prop: rec.prop[k],
        };
        let (a1, r1) = step_terms(act, &end, &th, &dnu1, g.velocity);
        for j in 0..P {
            let grad: f64 = (0..6).map(|i| r0[i][j] * dnu[i] + r1[i][j] * dnu1[i]).sum();
            th[j] += 0.5 * dt * gamma[j] * grad;
        }
        for i in 0..6 {
            th[i] = th[i].max(floor[i]);
            nu_hat[i] += 0.5 * dt * (a0[i] + a1[i]);
        }
        if 4 * k >= 3 * n {
            count += 1;
            for i in 0..6 {
                sq[i] += dnu[i] * dnu[i];
            }
        }
        if k % stride == 0 {
            out.t.push(rec.t[k]);
            out.theta.push(th.clone());
        }
    }
    out.velocity_error_rms = std::array::from_fn(|i| (sq[i] / count.max(1) as f64).sqrt());
    out.last = th;
    out
}

/// The identifier plant's acceleration at sample `s` (whose acceleration is zero) with
/// velocity error `dnu`, and the regressor at that acceleration (the acceleration enters only
/// the mass columns' diagonal).
fn step_terms(
    act: &Actuators,
    s: &Sample,
    th: &[f64],
    dnu: &[f64; 6],
    k: f64,
) -> ([f64; 6], Regressor) {
    let mut r = regressor(act, s);
    let f = apply(&r, th);
    let a: [f64; 6] = std::array::from_fn(|i| -k * dnu[i] - f[i] / th[i]);
    for i in 0..6 {
        r[i][i] += a[i];
    }
    (a, r)
}

/// `theta` scaled so that parameter `j` takes the value `known`.
pub fn scaled(theta: &[f64], j: usize, known: f64) -> Vec<f64> {
    let c = known / theta[j];
    theta.iter().map(|x| x * c).collect()
}

/// The excitation of a window: the regressor's Gram matrix with columns equilibrated, its
/// eigenvalues relative to the largest, with the direction of the estimate (the model's own
/// nullspace: scale) projected off.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Excitation {
    pub t0: f64,
    pub t1: f64,
    /// Smallest eigenvalue over the largest, off the nullspace.
    pub min_ratio: f64,
    /// Smallest eigenvalue over the largest along the estimate's direction (near 0 when the
    /// model explains the data: that is the scale).
    pub nullspace_ratio: f64,
    /// The three least excited parameter combinations off the nullspace, least first: the
    /// ratio and the leading components (parameter index and weight); those below the
    /// threshold the data cannot identify.
    pub weakest: Vec<(f64, Vec<(usize, f64)>)>,
    pub threshold: f64,
}

/// The excitation of samples `range` of `rec` (measured accelerations), the estimate `theta`
/// giving the nullspace direction.
pub fn excitation(
    act: &Actuators,
    rec: &Record,
    acc: &[[f64; 6]],
    range: std::ops::Range<usize>,
    theta: &[f64],
    threshold: f64,
) -> Excitation {
    let mut gram = DMatrix::<f64>::zeros(P, P);
    for k in range.clone() {
        let r = regressor(act, &rec.sample(k, acc[k]));
        let m = DMatrix::from_fn(6, P, |i, j| r[i][j]);
        gram += m.transpose() * m;
    }
    let scale: Vec<f64> = (0..P).map(|j| gram[(j, j)].sqrt().max(1e-12)).collect();
    let g = DMatrix::from_fn(P, P, |i, j| gram[(i, j)] / (scale[i] * scale[j]));
    // The nullspace direction in equilibrated coordinates, and the projector off it.
    let mut z = nalgebra::DVector::from_fn(P, |j, _| theta[j] * scale[j]);
    z /= z.norm().max(1e-300);
    let proj = DMatrix::<f64>::identity(P, P) - &z * z.transpose();
    let along = (z.transpose() * &g * &z)[(0, 0)];
    let off = &proj * &g * &proj;
    let eig =
        crate::core::numerics::symmetric_eigen(off.clone()).unwrap_or_else(|| SymmetricEigen {
            eigenvalues: nalgebra::DVector::zeros(P),
            eigenvectors: DMatrix::identity(P, P),
        });
    let max = eig.eigenvalues.max().max(1e-300);
    let mut order: Vec<usize> = (0..P).collect();
    order.sort_by(|a, b| eig.eigenvalues[*a].total_cmp(&eig.eigenvalues[*b]));
    // The smallest eigenvalue is the projected-off direction itself (zero): skip it.
    let rest = &order[1..];
    let weakest = rest
        .iter()
        .take(3)
        .map(|&i| {
            let v = eig.eigenvectors.column(i);
            let mut c: Vec<(usize, f64)> = (0..P)
                .map(|j| (j, v[j]))
                .filter(|(_, x)| x.abs() > 0.3)
                .collect();
            c.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
            (eig.eigenvalues[i] / max, c)
        })
        .collect();
    Excitation {
        t0: rec.t[range.start],
        t1: rec.t[range.end.saturating_sub(1)],
        min_ratio: eig.eigenvalues[rest[0]] / max,
        nullspace_ratio: along / max,
        weakest,
        threshold,
    }
}

/// The model `theta` simulated on `rec` from its first measured state under its commands
/// (RK4 per sample, commands held, roll and pitch integrated from the simulated rates).
/// None when it diverges.
pub fn simulate(act: &Actuators, rec: &Record, theta: &[f64]) -> Option<Vec<[f64; 6]>> {
    let n = rec.t.len();
    let mut x: [f64; 8] = std::array::from_fn(|i| {
        if i < 6 {
            rec.nu[0][i]
        } else {
            rec.roll_pitch[0][i - 6]
        }
    });
    let mut out = Vec::with_capacity(n);
    let f = |x: &[f64; 8], k: usize| -> [f64; 8] {
        let s = Sample {
            nu: std::array::from_fn(|i| x[i]),
            acc: [0.0; 6],
            down: down(x[6], x[7]),
            fins: &rec.fins[k],
            prop: rec.prop[k],
        };
        let r = apply(&regressor(act, &s), theta);
        let (phi, th) = (x[6], x[7]);
        let (p, q, rr) = (x[3], x[4], x[5]);
        std::array::from_fn(|i| match i {
            0..6 => -r[i] / theta[i],
            6 => p + (q * phi.sin() + rr * phi.cos()) * th.tan(),
            _ => q * phi.cos() - rr * phi.sin(),
        })
    };
    for k in 0..n {
        out.push(std::array::from_fn(|i| x[i]));
        if k + 1 == n {
            break;
        }
        let h = rec.t[k + 1] - rec.t[k];
        let add = |a: &[f64; 8], b: &[f64; 8], s: f64| -> [f64; 8] {
            std::array::from_fn(|i| a[i] + s * b[i])
        };
        let k1 = f(&x, k);
        let k2 = f(&add(&x, &k1, h / 2.0), k);
        let k3 = f(&add(&x, &k2, h / 2.0), k);
        let k4 = f(&add(&x, &k3, h), k);
        x = std::array::from_fn(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        if x.iter().any(|v| !v.is_finite() || v.abs() > 1e3) {
            return None;
        }
    }
    Some(out)
}

/// Mean absolute error per DOF of `sim` against the record's velocities.
pub fn mae(rec: &Record, sim: &[[f64; 6]]) -> [f64; 6] {
    std::array::from_fn(|i| {
        rec.nu
            .iter()
            .zip(sim)
            .map(|(m, s)| (m[i] - s[i]).abs())
            .sum::<f64>()
            / sim.len().max(1) as f64
    })
}
