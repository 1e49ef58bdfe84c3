//! Sensor fusion of a pool run into body-frame velocities u, v, w, r with a standard deviation
//! per sample, on the thrust log's time base.
//!
//! Two smoothed Kalman filters, run one after the other:
//! 1. heading: state [psi, r, gyro bias], fed by the IMU's yaw (an absolute, noisy heading)
//!    and its z gyro (rate plus a slowly wandering bias);
//! 2. position: state [x, y, z, vx, vy, vz, accelerometer bias (body x, y, z)] in the pool
//!    frame, driven by the IMU's specific force rotated with the smoothed heading and
//!    corrected by UWB fixes (median pre-screen and a chi-square gate against multipath),
//!    sonar fixes (when the vehicle is in the sonar's view) and the depth gauge.
//!
//! Both are smoothed backwards (Rauch-Tung-Striebel), so a velocity at time t uses the fixes
//! after t as well as before: the right choice offline, where the recording is complete.
//! Body velocities are rotated from the pool frame with the smoothed heading; their variance
//! includes the heading's. Roll and pitch are taken as level for the rotation (an open-frame
//! ROV is passively stable in both; the IMU's roll and pitch are used for gravity).

mod heading;
pub mod kalman;
pub mod nav;
pub mod run;

mod numeric;
use crate::io::csvlog::Log;
use crate::io::pool::{G, PoolRun};
use heading::{Heading, HeadingInput, heading};
use kalman::{Filter, Mat, Update, Vector, white_accel};
use nalgebra::{SMatrix, SVector};
use numeric::{chi2_quantile, wrap_pi};
pub use numeric::{interp, interp_at, locate};
use serde::{Deserialize, Serialize};

/// Sensor noise and rejection settings. A noise level left out (the default) is estimated from
/// the log itself: the robust spread (MAD) of second differences, which a smooth motion
/// sampled this fast barely moves, so what remains is the sensor's own noise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {
    /// UWB noise per axis, m (x, y, z).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uwb_sigma_m: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sonar_sigma_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub depth_sigma_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub yaw_sigma_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyro_sigma_dps: Option<f64>,
    /// Accelerometer noise per sample, g.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accel_sigma_g: Option<f64>,
    /// A UWB fix further than this from the median of its neighbours is multipath (default 0.4 m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uwb_outlier_m: Option<f64>,
    /// Sensors to leave out, e.g. `[sonar]`, to see what each contributes.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub exclude: Vec<String>,
}

/// Neighbours each side for the UWB median screen (seed 003 uses median filters the same way).
const MEDIAN_HALF_WINDOW: usize = 5;
/// Probability kept by the chi-square gate on every position fix.
const GATE_PROBABILITY: f64 = 0.999;

/// The noise levels used, after estimation (SI: m, rad, rad/s, m/s^2).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Noise {
    pub uwb_m: [f64; 3],
    pub sonar_m: f64,
    pub depth_m: f64,
    pub yaw_rad: f64,
    pub gyro_rad_s: f64,
    pub accel_m_s2: f64,
}

/// Robust noise level of a sampled signal: 1.4826 MAD of second differences / sqrt(6).
pub fn noise_sigma(x: &[f64], floor: f64) -> f64 {
    if x.len() < 5 {
        return floor;
    }
    let mut d: Vec<f64> = x.windows(3).map(|w| w[0] - 2.0 * w[1] + w[2]).collect();
    let n = d.len();
    let med = {
        d.sort_by(f64::total_cmp);
        d[n / 2]
    };
    let mut dev: Vec<f64> = d.iter().map(|v| (v - med).abs()).collect();
    dev.sort_by(f64::total_cmp);
    (1.4826 * dev[n / 2] / 6f64.sqrt()).max(floor)
}

fn unwrap_angles(a: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(a.len());
    let mut off = 0.0;
    for (k, &x) in a.iter().enumerate() {
        if k > 0 {
            let d = x - a[k - 1];
            off -= (d / (2.0 * std::f64::consts::PI)).round() * 2.0 * std::f64::consts::PI;
        }
        out.push(x + off);
    }
    out
}

impl Settings {
    fn noise(&self, run: &PoolRun) -> Noise {
        let est = |l: Option<&Log>, c: usize, floor: f64| {
            l.and_then(|l| l.col(c))
                .map_or(floor, |x| noise_sigma(x, floor))
        };
        let uwb = run.uwb.as_ref();
        let imu = run.imu.as_ref();
        Noise {
            uwb_m: self
                .uwb_sigma_m
                .unwrap_or_else(|| std::array::from_fn(|c| est(uwb, c, 0.005))),
            sonar_m: self.sonar_sigma_m.unwrap_or_else(|| {
                est(run.sonar.as_ref(), 0, 0.005).max(est(run.sonar.as_ref(), 1, 0.005))
            }),
            depth_m: self
                .depth_sigma_m
                .unwrap_or_else(|| est(run.depth.as_ref(), 0, 0.002)),
            yaw_rad: self.yaw_sigma_deg.map(f64::to_radians).unwrap_or_else(|| {
                imu.and_then(|l| l.col(2)).map_or(0.01, |y| {
                    noise_sigma(&unwrap_angles(y), 0.1f64.to_radians())
                })
            }),
            gyro_rad_s: self
                .gyro_sigma_dps
                .map(f64::to_radians)
                .unwrap_or_else(|| est(imu, 5, 0.05f64.to_radians())),
            accel_m_s2: self.accel_sigma_g.map(|g| g * G).unwrap_or_else(|| {
                (0..2)
                    .map(|c| est(imu, 6 + c, 0.002 * G))
                    .fold(0.0, f64::max)
            }),
        }
    }
}

pub const SENSORS: [&str; 4] = ["uwb", "sonar", "imu", "depth"];

/// The fused run on the thrust log's time base. DOFs the sensors cannot give are `None`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Fused {
    pub t: Vec<f64>,
    /// u, v, w, r and their standard deviations (r in rad/s).
    pub vel: [Option<Vec<f64>>; 4],
    pub std: [Option<Vec<f64>>; 4],
    /// Pool-frame position and heading (NaN where unknown).
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
    pub psi: Vec<f64>,
    pub stats: Stats,
}

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Stats {
    /// Noise of each navigation-log velocity channel (u, v, w), when the run has one.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub nav: Vec<(String, nav::Noise)>,
    pub uwb_fixes: usize,
    pub uwb_rejected_median: usize,
    pub uwb_rejected_gate: usize,
    pub sonar_fixes: usize,
    pub sonar_rejected_gate: usize,
    pub depth_fixes: usize,
    pub gyro_bias_dps: Option<f64>,
    pub noise: Noise,
    pub notes: Vec<String>,
}

/// Marks UWB fixes that stray from the median of their neighbours (multipath).
fn median_screen(uwb: &Log, half: usize, limit: f64) -> Vec<bool> {
    let n = uwb.len();
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(half), (k + half + 1).min(n));
            (0..3).all(|c| {
                let mut w: Vec<f64> = uwb.cols[c][a..b].to_vec();
                w.sort_by(f64::total_cmp);
                (uwb.cols[c][k] - w[w.len() / 2]).abs() <= limit * if c == 2 { 2.0 } else { 1.0 }
            })
        })
        .collect()
}

#[derive(Clone, Copy)]
enum Event {
    Imu(usize),
    Uwb(usize),
    Sonar(usize),
    Depth(usize),
    Out(usize),
}

/// Fuses one run. Fails only when the thrust log is empty (the importer prevents that).
pub fn fuse(run: &PoolRun, s: &Settings) -> Fused {
    let use_ = |name: &str| !s.exclude.iter().any(|e| e == name);
    let imu = run.imu.as_ref().filter(|_| use_("imu"));
    let uwb = run.uwb.as_ref().filter(|_| use_("uwb"));
    let sonar = run.sonar.as_ref().filter(|_| use_("sonar"));
    let depth = run.depth.as_ref().filter(|_| use_("depth"));
    let out_t = run.thrust.t.clone();
    let mut stats = Stats::default();
    let mut noise = s.noise(run);
    let nav = run.nav.as_ref().filter(|_| use_("nav"));
    let hd = HeadingInput::of(imu, nav).map(|src| {
        heading(
            &src,
            &mut noise,
            &mut stats.notes,
            s.yaw_sigma_deg.is_some(),
        )
    });
    stats.gyro_bias_dps = hd.as_ref().map(|h| h.bias.to_degrees());
    stats.noise = noise.clone();

    let mut events: Vec<(f64, u8, Event)> = Vec::new();
    // Only an IMU with accelerometers drives the position filter.
    let imu_accel = imu.filter(|l| (6..9).all(|c| l.has(c)));
    if let Some(l) = imu_accel {
        events.extend(l.t.iter().enumerate().map(|(k, &t)| (t, 0, Event::Imu(k))));
    }
    if let Some(l) = uwb {
        events.extend(l.t.iter().enumerate().map(|(k, &t)| (t, 1, Event::Uwb(k))));
    }
    if let Some(l) = sonar {
        events.extend(
            l.t.iter()
                .enumerate()
                .map(|(k, &t)| (t, 1, Event::Sonar(k))),
        );
    }
    if let Some(l) = depth {
        events.extend(
            l.t.iter()
                .enumerate()
                .map(|(k, &t)| (t, 1, Event::Depth(k))),
        );
    }
    events.extend(
        out_t
            .iter()
            .enumerate()
            .map(|(k, &t)| (t, 2, Event::Out(k))),
    );
    events.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));

    // Initial position: the first fixes there are.
    let first = |l: Option<&Log>, c: usize| l.map(|l| l.cols[c][0]);
    let x0 = Vector::<9>::from_column_slice(&[
        first(sonar, 0).or(first(uwb, 0)).unwrap_or(0.0),
        first(sonar, 1).or(first(uwb, 1)).unwrap_or(0.0),
        first(depth, 0).or(first(uwb, 2)).unwrap_or(0.0),
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ]);
    let ab = 0.02 * G;
    let p0 = Mat::<9>::from_diagonal(&Vector::<9>::from_column_slice(&[
        1.0,
        1.0,
        1.0,
        0.25,
        0.25,
        0.25,
        ab * ab,
        ab * ab,
        ab * ab,
    ]));
    let mut kf = Filter::<9>::new(x0, p0);
    let good_uwb = uwb.map_or(vec![], |l| {
        median_screen(l, MEDIAN_HALF_WINDOW, s.uwb_outlier_m.unwrap_or(0.4))
    });
    let (gate3, gate2, gate1) = (
        chi2_quantile(GATE_PROBABILITY, 3),
        chi2_quantile(GATE_PROBABILITY, 2),
        chi2_quantile(GATE_PROBABILITY, 1),
    );
    let mut out_step = vec![0usize; out_t.len()];
    let mut last_t = events.first().map_or(0.0, |e| e.0);
    let mut last_imu: Option<usize> = None;
    let mut rejected_in_row = 0;
    for (t, _, ev) in &events {
        let dt = t - last_t;
        if dt > 0.0 {
            let (fm, u, q) = transition(
                dt,
                last_imu.and_then(|k| Some((imu_accel?, hd.as_ref()?, k))),
                &noise,
            );
            kf.predict(fm, u, q);
            last_t = *t;
        }
        match *ev {
            Event::Imu(k) => last_imu = Some(k),
            Event::Uwb(k) => {
                let l = uwb.unwrap();
                stats.uwb_fixes += 1;
                if !good_uwb[k] {
                    stats.uwb_rejected_median += 1;
                    continue;
                }
                // A UWB log without heights gives the horizontal position only.
                let z = SVector::<f64, 3>::new(
                    l.cols[0][k],
                    l.cols[1][k],
                    if l.has(2) { l.cols[2][k] } else { 0.0 },
                );
                let mut h = SMatrix::<f64, 3, 9>::zeros();
                h[(0, 0)] = 1.0;
                h[(1, 1)] = 1.0;
                h[(2, 2)] = 1.0;
                let r = SMatrix::<f64, 3, 3>::from_diagonal(&SVector::<f64, 3>::from_iterator(
                    noise.uwb_m.iter().map(|x| x * x),
                ));
                if !l.has(2) {
                    h[(2, 2)] = 0.0;
                }
                // After a second of rejections the filter, not the fixes, is wrong: re-acquire.
                let gate = if rejected_in_row >= 10 {
                    f64::INFINITY
                } else {
                    gate3
                };
                match kf.update(z, h, r, gate, |_| {}) {
                    Update::Accepted => rejected_in_row = 0,
                    Update::Gated(_) => {
                        rejected_in_row += 1;
                        stats.uwb_rejected_gate += 1;
                    }
                }
            }
            Event::Sonar(k) => {
                let l = sonar.unwrap();
                let z = SVector::<f64, 2>::new(l.cols[0][k], l.cols[1][k]);
                let mut h = SMatrix::<f64, 2, 9>::zeros();
                h[(0, 0)] = 1.0;
                h[(1, 1)] = 1.0;
                let r = SMatrix::<f64, 2, 2>::identity() * noise.sonar_m.powi(2);
                match kf.update(z, h, r, gate2, |_| {}) {
                    Update::Accepted => stats.sonar_fixes += 1,
                    Update::Gated(_) => stats.sonar_rejected_gate += 1,
                }
            }
            Event::Depth(k) => {
                let l = depth.unwrap();
                let mut h = SMatrix::<f64, 1, 9>::zeros();
                h[(0, 2)] = 1.0;
                if kf.update(
                    SVector::<f64, 1>::new(l.cols[0][k]),
                    h,
                    SMatrix::<f64, 1, 1>::new(noise.depth_m.powi(2)),
                    gate1 * 4.0,
                    |_| {},
                ) == Update::Accepted
                {
                    stats.depth_fixes += 1;
                }
            }
            Event::Out(k) => out_step[k] = kf.len() - 1,
        }
    }
    let sm = kf.smooth();
    let vertical = depth.is_some() || uwb.is_some_and(|l| l.has(2));
    let mut fused = assemble(
        run,
        out_t,
        &out_step,
        &sm,
        hd.as_ref(),
        uwb.is_some() || sonar.is_some(),
        vertical,
        stats,
    );
    if let Some(nav) = nav {
        use_nav(&mut fused, nav, hd.as_ref());
    }
    fused
}

/// The navigation log's body velocities replace what the position filter derived (a DVL
/// measures them directly; differentiating positions only adds noise), channel by channel.
/// Its yaw rate is used when no IMU gave one.
fn use_nav(fused: &mut Fused, nav: &Log, hd: Option<&Heading>) {
    let floors = [0.002, 0.002, 0.002];
    for (j, name) in ["u", "v", "w"].iter().enumerate() {
        let Some(z) = nav.col(j) else { continue };
        let noise = nav::noise_level(&nav.t, z, floors[j]);
        let (s, jerk) = nav::smooth_ml(&nav.t, z, &fused.t, noise);
        fused.stats.notes.push(format!("navigation log {name}: jerk density {jerk} (m/s^3)^2 s chosen by the likelihood of its innovations"));
        fused.vel[j] = Some(s.v);
        fused.std[j] = Some(s.std);
        fused.stats.nav.push((name.to_string(), noise));
    }
    if fused.vel[3].is_none()
        && hd.is_none()
        && let Some(r) = nav.col(8)
    {
        let noise = nav::noise_level(&nav.t, r, 0.05f64.to_radians());
        let (s, _) = nav::smooth_ml(&nav.t, r, &fused.t, noise);
        fused.vel[3] = Some(s.v);
        fused.std[3] = Some(s.std);
    }
    // The position filter's reasons for unknown velocities no longer hold where the log gave them.
    let known = |j: usize| fused.vel[j].is_some();
    let (horizontal, vertical, yaw) = (known(0) && known(1), known(2), known(3));
    fused.stats.notes.retain(|n| {
        !((horizontal && n.contains("so surge and sway are unknown"))
            || (vertical && n.contains("so heave is unknown"))
            || (horizontal && yaw && n.contains("so surge, sway and yaw rate are unknown")))
    });
    if fused.vel[3].is_none() {
        fused
            .stats
            .notes
            .push("no yaw rate: neither an IMU nor the navigation log gives heading or r".into());
    }
    if fused.x.iter().all(|x| x.is_nan()) {
        fused.stats.notes.push(
            "no pool-frame position (no UWB or sonar): tether length and wall distance are unknown"
                .into(),
        );
    }
}

/// Transition of the position filter over `dt`, driven by the IMU sample `k` when there is one.
fn transition(
    dt: f64,
    imu: Option<(&Log, &Heading, usize)>,
    n: &Noise,
) -> (Mat<9>, Vector<9>, Mat<9>) {
    let mut f = Mat::<9>::identity();
    let mut u = Vector::<9>::zeros();
    let mut q = Mat::<9>::zeros();
    for i in 0..3 {
        f[(i, i + 3)] = dt;
    }
    match imu {
        Some((l, hd, k)) => {
            let psi = interp(&hd.t, &hd.psi, l.t[k]);
            let level = |x: f64| if x.is_finite() { x } else { 0.0 };
            let (phi, theta) = (level(l.cols[0][k]), level(l.cols[1][k]));
            let rot = nalgebra::Rotation3::from_euler_angles(phi, theta, psi);
            let fb = nalgebra::Vector3::new(l.cols[6][k], l.cols[7][k], l.cols[8][k]);
            let a = rot * fb + nalgebra::Vector3::new(0.0, 0.0, G);
            let rm = rot.matrix();
            for i in 0..3 {
                u[i] = 0.5 * dt * dt * a[i];
                u[i + 3] = dt * a[i];
                for j in 0..3 {
                    f[(i, 6 + j)] = -0.5 * dt * dt * rm[(i, j)];
                    f[(i + 3, 6 + j)] = -dt * rm[(i, j)];
                }
            }
            // White accelerometer noise of sigma per sample at the IMU's rate.
            let imu_dt = if l.len() > 1 {
                (l.t[l.len() - 1] - l.t[0]) / (l.len() - 1) as f64
            } else {
                0.02
            };
            let qa = n.accel_m_s2.powi(2) * imu_dt + 1e-4;
            let w = white_accel(qa, dt);
            for i in 0..3 {
                q[(i, i)] = w[0][0];
                q[(i, i + 3)] = w[0][1];
                q[(i + 3, i)] = w[1][0];
                q[(i + 3, i + 3)] = w[1][1];
                q[(6 + i, 6 + i)] = (1e-4 * G).powi(2) * dt;
            }
        }
        None => {
            // No IMU: constant velocity driven by the accelerations a pool ROV reaches (~1 m/s^2).
            let w = white_accel(1.0, dt);
            for i in 0..3 {
                q[(i, i)] = w[0][0];
                q[(i, i + 3)] = w[0][1];
                q[(i + 3, i)] = w[1][0];
                q[(i + 3, i + 3)] = w[1][1];
            }
        }
    }
    (f, u, q)
}

#[allow(clippy::too_many_arguments)]
fn assemble(
    run: &PoolRun,
    t: Vec<f64>,
    out_step: &[usize],
    sm: &[(Vector<9>, Mat<9>)],
    hd: Option<&Heading>,
    horizontal: bool,
    vertical: bool,
    mut stats: Stats,
) -> Fused {
    let n = t.len();
    let pick = |k: usize| &sm[out_step[k]];
    let x: Vec<f64> = (0..n)
        .map(|k| if horizontal { pick(k).0[0] } else { f64::NAN })
        .collect();
    let y: Vec<f64> = (0..n)
        .map(|k| if horizontal { pick(k).0[1] } else { f64::NAN })
        .collect();
    let z: Vec<f64> = (0..n)
        .map(|k| if vertical { pick(k).0[2] } else { f64::NAN })
        .collect();
    let psi: Vec<f64> = t
        .iter()
        .map(|&tk| hd.map_or(f64::NAN, |h| interp(&h.t, &h.psi, tk)))
        .collect();
    let mut vel: [Option<Vec<f64>>; 4] = [None, None, None, None];
    let mut std: [Option<Vec<f64>>; 4] = [None, None, None, None];
    if let (Some(h), true) = (hd, horizontal) {
        let (mut u, mut v, mut su, mut sv) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for k in 0..n {
            let (m, p) = pick(k);
            let (c, s) = (psi[k].cos(), psi[k].sin());
            let var_psi = interp(&h.t, &h.psi_var, t[k]);
            u[k] = c * m[3] + s * m[4];
            v[k] = -s * m[3] + c * m[4];
            let quad =
                |a: f64, b: f64| a * a * p[(3, 3)] + b * b * p[(4, 4)] + 2.0 * a * b * p[(3, 4)];
            su[k] = (quad(c, s) + v[k] * v[k] * var_psi).sqrt();
            sv[k] = (quad(-s, c) + u[k] * u[k] * var_psi).sqrt();
        }
        vel[0] = Some(u);
        vel[1] = Some(v);
        std[0] = Some(su);
        std[1] = Some(sv);
    } else if hd.is_none() {
        stats.notes.push(format!("{}: no IMU heading, so surge, sway and yaw rate are unknown (the pool-frame track is kept)", run.name));
    } else {
        stats.notes.push(format!(
            "{}: no UWB or sonar positions, so surge and sway are unknown",
            run.name
        ));
    }
    if vertical {
        vel[2] = Some((0..n).map(|k| pick(k).0[5]).collect());
        std[2] = Some((0..n).map(|k| pick(k).1[(5, 5)].max(0.0).sqrt()).collect());
    } else {
        stats.notes.push(format!(
            "{}: no depth or UWB, so heave is unknown",
            run.name
        ));
    }
    if let Some(h) = hd {
        vel[3] = Some(t.iter().map(|&tk| interp(&h.t, &h.r, tk)).collect());
        std[3] = Some(
            t.iter()
                .map(|&tk| interp(&h.t, &h.r_var, tk).max(0.0).sqrt())
                .collect(),
        );
    }
    Fused {
        t,
        vel,
        std,
        x,
        y,
        z,
        psi,
        stats,
    }
}

#[cfg(test)]
mod tests;
