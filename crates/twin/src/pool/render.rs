//! Rendering a simulated pool run as the files a run folder holds: `run.yaml`, the thrust log
//! and each sensor's log with its rate, noise, outliers and dropouts, read from the truth as
//! the (late, low-passed) sensors see it.

use super::{
    G, LOG_EVERY, POOL, RunSpec, SONAR_AT, SONAR_HALF_FOV_DEG, SONAR_RANGE_M, STEP, Sensors,
    TETHER_ANCHOR, Truth,
};
use crate::world::{Effect, State};
use hydrofit_core::model::Vec6;
use hydrofit_core::rng::Rng;
use std::fmt::Write as _;

fn wrap_deg(a: f64) -> f64 {
    let mut x = (a + 180.0).rem_euclid(360.0) - 180.0;
    if x == -180.0 {
        x = 180.0;
    }
    x
}

/// Truth at time `t` (linear interpolation on the internal step; clamped at the ends).
fn at(truth: &Truth, t: f64) -> (State, Vec6) {
    let x = (t / STEP).clamp(0.0, (truth.t.len() - 1) as f64);
    let i = (x.floor() as usize).min(truth.t.len() - 2);
    let w = x - i as f64;
    let (a, b) = (&truth.states[i], &truth.states[i + 1]);
    let lerp = |p: f64, q: f64| p + w * (q - p);
    let s = State {
        nu: std::array::from_fn(|j| lerp(a.nu[j], b.nu[j])),
        pos: std::array::from_fn(|j| lerp(a.pos[j], b.pos[j])),
        psi: lerp(a.psi, b.psi),
        thrust: a.thrust,
    };
    (
        s,
        std::array::from_fn(|j| lerp(truth.accel[i][j], truth.accel[i + 1][j])),
    )
}

/// How late the position, attitude and depth sensors report: a transport delay and a
/// first-order low-pass, s (the twin's form of `sensor_delay`).
#[derive(Debug, Clone, Copy, Default)]
pub struct Latency {
    pub delay_s: f64,
    pub filter_s: f64,
}

impl Latency {
    pub(super) fn of(effects: &[Effect]) -> Latency {
        effects
            .iter()
            .find_map(|e| match e {
                Effect::SensorDelay { delay_s, filter_s } => Some(Latency {
                    delay_s: *delay_s,
                    filter_s: *filter_s,
                }),
                _ => None,
            })
            .unwrap_or_default()
    }

    /// The truth through the sensors' low-pass, when they have one (`None`: as it is).
    fn sensed(self, truth: &Truth) -> Option<Truth> {
        (self.filter_s > 0.0).then(|| low_pass(truth, self.filter_s))
    }
}

/// The truth as a sensor with a first-order low-pass of time constant `tau` sees it.
fn low_pass(truth: &Truth, tau: f64) -> Truth {
    let a = 1.0 - (-STEP / tau).exp();
    let mut states = Vec::with_capacity(truth.states.len());
    let mut accel = Vec::with_capacity(truth.accel.len());
    let (mut s, mut acc) = (truth.states[0], truth.accel[0]);
    for (x, y) in truth.states.iter().zip(&truth.accel) {
        for j in 0..6 {
            s.nu[j] += a * (x.nu[j] - s.nu[j]);
            acc[j] += a * (y[j] - acc[j]);
        }
        for j in 0..3 {
            s.pos[j] += a * (x.pos[j] - s.pos[j]);
        }
        s.psi += a * (x.psi - s.psi);
        states.push(s);
        accel.push(acc);
    }
    Truth {
        t: truth.t.clone(),
        states,
        accel,
        cmd: truth.cmd.clone(),
    }
}

/// The files of one run folder, rendered: (file name, contents).
pub fn render(
    spec: &RunSpec,
    truth: &Truth,
    sensors: &Sensors,
    latency: Latency,
    seed: u64,
) -> Vec<(&'static str, String)> {
    let mut rng = Rng::derive(seed, &format!("pool/{}/sensors", spec.name));
    let end = *truth.t.last().unwrap();
    let sensed = latency.sensed(truth);
    let seen = |t: f64| at(sensed.as_ref().unwrap_or(truth), t - latency.delay_s);
    // The sensors draw their noise from one stream, in this order.
    let mut files = vec![
        ("run.yaml", run_yaml(spec)),
        ("thrust.csv", thrust_csv(truth)),
        ("uwb.csv", uwb_csv(&seen, end, sensors, &mut rng)),
    ];
    if spec.sonar {
        files.push(("sonar.csv", sonar_csv(&seen, end, sensors, &mut rng)));
    }
    files.push(("imu.csv", imu_csv(&seen, end, sensors, &mut rng)));
    files.push(("depth.csv", depth_csv(&seen, end, sensors, &mut rng)));
    files
}

/// The files of one run folder of a vehicle that logs its own navigation only (a DVL's
/// velocity and an AHRS's attitude in `nav.csv`, and a depth gauge): no UWB, sonar or IMU, the
/// run's start position in `run.yaml` so that a position can be dead-reckoned. The same truth
/// and effects as [`render`]; `latency` (a concealed `sensor_delay`) makes the navigation log
/// and the depth late as it does the other sensors.
pub fn render_nav(
    spec: &RunSpec,
    truth: &Truth,
    sensors: &Sensors,
    latency: Latency,
    seed: u64,
) -> Vec<(&'static str, String)> {
    let mut rng = Rng::derive(seed, &format!("pool/{}/navigation log", spec.name));
    let end = *truth.t.last().unwrap();
    let sensed = latency.sensed(truth);
    let seen = |t: f64| at(sensed.as_ref().unwrap_or(truth), t - latency.delay_s);
    let start = truth.states[0].pos;
    let run = format!(
        "{}start_m: [{:.3}, {:.3}]\n",
        run_yaml(spec),
        start[0],
        start[1]
    );
    vec![
        ("run.yaml", run),
        ("thrust.csv", thrust_csv(truth)),
        ("nav.csv", nav_csv(&seen, end, &mut rng)),
        ("depth.csv", depth_csv(&seen, end, sensors, &mut rng)),
    ]
}

/// The DVL's velocity noise (white, each ping), m/s, of [`render_nav`]'s navigation log.
const NAV_DVL_NOISE_M_S: f64 = 0.012;

/// The DVL's ping interval, s.
pub const NAV_DVL_PERIOD_S: f64 = 0.125;

/// `nav.csv`: the vehicle's navigation output at an irregular 4-6 Hz, each row the last DVL
/// ping's body velocity (white noise [`NAV_DVL_NOISE_M_S`]) and the AHRS's attitude (0.3 deg
/// noise on roll and pitch, 0.5 deg on the heading).
fn nav_csv(seen: &Seen, end: f64, rng: &mut Rng) -> String {
    let mut nav = String::from("t,u_m_s,v_m_s,w_m_s,roll_deg,pitch_deg,yaw_deg\n");
    let (mut ping, mut t) = (0.1, 0.2 + 0.1 * rng.uniform());
    let mut dvl = [0.0; 3];
    while t <= end {
        while ping <= t {
            let (s, _) = seen(ping);
            dvl = std::array::from_fn(|i| s.nu[i] + NAV_DVL_NOISE_M_S * rng.normal());
            ping += NAV_DVL_PERIOD_S;
        }
        let (s, _) = seen(t);
        let _ = writeln!(
            nav,
            "{t:.3},{:.4},{:.4},{:.4},{:.2},{:.2},{:.2}",
            dvl[0],
            dvl[1],
            dvl[2],
            0.3 * rng.normal(),
            0.3 * rng.normal(),
            wrap_deg(s.psi.to_degrees() + 0.5 * rng.normal()),
        );
        t += 1.0 / (4.0 + 2.0 * rng.uniform());
    }
    nav
}

/// What a sensor sees at time t: the (late, filtered) state and body acceleration.
type Seen<'a> = dyn Fn(f64) -> (State, Vec6) + 'a;

/// `run.yaml`: role, description, the pool and the tether's anchor.
fn run_yaml(spec: &RunSpec) -> String {
    let mut run_yaml = format!(
        "role: {}\ndescription: \"{:?} manoeuvre of the reference vehicle, {:.0} s (synthetic: hydrofit twin pool)\"\n",
        spec.role, spec.manoeuvre, spec.duration_s
    );
    let _ = write!(
        run_yaml,
        "pool: {{length_m: {}, width_m: {}, depth_m: {}}}\ntether_anchor_m: [{}, {}, {}]\n",
        POOL.length_m,
        POOL.width_m,
        POOL.depth_m,
        TETHER_ANCHOR[0],
        TETHER_ANCHOR[1],
        TETHER_ANCHOR[2]
    );
    run_yaml
}

/// `thrust.csv`: the logged command at 20 Hz.
fn thrust_csv(truth: &Truth) -> String {
    let mut thrust = String::from("t,X_N,Y_N,Z_N,N_Nm\n");
    for (k, c) in truth.cmd.iter().enumerate() {
        let _ = writeln!(
            thrust,
            "{:.2},{:.1},{:.1},{:.1},{:.2}",
            k as f64 * STEP * LOG_EVERY as f64,
            c[0],
            c[1],
            c[2],
            c[5]
        );
    }
    thrust
}

/// `uwb.csv`: position fixes at ~10 Hz with noise, multipath jumps and dropouts.
fn uwb_csv(seen: &Seen, end: f64, sensors: &Sensors, rng: &mut Rng) -> String {
    let mut uwb = String::from("t,x_m,y_m,z_m\n");
    let mut t = 0.05;
    while t <= end {
        let (s, _) = seen(t);
        let mut p: [f64; 3] =
            std::array::from_fn(|i| s.pos[i] + sensors.uwb_sigma_m[i] * rng.normal());
        if rng.uniform() < sensors.uwb_outlier_rate {
            // Multipath: a reflected path is longer, so the fix jumps by up to a few metres.
            let (mag, dir) = (
                0.5 + 2.5 * rng.uniform(),
                2.0 * std::f64::consts::PI * rng.uniform(),
            );
            p[0] += mag * dir.cos();
            p[1] += mag * dir.sin();
            p[2] += 0.3 * mag * rng.normal();
        }
        if rng.uniform() > 0.02 {
            let _ = writeln!(uwb, "{t:.3},{:.3},{:.3},{:.3}", p[0], p[1], p[2]);
        }
        t += 0.1 + 0.004 * (rng.uniform() - 0.5);
    }
    uwb
}

/// `sonar.csv`: fixes of a sonar at one end, at 5 Hz, inside its field of view and range.
fn sonar_csv(seen: &Seen, end: f64, sensors: &Sensors, rng: &mut Rng) -> String {
    let mut sonar = String::from("t,x_m,y_m\n");
    for k in 0.. {
        let t = 0.1 + 0.2 * k as f64;
        if t > end {
            break;
        }
        let (s, _) = seen(t);
        let (dx, dy) = (s.pos[0] - SONAR_AT[0], s.pos[1] - SONAR_AT[1]);
        let range = (dx * dx + dy * dy).sqrt();
        let bearing = dy.atan2(dx).to_degrees();
        if bearing.abs() <= SONAR_HALF_FOV_DEG
            && (SONAR_RANGE_M.0..=SONAR_RANGE_M.1).contains(&range)
        {
            let sigma = sensors.sonar_sigma_m * (1.0 + range / 10.0);
            let _ = writeln!(
                sonar,
                "{t:.1},{:.3},{:.3}",
                s.pos[0] + sigma * rng.normal(),
                s.pos[1] + sigma * rng.normal()
            );
        }
    }
    sonar
}

/// `imu.csv`: attitude, rates and specific force at 50 Hz, with gyro and accelerometer biases.
fn imu_csv(seen: &Seen, end: f64, sensors: &Sensors, rng: &mut Rng) -> String {
    let mut imu = String::from("t,roll_deg,pitch_deg,yaw_deg,p_dps,q_dps,r_dps,ax_g,ay_g,az_g\n");
    for k in 0.. {
        let t = 0.02 * k as f64;
        if t > end {
            break;
        }
        let (s, a) = seen(t);
        // Specific force in the body frame: a + omega x v - g, roll and pitch held level.
        let f = [a[0] - s.nu[5] * s.nu[1], a[1] + s.nu[5] * s.nu[0], a[2] - G];
        let _ = writeln!(
            imu,
            "{t:.2},{:.2},{:.2},{:.2},{:.3},{:.3},{:.3},{:.4},{:.4},{:.4}",
            0.3 * rng.normal(),
            0.3 * rng.normal(),
            wrap_deg(s.psi.to_degrees() + sensors.imu_yaw_sigma_deg * rng.normal()),
            sensors.gyro_sigma_dps * rng.normal(),
            sensors.gyro_sigma_dps * rng.normal(),
            s.nu[5].to_degrees() + sensors.gyro_bias_dps + sensors.gyro_sigma_dps * rng.normal(),
            f[0] / G + sensors.accel_bias_g[0] + sensors.accel_sigma_g * rng.normal(),
            f[1] / G + sensors.accel_bias_g[1] + sensors.accel_sigma_g * rng.normal(),
            f[2] / G + sensors.accel_bias_g[2] + sensors.accel_sigma_g * rng.normal(),
        );
    }
    imu
}

/// `depth.csv`: the depth gauge at 10 Hz.
fn depth_csv(seen: &Seen, end: f64, sensors: &Sensors, rng: &mut Rng) -> String {
    let mut depth = String::from("t,depth_m\n");
    for k in 0.. {
        let t = 0.05 + 0.1 * k as f64;
        if t > end {
            break;
        }
        let _ = writeln!(
            depth,
            "{t:.2},{:.3}",
            seen(t).0.pos[2] + sensors.depth_sigma_m * rng.normal()
        );
    }
    depth
}
