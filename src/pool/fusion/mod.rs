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
pub mod latency;
pub mod lever;
pub mod motion;
pub mod nav;
mod numeric;
mod position;
pub mod rotation;
pub mod run;
#[cfg(test)]
mod tests;

use crate::pool::import::csvlog::Log;
use crate::pool::import::{G, PoolRun};
use heading::{Heading, HeadingInput, heading};
use kalman::{Mat, Vector};
use numeric::wrap_pi;
pub use numeric::{interp, interp_at, locate, unwrap_angles};
use position::{PositionFilter, Sensors};
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
    /// How late the navigation log is, s: its rows are read this much earlier in every run
    /// (a DVL's or a navigation filter's latency; the runs measure it against the depth
    /// gauge where they change depth, [`latency`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nav_latency_s: Option<f64>,
    /// Where the navigation log's velocity is measured: a DVL's position from the centre of
    /// gravity (x forward, y starboard, z down, m). Every run's navigation-log velocity is
    /// moved to the centre with the fused rates ([`lever`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nav_at_m: Option<[f64; 3]>,
}

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
    /// Roll, pitch, p and q, for a vehicle that moves in them (empty otherwise).
    #[serde(default)]
    pub roll_pitch: rotation::RollPitch,
    /// The navigation log's u, v, w smoothed under the sensor's own noise, with their standard
    /// deviations ([`Tracked`]); `None` for a channel not from a navigation log.
    #[serde(default)]
    pub tracked: Tracked,
    pub stats: Stats,
}

/// A navigation log's velocities smoothed under the sensor's own noise (`stats.nav_sensor`)
/// rather than the larger figure `vel` is smoothed under (`stats.nav`). These keep the motion:
/// on the twin's navigation-log runs with a 0.42 Hz heave force (0.018 m/s rms), `vel`'s heave
/// error against the truth doubled (0.0054 to 0.0120 m/s rms; these: 0.0068), and the force
/// was then "within noise". The equation-error fits differentiate `vel`, and
/// predict worse from these (six-DOF surge NMAE 0.05 to 0.13), so the diagnosis, which
/// compares simulations with the velocities themselves, reads these and `vel` stays as it is.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Tracked {
    pub vel: [Option<Vec<f64>>; 3],
    pub std: [Option<Vec<f64>>; 3],
}

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Stats {
    /// Noise of each navigation-log velocity channel (u, v, w), when the run has one.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub nav: Vec<(String, nav::Noise)>,
    /// The sensor's own noise in the same channels, told apart from the manoeuvres
    /// ([`motion::noise_level`]): what the diagnosis's noise floor counts. The smoother keeps
    /// the larger figure above (the equation-error fits differentiate its velocities, and
    /// smoothing them less doubled six-DOF held-out errors); taken as the floor, that figure
    /// counted a closed-loop vehicle's manoeuvres as noise (10-19 times the DVL's noise on
    /// `examples/six_dof_rov`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub nav_sensor: Vec<(String, nav::Noise)>,
    pub uwb_fixes: usize,
    pub uwb_rejected_median: usize,
    pub uwb_rejected_gate: usize,
    pub sonar_fixes: usize,
    pub sonar_rejected_gate: usize,
    pub depth_fixes: usize,
    pub gyro_bias_dps: Option<f64>,
    pub noise: Noise,
    pub notes: Vec<String>,
    /// The navigation log's latency against the depth gauge, where this run tells it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nav_latency: Option<latency::NavLatency>,
    /// Roll and pitch where the logs give their rates but the model leaves them out (so they
    /// were not fused): named when a fit the logs cannot support says which DOFs they can.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rates_unfused: Vec<crate::core::dof::Dof>,
}

impl Fused {
    /// Per DOF (u, v, w, r), the velocity that keeps the motion and its standard deviation:
    /// [`Tracked`] where the navigation log gave the channel, `vel` otherwise; with the share
    /// of that deviation that is the sensor's own noise (1 for a tracked channel, smoothed
    /// under that noise; [`Fused::noise_share`] otherwise). `None` where the DOF is unknown.
    pub fn tracking(&self, j: usize) -> Option<(&[f64], &[f64], f64)> {
        let tracked = self.tracked.vel.get(j).zip(self.tracked.std.get(j));
        if let Some((Some(v), Some(s))) = tracked {
            return Some((v, s, 1.0));
        }
        let (v, s) = (self.vel[j].as_deref()?, self.std[j].as_deref()?);
        Some((v, s, self.noise_share()[j]))
    }

    /// Per DOF (u, v, w, r), the share of the stated standard deviation that is the sensor's own
    /// noise: for a navigation-log channel, its sensor noise over the noise the smoother
    /// assumed (at most 1); 1 elsewhere.
    pub fn noise_share(&self) -> [f64; 4] {
        let sigma = |list: &[(String, nav::Noise)], name: &str| {
            list.iter().find(|(n, _)| n == name).map(|(_, n)| n.sigma)
        };
        std::array::from_fn(|j| {
            let name = ["u", "v", "w", "r"][j];
            match (
                sigma(&self.stats.nav_sensor, name),
                sigma(&self.stats.nav, name),
            ) {
                (Some(sensor), Some(smoothed)) if smoothed > 0.0 => (sensor / smoothed).min(1.0),
                _ => 1.0,
            }
        })
    }
}

/// Fuses one run. Fails only when the thrust log is empty (the importer prevents that).
pub fn fuse(run: &PoolRun, s: &Settings) -> Fused {
    let sensors = Sensors::of(run, s);
    let out_t = run.thrust.t.clone();
    let mut stats = Stats::default();
    let mut noise = s.noise(run);
    let hd = HeadingInput::of(sensors.imu, sensors.nav).map(|src| {
        heading(
            &src,
            &mut noise,
            &mut stats.notes,
            s.yaw_sigma_deg.is_some(),
        )
    });
    stats.gyro_bias_dps = hd.as_ref().map(|h| h.bias.to_degrees());
    stats.noise = noise.clone();
    let (sm, out_step) =
        PositionFilter::new(&sensors, s, &noise, hd.as_ref()).run(&out_t, &mut stats);
    let track = Track {
        sm: &sm,
        out_step: &out_step,
        horizontal: sensors.horizontal(),
        vertical: sensors.vertical(),
    };
    let mut fused = assemble(run, out_t, &track, hd.as_ref(), stats);
    if let Some(nav) = sensors.nav {
        use_nav(&mut fused, nav, hd.as_ref());
        fused.stats.nav_latency = run.depth.as_ref().and_then(|d| latency::measure(nav, d));
        if let Some(m) = &fused.stats.nav_latency {
            fused.stats.notes.push(latency::sentence(m));
        }
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
        let sensor = motion::sensor_noise(&nav.t, z, floors[j]);
        let (s, jerk) = nav::smooth_ml(&nav.t, z, &fused.t, noise);
        let (kept, _) = nav::smooth_ml(&nav.t, z, &fused.t, sensor);
        fused.tracked.vel[j] = Some(kept.v);
        fused.tracked.std[j] = Some(kept.std);
        fused.stats.notes.push(format!("navigation log {name}: jerk density {jerk} (m/s^3)^2 s chosen by the likelihood of its innovations"));
        fused.vel[j] = Some(s.v);
        fused.std[j] = Some(s.std);
        fused.stats.nav.push((name.to_string(), noise));
        fused.stats.nav_sensor.push((name.to_string(), sensor));
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
    // The position filter's reasons for unknown velocities no longer hold where the log gave
    // them: each note names only the DOFs still unknown, or goes.
    let known: [bool; 4] = std::array::from_fn(|j| fused.vel[j].is_some());
    fused.stats.notes = std::mem::take(&mut fused.stats.notes)
        .into_iter()
        .filter_map(|n| still_unknown(n, &known))
        .collect();
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

/// A position filter's note of unknown velocities (`..., so surge and sway are unknown`)
/// naming only the DOFs the navigation log did not give after all (`known`: surge, sway,
/// heave, yaw); `None` when it gave them all. Other notes are kept as they are.
fn still_unknown(note: String, known: &[bool; 4]) -> Option<String> {
    const TAILS: [(&str, &[usize]); 3] = [
        ("so surge and sway are unknown", &[0, 1]),
        ("so heave is unknown", &[2]),
        ("so surge, sway and yaw rate are unknown", &[0, 1, 3]),
    ];
    let Some((tail, dofs)) = TAILS.iter().find(|(t, _)| note.contains(t)) else {
        return Some(note);
    };
    let names = ["surge", "sway", "heave", "yaw rate"];
    let left: Vec<&str> = dofs
        .iter()
        .filter(|&&j| !known[j])
        .map(|&j| names[j])
        .collect();
    let said = match left.as_slice() {
        [] => return None,
        [one] => format!("so {one} is unknown"),
        [init @ .., last] => format!("so {} and {last} are unknown", init.join(", ")),
    };
    match left.len() == dofs.len() {
        true => Some(note),
        false => Some(note.replacen(tail, &said, 1)),
    }
}

/// The smoothed position-filter states at the output times, and which of them the sensors
/// fixed.
struct Track<'a> {
    sm: &'a [(Vector<9>, Mat<9>)],
    /// The filter step of each output time.
    out_step: &'a [usize],
    horizontal: bool,
    vertical: bool,
}

impl Track<'_> {
    /// The smoothed state and covariance at output time `k`.
    fn at(&self, k: usize) -> &(Vector<9>, Mat<9>) {
        &self.sm[self.out_step[k]]
    }

    /// Position component `c` at every output time, NaN throughout unless `known`.
    fn coordinate(&self, c: usize, known: bool) -> Vec<f64> {
        (0..self.out_step.len())
            .map(|k| if known { self.at(k).0[c] } else { f64::NAN })
            .collect()
    }
}

/// The fused run from the smoothed filters: position, heading and the body velocities the
/// sensors give, with a note for each they do not.
fn assemble(
    run: &PoolRun,
    t: Vec<f64>,
    track: &Track,
    hd: Option<&Heading>,
    mut stats: Stats,
) -> Fused {
    let x = track.coordinate(0, track.horizontal);
    let y = track.coordinate(1, track.horizontal);
    let z = track.coordinate(2, track.vertical);
    let psi: Vec<f64> = t
        .iter()
        .map(|&tk| hd.map_or(f64::NAN, |h| interp(&h.t, &h.psi, tk)))
        .collect();
    let mut vel: [Option<Vec<f64>>; 4] = [None, None, None, None];
    let mut std: [Option<Vec<f64>>; 4] = [None, None, None, None];
    if let (Some(h), true) = (hd, track.horizontal) {
        let [u, v, su, sv] = surge_sway(&t, &psi, track, h);
        (vel[0], vel[1], std[0], std[1]) = (Some(u), Some(v), Some(su), Some(sv));
    } else if hd.is_none() {
        stats.notes.push(format!("{}: no IMU heading, so surge, sway and yaw rate are unknown (the pool-frame track is kept)", run.name));
    } else {
        stats.notes.push(format!(
            "{}: no UWB or sonar positions, so surge and sway are unknown",
            run.name
        ));
    }
    if track.vertical {
        vel[2] = Some((0..t.len()).map(|k| track.at(k).0[5]).collect());
        std[2] = Some(
            (0..t.len())
                .map(|k| track.at(k).1[(5, 5)].max(0.0).sqrt())
                .collect(),
        );
    } else {
        stats.notes.push(format!(
            "{}: no depth or UWB, so heave is unknown",
            run.name
        ));
    }
    if let Some(h) = hd {
        (vel[3], std[3]) = yaw_rate(&t, h);
    }
    Fused {
        t,
        vel,
        std,
        x,
        y,
        z,
        psi,
        roll_pitch: Default::default(),
        tracked: Tracked::default(),
        stats,
    }
}

/// Surge and sway: the pool-frame velocity rotated by the heading `psi`, with standard
/// deviations that include the heading's variance. Returns [u, v, sd u, sd v].
fn surge_sway(t: &[f64], psi: &[f64], track: &Track, h: &Heading) -> [Vec<f64>; 4] {
    let n = t.len();
    let (mut u, mut v, mut su, mut sv) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for k in 0..n {
        let (m, p) = track.at(k);
        let (c, s) = (psi[k].cos(), psi[k].sin());
        let var_psi = interp(&h.t, &h.psi_var, t[k]);
        u[k] = c * m[3] + s * m[4];
        v[k] = -s * m[3] + c * m[4];
        let quad = |a: f64, b: f64| a * a * p[(3, 3)] + b * b * p[(4, 4)] + 2.0 * a * b * p[(3, 4)];
        su[k] = (quad(c, s) + v[k] * v[k] * var_psi).sqrt();
        sv[k] = (quad(-s, c) + u[k] * u[k] * var_psi).sqrt();
    }
    [u, v, su, sv]
}

/// The smoothed yaw rate at times `t` and its standard deviation.
fn yaw_rate(t: &[f64], h: &Heading) -> (Option<Vec<f64>>, Option<Vec<f64>>) {
    let r = t.iter().map(|&tk| interp(&h.t, &h.r, tk)).collect();
    let sd = t
        .iter()
        .map(|&tk| interp(&h.t, &h.r_var, tk).max(0.0).sqrt())
        .collect();
    (Some(r), Some(sd))
}
