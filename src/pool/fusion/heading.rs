//! The heading filter: yaw, yaw rate and gyro bias smoothed from an IMU's or a navigation
//! log's yaw and rate (either may be missing).

use super::kalman::{Filter, Mat, Vector, white_accel_and};
use super::{Noise, wrap_pi};
use crate::pool::import::csvlog::Log;
use nalgebra::{SMatrix, SVector};

/// Smoothed heading, yaw rate and gyro bias at the IMU's times: (t, psi, var psi, r, var r, bias).
pub(super) struct Heading {
    pub(super) t: Vec<f64>,
    pub(super) psi: Vec<f64>,
    pub(super) psi_var: Vec<f64>,
    pub(super) r: Vec<f64>,
    pub(super) r_var: Vec<f64>,
    pub(super) bias: f64,
}

/// A heading source: absolute yaw and/or the rate the yaw turns at, from a gyro, at times `t`
/// (either may be absent).
pub(super) struct HeadingInput<'a> {
    t: &'a [f64],
    yaw: Option<&'a [f64]>,
    gyro: Option<Vec<f64>>,
    /// Roll, pitch and q where the log has them: the heading's rate is turned into the body's
    /// yaw rate r with them.
    attitude: Option<[&'a [f64]; 3]>,
}

/// Columns of a log the heading reads: yaw, and roll, pitch, q, r for its rate.
struct Columns {
    yaw: usize,
    roll: usize,
    pitch: usize,
    q: usize,
    r: usize,
}

/// The IMU's columns (roll, pitch, yaw, p, q, r, ...) and the navigation log's (u, v, w,
/// roll, pitch, yaw, p, q, r).
const IMU: Columns = Columns {
    roll: 0,
    pitch: 1,
    yaw: 2,
    q: 4,
    r: 5,
};
const NAV: Columns = Columns {
    roll: 3,
    pitch: 4,
    yaw: 5,
    q: 7,
    r: 8,
};

/// Beyond this pitch the yaw angle is ill-defined (gimbal lock) and a gyro sample says
/// nothing of the heading's rate.
const MAX_PITCH_RAD: f64 = 1.37;

impl<'a> HeadingInput<'a> {
    /// From the IMU when it has yaw or a z gyro, else from the navigation log's.
    pub(super) fn of(imu: Option<&'a Log>, nav: Option<&'a Log>) -> Option<HeadingInput<'a>> {
        let from = |l: &'a Log, c: &Columns| {
            let attitude = match (l.col(c.roll), l.col(c.pitch), l.col(c.q)) {
                (Some(phi), Some(theta), Some(q)) => Some([phi, theta, q]),
                _ => None,
            };
            (l.has(c.yaw) || l.has(c.r)).then(|| HeadingInput {
                t: &l.t,
                yaw: l.col(c.yaw),
                gyro: l.col(c.r).map(|r| heading_rate(r, attitude)),
                attitude,
            })
        };
        imu.and_then(|l| from(l, &IMU))
            .or_else(|| nav.and_then(|l| from(l, &NAV)))
    }
}

/// The rate the heading turns at, from the body rates: (q sin(phi) + r cos(phi)) / cos(theta)
/// where a row has roll, pitch and q (Fossen 2011 eq. 2.29), else r. A vehicle that rolls
/// and pitches turns its heading at another rate than r, and the filter, fed r, took the
/// difference for gyro bias; beyond [`MAX_PITCH_RAD`] the row is left out.
fn heading_rate(r: &[f64], attitude: Option<[&[f64]; 3]>) -> Vec<f64> {
    let Some([phi, theta, q]) = attitude else {
        return r.to_vec();
    };
    (0..r.len())
        .map(|k| {
            let (ph, th, qk) = (phi[k], theta[k], q[k]);
            if !(ph.is_finite() && th.is_finite() && qk.is_finite()) {
                r[k]
            } else if th.abs() > MAX_PITCH_RAD {
                f64::NAN
            } else {
                (qk * ph.sin() + r[k] * ph.cos()) / th.cos()
            }
        })
        .collect()
}

/// Random-walk density of the gyro bias, (rad/s)^2 / s.
const GYRO_BIAS_Q: f64 = 1e-8;

/// The heading filter at the first sample: yaw and rate as measured (yaw barely known when
/// not measured), bias within a few hundredths of a rad/s.
fn initial(yaw0: f64, gyro0: f64, sy: f64, motion: Motion) -> Filter<3> {
    let finite_or = |x: f64, d: f64| if x.is_finite() { x } else { d };
    let x0 = Vector::<3>::new(finite_or(yaw0, 0.0), finite_or(gyro0, 0.0), 0.0);
    let psi_var0 = if yaw0.is_finite() { sy * sy } else { 10.0 };
    let third_var0 = match motion {
        Motion::Rate(_) => 0.03f64.powi(2),
        Motion::Accel(_) => 1.0,
    };
    Filter::<3>::new(
        x0,
        Mat::<3>::from_diagonal(&Vector::<3>::new(psi_var0, 0.1, third_var0)),
    )
}

/// How the yaw rate moves between samples.
///
/// `Rate(q)`: a constant rate driven by white yaw acceleration of density `q` (rad^2/s^3); the
/// third state is the gyro's bias. `Accel(q)`: the rate has a yaw acceleration of its own,
/// driven by white yaw jerk of density `q` (rad^2/s^5); the third state is that acceleration.
/// The second is for a heading without a gyro (no bias to carry): there the rate rests on the
/// model alone, and a vehicle's turns are smooth (the thrusters' moment changes its yaw
/// acceleration, not its rate, at once). Under `Rate` the likelihood took turning for noise
/// in the rate and stated its error at about twice the truth on the twin's navigation logs
/// (1.9-2.4 times, with a tenth of a degree of yaw noise chosen where the log has half a
/// degree); under `Accel`, 0.7-1.2 times.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Motion {
    Rate(f64),
    Accel(f64),
}

/// A step of `dt` under `motion`; the bias a slow random walk.
fn predict(f: &mut Filter<3>, dt: f64, motion: Motion) {
    let (fm, q) = match motion {
        Motion::Rate(q_r) => (
            Mat::<3>::new(1.0, dt, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
            white_accel_and(q_r, dt, GYRO_BIAS_Q * dt),
        ),
        Motion::Accel(j) => (
            Mat::<3>::new(1.0, dt, dt * dt / 2.0, 0.0, 1.0, dt, 0.0, 0.0, 1.0),
            Mat::<3>::from(white_jerk(j, dt)),
        ),
    };
    f.predict(fm, Vector::<3>::zeros(), q);
}

/// Process noise of a position-velocity-acceleration triple driven by white jerk of density
/// `q` (row-major).
fn white_jerk(q: f64, dt: f64) -> [[f64; 3]; 3] {
    let p = |n: i32, d: f64| q * dt.powi(n) / d;
    [
        [p(5, 20.0), p(4, 8.0), p(3, 6.0)],
        [p(4, 8.0), p(3, 3.0), p(2, 2.0)],
        [p(3, 6.0), p(2, 2.0), p(1, 1.0)],
    ]
}

/// Minus the log likelihood (less a constant) of a yaw measurement under the prediction.
fn yaw_innovation_cost(f: &Filter<3>, yaw: f64, sy: f64) -> f64 {
    let (x, p) = f.state();
    let s = p[(0, 0)] + sy * sy;
    let nu = wrap_pi(yaw - x[0]);
    0.5 * (s.ln() + nu * nu / s)
}

/// A yaw measurement of noise `sy`, its innovation wrapped to (-pi, pi].
fn update_yaw(f: &mut Filter<3>, yaw: f64, sy: f64) {
    let h = SMatrix::<f64, 1, 3>::new(1.0, 0.0, 0.0);
    let wrap = |v: &mut SVector<f64, 1>| v[0] = wrap_pi(v[0]);
    f.update(
        SVector::<f64, 1>::new(yaw),
        h,
        SMatrix::<f64, 1, 1>::new(sy * sy),
        f64::INFINITY,
        wrap,
    );
}

/// A gyro measurement of noise `sg`: the rate plus the bias.
fn update_gyro(f: &mut Filter<3>, gyro: f64, sg: f64) {
    let h = SMatrix::<f64, 1, 3>::new(0.0, 1.0, 1.0);
    f.update(
        SVector::<f64, 1>::new(gyro),
        h,
        SMatrix::<f64, 1, 1>::new(sg * sg),
        f64::INFINITY,
        |_| {},
    );
}

/// The smoothed heading at the times of the filter's steps, which are taken only at
/// increasing times.
fn smoothed(f: &Filter<3>, times: &[f64], motion: Motion) -> Heading {
    let sm = f.smooth();
    let mut t = Vec::with_capacity(times.len());
    for (k, &tk) in times.iter().enumerate() {
        if k == 0 || tk > times[k - 1] {
            t.push(tk);
        }
    }
    Heading {
        t,
        psi: sm.iter().map(|(x, _)| x[0]).collect(),
        psi_var: sm.iter().map(|(_, p)| p[(0, 0)]).collect(),
        r: sm.iter().map(|(x, _)| x[1]).collect(),
        r_var: sm.iter().map(|(_, p)| p[(1, 1)]).collect(),
        bias: match motion {
            Motion::Rate(_) => sm.last().map_or(0.0, |(x, _)| x[2]),
            Motion::Accel(_) => 0.0,
        },
    }
}

/// The heading filter with yaw noise `sy` and the rate moving as `motion`, and the log
/// likelihood of its yaw innovations.
fn heading_with(src: &HeadingInput, sy: f64, sg: f64, motion: Motion) -> (Heading, f64) {
    let len = src.t.len();
    let nan = vec![f64::NAN; len];
    let (yaw, gyro) = (src.yaw.unwrap_or(&nan), src.gyro.as_deref().unwrap_or(&nan));
    let mut loglik = 0.0;
    let mut f = initial(yaw[0], gyro[0], sy, motion);
    for k in 0..len {
        if k > 0 {
            let dt = src.t[k] - src.t[k - 1];
            if dt <= 0.0 {
                continue;
            }
            predict(&mut f, dt, motion);
        }
        if yaw[k].is_finite() {
            if k > 0 {
                loglik -= yaw_innovation_cost(&f, yaw[k], sy);
            }
            update_yaw(&mut f, yaw[k], sy);
        }
        if gyro[k].is_finite() {
            update_gyro(&mut f, gyro[k], sg);
        }
    }
    (smoothed(&f, src.t, motion), loglik)
}

/// The heading's rate psi_dot turned into the body's yaw rate, r = (psi_dot cos(theta) -
/// q sin(phi)) / cos(phi), at the rows whose roll, pitch and q are known (a vehicle rolled
/// past 78 deg keeps psi_dot); the rate's variance scaled with it. Without them, `h` as it is.
fn body_rate(mut h: Heading, src: &HeadingInput) -> Heading {
    let (t, Some([phi, theta, q])) = (src.t, src.attitude) else {
        return h;
    };
    for (k, &tk) in h.t.iter().enumerate() {
        let i = t.partition_point(|&x| x < tk).min(t.len() - 1);
        let (ph, th, qi) = (phi[i], theta[i], q[i]);
        if !(ph.is_finite() && th.is_finite() && qi.is_finite()) || ph.cos() < 0.2 {
            continue;
        }
        let scale = th.cos() / ph.cos();
        h.r[k] = h.r[k] * scale - qi * ph.tan();
        h.r_var[k] *= scale * scale;
    }
    h
}

/// A gyro bias the heading filter finds beyond this, deg/s, is said in the notes: a MEMS
/// gyro's own bias is a fraction of it, so the heading and the rates disagree.
const BIAS_SAID_DPS: f64 = 5.0;

/// Yaw acceleration density of a thruster-driven ROV when a gyro measures the rate: a few
/// rad/s^2 at most (the gyro, not this, sets the rate's uncertainty).
const YAW_ACCEL_Q: f64 = 2.0;

/// Yaw-jerk densities tried for a heading without a gyro, rad^2/s^5: from a vehicle holding
/// its heading to one turning in steps of a few tenths of a rad/s within a second.
const YAW_JERKS: [f64; 12] = [
    1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0,
];

/// The heading: with a gyro, the filter as configured. Without one (a navigation log's or an
/// AHRS's yaw alone) the rate's uncertainty rests on the yaw-jerk density ([`Motion::Accel`])
/// and on the yaw noise, so both are chosen from the data: the pair whose yaw innovations are
/// most likely (maximum likelihood over a log grid), and the choice is said in the notes.
pub(super) fn heading(
    src: &HeadingInput,
    n: &mut Noise,
    notes: &mut Vec<String>,
    yaw_set: bool,
) -> Heading {
    if src.gyro.is_some() || src.yaw.is_none() {
        let h = heading_with(src, n.yaw_rad, n.gyro_rad_s, Motion::Rate(YAW_ACCEL_Q)).0;
        let h = body_rate(h, src);
        if src.yaw.is_some() && h.bias.abs() > BIAS_SAID_DPS.to_radians() {
            notes.push(format!(
                "the logged heading and the yaw-rate gyro disagree by {:+.1} deg/s on average, more than a gyro's bias: the yaw angle does not follow the rates (a magnetometer's disturbance, or an AHRS that weighs its compass over its gyro); the fit reads the rates, the position the heading",
                h.bias.to_degrees()
            ));
        }
        return h;
    }
    let sigmas: Vec<f64> = if yaw_set {
        vec![n.yaw_rad]
    } else {
        [0.05f64, 0.1, 0.2, 0.4, 0.8, 1.6]
            .iter()
            .map(|d| d.to_radians())
            .collect()
    };
    let mut best = (f64::NEG_INFINITY, n.yaw_rad, 1.0);
    for q in YAW_JERKS {
        for &sy in &sigmas {
            let (_, ll) = heading_with(src, sy, n.gyro_rad_s, Motion::Accel(q));
            if ll > best.0 {
                best = (ll, sy, q);
            }
        }
    }
    n.yaw_rad = best.1;
    notes.push(format!(
        "heading without a gyro: yaw noise {:.2} deg and yaw-jerk density {} rad^2/s^5 chosen by the likelihood of the yaw innovations",
        best.1.to_degrees(),
        best.2
    ));
    body_rate(
        heading_with(src, best.1, n.gyro_rad_s, Motion::Accel(best.2)).0,
        src,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A vehicle that rolls (30 deg) and pitches (17 deg) while it turns, its IMU logging
    /// roll, pitch, yaw and body rates with a z-gyro bias of 0.02 rad/s: the heading filter
    /// finds that bias within 0.003 rad/s. Fed r as the heading's rate, it took part of the
    /// kinematic difference for bias (0.011 rad/s found here).
    #[test]
    fn the_gyro_bias_of_a_vehicle_that_rolls_and_pitches_is_its_own() {
        let (bias, dt) = (0.02, 0.01);
        let mut rng = crate::core::rng::Rng::new(5);
        let mut cols = vec![Vec::new(); 9];
        let mut psi = 0.0f64;
        for k in 0..6000 {
            let t = k as f64 * dt;
            let (phi, phi_dot) = (0.5 * (0.7 * t).sin(), 0.35 * (0.7 * t).cos());
            let (th, th_dot) = (0.3 * (0.4 * t + 1.0).sin(), 0.12 * (0.4 * t + 1.0).cos());
            let psi_dot = 0.1 + 0.2 * (0.2 * t).sin();
            // Body rates of ZYX Euler angles (Fossen 2011 eq. 2.28).
            let p = phi_dot - psi_dot * th.sin();
            let q = th_dot * phi.cos() + psi_dot * th.cos() * phi.sin();
            let r = -th_dot * phi.sin() + psi_dot * th.cos() * phi.cos();
            let row = [
                phi,
                th,
                wrap_pi(psi + 0.005 * rng.normal()),
                p,
                q,
                r + bias + 0.002 * rng.normal(),
                0.0,
                0.0,
                0.0,
            ];
            for (c, v) in cols.iter_mut().zip(row) {
                c.push(v);
            }
            psi += psi_dot * dt;
        }
        let log = Log {
            t: (0..6000).map(|k| k as f64 * dt).collect(),
            cols,
            notes: Vec::new(),
            present: vec![true; 9],
        };
        let mut noise = Noise {
            yaw_rad: 0.005,
            gyro_rad_s: 0.002,
            ..Noise::default()
        };
        let src = HeadingInput::of(Some(&log), None).unwrap();
        let h = heading(&src, &mut noise, &mut Vec::new(), true);
        assert!(
            (h.bias - bias).abs() < 0.003,
            "bias {} against {bias}",
            h.bias
        );
        // And its rate is the body's r, not the heading's.
        let (rms, n) = (100..5900).fold((0.0, 0.0), |(s, n), k| {
            let e = h.r[k] - (log.cols[5][k] - bias);
            (s + e * e, n + 1.0)
        });
        assert!(
            (rms / n).sqrt() < 0.01,
            "r off by {} rad/s rms",
            (rms / n).sqrt()
        );
    }
}
