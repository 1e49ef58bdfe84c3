//! A twin of a real vehicle's field logs: a 30 kg tethered ROV flown by a closed-loop
//! position / depth / heading controller with model-based feed-forward (its own wrong guesses
//! of mass, drag and buoyancy), thrusters that saturate, a few newtons of positive buoyancy, a
//! tether, and the logs such a vehicle writes: the controller's commanded wrench by receive
//! time (bursts and stalls), a DVL-based navigation filter's body velocity and AHRS heading at
//! an irregular 5-7 Hz, filtered and late, a depth sensor, and horizontal UWB fixes. No
//! accelerometer, no CFD.
//!
//! The hidden physics here is written apart from the diagnosis's own forms
//! (`hydrofit_core::model::effects`): the tether's drag follows the length of cable paid out (horizontal
//! run plus depth plus slack, not the straight-line distance), the nav filter is an exponential
//! low-pass with a latency, and the controller closes the loop on what it measures. What the
//! twin hides is recorded apart, in the truth folder.

use hydrofit_core::model::{Hydro, Plant, Vec6, Vehicle};
use hydrofit_core::rng::Rng;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Internal integration step, s.
const STEP: f64 = 0.005;
/// The controller's rate: one command every this many steps (50 Hz).
const CONTROL_EVERY: usize = 4;

/// What the twin hides (written to the truth folder, never to the run).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Hidden {
    /// Net buoyancy, N upward (the vehicle floats up when the thrusters stop).
    pub buoyancy_up_n: f64,
    /// Tether drag: -k L |v| v on the horizontal velocity, L = horizontal run from the anchor
    /// + depth + slack (cable paid out), k in N s^2/m^3.
    pub tether_k: f64,
    pub tether_slack_m: f64,
    /// Latency of the navigation filter's output, s.
    pub nav_latency_s: f64,
    /// Time constant of the navigation filter's low-pass, s.
    pub nav_filter_s: f64,
    /// Thruster limits per DOF (X, Y, Z N; N N m): commands beyond are clipped.
    pub limits: [f64; 4],
    /// Where the DVL is mounted, from the centre of gravity (x forward, y starboard, z down,
    /// m): it measures its own point's velocity, `v + omega x at` (the vehicle turns in yaw
    /// only, so `(-r y, r x, 0)` is added).
    pub dvl_at_m: [f64; 3],
}

impl Default for Hidden {
    fn default() -> Hidden {
        Hidden {
            buoyancy_up_n: 6.0,
            tether_k: 1.6,
            tether_slack_m: 1.5,
            nav_latency_s: 0.15,
            nav_filter_s: 0.25,
            limits: [60.0, 50.0, 45.0, 9.0],
            dvl_at_m: [0.0; 3],
        }
    }
}

/// The field vehicle: 30 kg, its true coefficients (SNAME, negative).
pub fn vehicle() -> Vehicle {
    let mut v = Vehicle::reference();
    v.name = "tethered 30 kg ROV (field twin)".into();
    v.mass_kg = 30.0;
    v.inertia_kg_m2.zz = 1.0;
    v
}

pub fn hydro() -> Hydro {
    Hydro::diagonal(
        [-12.0, -22.0, -40.0, 0.0, 0.0, -0.8],
        [-6.0, -9.0, -14.0, 0.0, 0.0, -2.2],
        [-32.0, -58.0, -70.0, 0.0, 0.0, -1.6],
    )
}

pub const POOL: hydrofit_core::model::Pool = hydrofit_core::model::Pool {
    length_m: 30.0,
    width_m: 15.0,
    depth_m: 5.0,
};
pub const ANCHOR: [f64; 3] = [1.0, 7.5, 0.0];

/// The flights: what the controller is asked to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Flight {
    /// Waypoints around a rectangle, heading along the track.
    Box,
    /// Hold position; depth and heading steps.
    DepthSteps,
    /// Fast straight transects back and forth along the pool.
    Transects,
    /// A figure of eight at constant heading (sway and surge together).
    FigureEight,
    /// Heading steps while creeping forward.
    Turns,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunSpec {
    pub name: String,
    pub role: String,
    pub flight: Flight,
    pub duration_s: f64,
}

pub fn default_runs() -> Vec<RunSpec> {
    let r = |name: &str, role: &str, flight| RunSpec {
        name: name.into(),
        role: role.into(),
        flight,
        duration_s: 60.0,
    };
    vec![
        r("box_1", "train", Flight::Box),
        r("depth_steps", "train", Flight::DepthSteps),
        r("transects_1", "train", Flight::Transects),
        r("figure_eight", "train", Flight::FigureEight),
        r("turns", "validate", Flight::Turns),
        r("transects_2", "validate", Flight::Transects),
    ]
}

/// The reference the controller tracks at time t: pool position, depth and heading.
fn reference(f: Flight, t: f64, start: [f64; 3]) -> ([f64; 3], f64) {
    let [x0, y0, z0] = start;
    match f {
        Flight::Box => {
            let corners = [
                (x0, y0),
                (x0 + 8.0, y0),
                (x0 + 8.0, y0 + 4.0),
                (x0, y0 + 4.0),
            ];
            let i = ((t / 15.0) as usize) % 4;
            let (a, b) = (corners[i], corners[(i + 1) % 4]);
            let heading = (b.1 - a.1).atan2(b.0 - a.0);
            ([b.0, b.1, z0], heading)
        }
        Flight::DepthSteps => {
            let depth = [z0, z0 + 1.2, z0 + 0.4, z0 + 1.8][((t / 15.0) as usize) % 4];
            let heading = [0.0, 0.8, -0.6, 0.3][((t / 12.0) as usize) % 4];
            ([x0, y0, depth], heading)
        }
        Flight::Transects => {
            let out = ((t / 20.0) as usize).is_multiple_of(2);
            let x = if out { x0 + 14.0 } else { x0 };
            (
                [x, y0, z0 + 0.3 * (t / 7.0).sin()],
                if out { 0.0 } else { std::f64::consts::PI },
            )
        }
        Flight::FigureEight => {
            let w = 2.0 * std::f64::consts::PI / 30.0;
            (
                [
                    x0 + 3.0 * (w * t).sin(),
                    y0 + 1.5 * (2.0 * w * t).sin(),
                    z0 + 0.5 * (0.5 * w * t).sin(),
                ],
                0.3,
            )
        }
        Flight::Turns => {
            let heading = [0.0, 1.2, -0.4, 2.0, 0.6][((t / 10.0) as usize) % 5];
            ([x0 + 0.12 * t, y0, z0], heading)
        }
    }
}

fn wrap(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI
}

/// True state: body velocity (u, v, w, r), pool position, heading.
#[derive(Debug, Clone, Copy, Default)]
struct S {
    nu: [f64; 4],
    pos: [f64; 3],
    psi: f64,
}

pub struct Truth {
    pub t: Vec<f64>,
    pub nu: Vec<[f64; 4]>,
    pub pos: Vec<[f64; 3]>,
    pub psi: Vec<f64>,
    /// Commanded wrench at the controller's ticks (X, Y, Z, N), and their times.
    pub cmd_t: Vec<f64>,
    pub cmd: Vec<[f64; 4]>,
}

/// Environment forces on the body (buoyancy, tether), body frame [X, Y, Z, N].
fn environment(h: &Hidden, s: &S) -> [f64; 4] {
    let (c, sn) = (s.psi.cos(), s.psi.sin());
    let vx = c * s.nu[0] - sn * s.nu[1];
    let vy = sn * s.nu[0] + c * s.nu[1];
    let speed = vx.hypot(vy);
    let paid_out =
        (s.pos[0] - ANCHOR[0]).hypot(s.pos[1] - ANCHOR[1]) + s.pos[2].max(0.0) + h.tether_slack_m;
    let (fx, fy) = (
        -h.tether_k * paid_out * speed * vx,
        -h.tether_k * paid_out * speed * vy,
    );
    [c * fx + sn * fy, -sn * fx + c * fy, -h.buoyancy_up_n, 0.0]
}

fn deriv(plant: &Plant, h: &Hidden, s: &S, tau: &[f64; 4]) -> S {
    let env = environment(h, s);
    let nu6: Vec6 = [s.nu[0], s.nu[1], s.nu[2], 0.0, 0.0, s.nu[3]];
    let f: Vec6 = [
        tau[0] + env[0],
        tau[1] + env[1],
        tau[2] + env[2],
        0.0,
        0.0,
        tau[3] + env[3],
    ];
    let a = plant.accel(&nu6, &f);
    let (c, sn) = (s.psi.cos(), s.psi.sin());
    S {
        nu: [a[0], a[1], a[2], a[5]],
        pos: [
            c * s.nu[0] - sn * s.nu[1],
            sn * s.nu[0] + c * s.nu[1],
            s.nu[2],
        ],
        psi: s.nu[3],
    }
}

fn add(s: &S, d: &S, k: f64) -> S {
    S {
        nu: std::array::from_fn(|i| s.nu[i] + k * d.nu[i]),
        pos: std::array::from_fn(|i| s.pos[i] + k * d.pos[i]),
        psi: s.psi + k * d.psi,
    }
}

/// The controller: PD on position (pool frame) and heading, PI on depth, and feed-forward from
/// its own model of the vehicle, which is wrong (mass 25 kg, half the true drag, 3 N buoyancy).
struct Controller {
    depth_integral: f64,
}

impl Controller {
    fn command(&mut self, s: &S, pos_ref: [f64; 3], psi_ref: f64, dt: f64) -> [f64; 4] {
        let (c, sn) = (s.psi.cos(), s.psi.sin());
        let e = [
            pos_ref[0] - s.pos[0],
            pos_ref[1] - s.pos[1],
            pos_ref[2] - s.pos[2],
        ];
        // Desired pool-frame velocity, limited to what the pilot allows.
        let sat = |x: f64, l: f64| x.clamp(-l, l);
        let vdx = sat(0.5 * e[0], 0.9);
        let vdy = sat(0.5 * e[1], 0.6);
        let vdz = sat(0.8 * e[2], 0.4);
        let (ud, vd) = (c * vdx + sn * vdy, -sn * vdx + c * vdy);
        let rd = sat(1.2 * wrap(psi_ref - s.psi), 0.6);
        self.depth_integral = (self.depth_integral + e[2] * dt).clamp(-10.0, 10.0);
        let (m_guess, i_guess) = (25.0 + 20.0, 0.9 + 0.6);
        let ff_drag = |lin: f64, quad: f64, x: f64| 0.5 * (lin + quad * x.abs()) * x;
        [
            m_guess * 1.5 * (ud - s.nu[0]) + ff_drag(6.0, 32.0, ud),
            m_guess * 1.5 * (vd - s.nu[1]) + ff_drag(9.0, 58.0, vd),
            (25.0 + 40.0) * 2.0 * (vdz - s.nu[2])
                + ff_drag(14.0, 70.0, vdz)
                + 3.0
                + 8.0 * self.depth_integral,
            i_guess * 2.5 * (rd - s.nu[3]) + ff_drag(2.2, 1.6, rd),
        ]
    }
}

/// Flies one run; deterministic in (`seed`, run name).
pub fn simulate(h: &Hidden, spec: &RunSpec, seed: u64) -> Truth {
    let mut rng = Rng::derive(seed, &format!("field/{}/start", spec.name));
    let plant = Plant::new(&vehicle(), hydro());
    let start = [
        8.0 + 4.0 * rng.uniform(),
        5.0 + 2.0 * rng.uniform(),
        1.2 + 0.5 * rng.uniform(),
    ];
    let mut s = S {
        pos: start,
        psi: 0.4 * (2.0 * rng.uniform() - 1.0),
        ..S::default()
    };
    let mut ctl = Controller {
        depth_integral: 0.0,
    };
    let n = (spec.duration_s / STEP).round() as usize + 1;
    let mut truth = Truth {
        t: vec![],
        nu: vec![],
        pos: vec![],
        psi: vec![],
        cmd_t: vec![],
        cmd: vec![],
    };
    let mut delivered = [0.0; 4];
    for k in 0..n {
        let t = k as f64 * STEP;
        if k % CONTROL_EVERY == 0 {
            let (pr, psr) = reference(spec.flight, t, start);
            let cmd = ctl.command(&s, pr, psr, STEP * CONTROL_EVERY as f64);
            let cmd: [f64; 4] = std::array::from_fn(|i| (cmd[i] * 100.0).round() / 100.0);
            delivered = std::array::from_fn(|i| cmd[i].clamp(-h.limits[i], h.limits[i]));
            truth.cmd_t.push(t);
            truth.cmd.push(cmd);
        }
        truth.t.push(t);
        truth.nu.push(s.nu);
        truth.pos.push(s.pos);
        truth.psi.push(s.psi);
        let k1 = deriv(&plant, h, &s, &delivered);
        let k2 = deriv(&plant, h, &add(&s, &k1, STEP / 2.0), &delivered);
        let k3 = deriv(&plant, h, &add(&s, &k2, STEP / 2.0), &delivered);
        let k4 = deriv(&plant, h, &add(&s, &k3, STEP), &delivered);
        s = S {
            nu: std::array::from_fn(|i| {
                s.nu[i] + STEP / 6.0 * (k1.nu[i] + 2.0 * k2.nu[i] + 2.0 * k3.nu[i] + k4.nu[i])
            }),
            pos: std::array::from_fn(|i| {
                s.pos[i] + STEP / 6.0 * (k1.pos[i] + 2.0 * k2.pos[i] + 2.0 * k3.pos[i] + k4.pos[i])
            }),
            psi: s.psi + STEP / 6.0 * (k1.psi + 2.0 * k2.psi + 2.0 * k3.psi + k4.psi),
        };
    }
    truth
}

fn at(truth: &Truth, t: f64) -> ([f64; 4], [f64; 3], f64) {
    let x = (t / STEP).clamp(0.0, (truth.t.len() - 1) as f64);
    let i = (x.floor() as usize).min(truth.t.len() - 2);
    let w = x - i as f64;
    let l = |a: f64, b: f64| a + w * (b - a);
    (
        std::array::from_fn(|j| l(truth.nu[i][j], truth.nu[i + 1][j])),
        std::array::from_fn(|j| l(truth.pos[i][j], truth.pos[i + 1][j])),
        l(truth.psi[i], truth.psi[i + 1]),
    )
}

/// Receive times of a 50 Hz stream written in bursts: rows queue during stalls of 0.2-1.2 s
/// and are written within a millisecond when the logger wakes.
fn bursty(send: &[f64], rng: &mut Rng) -> Vec<f64> {
    let mut out = Vec::with_capacity(send.len());
    let mut release = send.first().copied().unwrap_or(0.0);
    for &s in send {
        if s > release {
            release = s + 0.2 + rng.uniform();
        }
        let r = release.max(s) + 1e-5 * (out.len() % 60) as f64;
        out.push(out.last().map_or(r, |p: &f64| p.max(r)));
    }
    out
}

/// The run's files: run.yaml, thrust.csv, nav.csv, depth.csv, uwb.csv.
pub fn render(h: &Hidden, spec: &RunSpec, truth: &Truth, seed: u64) -> Vec<(&'static str, String)> {
    let mut rng = Rng::derive(seed, &format!("field/{}/sensors", spec.name));
    let end = *truth.t.last().expect("a run has samples");
    let mut files = vec![("run.yaml", run_yaml(spec))];
    // The command log starts before the navigation log and stops after it.
    let recv = bursty(&truth.cmd_t, &mut rng);
    files.push(("thrust.csv", thrust_csv(&recv, truth)));
    // The sensors draw their noise from one stream, in this order.
    files.push(("nav.csv", nav_csv(h, truth, end, &mut rng)));
    files.push(("depth.csv", depth_csv(truth, end, &mut rng)));
    files.push(("uwb.csv", uwb_csv(truth, end, &mut rng)));
    files
}

/// `run.yaml`: role, description, the pool and the tether's anchor.
fn run_yaml(spec: &RunSpec) -> String {
    format!(
        "role: {}\ndescription: \"{:?} flight of a tethered 30 kg ROV under closed-loop control, {:.0} s (synthetic: hydrofit twin field)\"\npool: {{length_m: {}, width_m: {}, depth_m: {}}}\ntether_anchor_m: [{}, {}, {}]\n",
        spec.role,
        spec.flight,
        spec.duration_s,
        POOL.length_m,
        POOL.width_m,
        POOL.depth_m,
        ANCHOR[0],
        ANCHOR[1],
        ANCHOR[2]
    )
}

/// `thrust.csv`: the controller's commands by their receive times.
fn thrust_csv(recv: &[f64], truth: &Truth) -> String {
    let mut thrust = String::from("t,X_N,Y_N,Z_N,N_Nm\n");
    for (t, c) in recv.iter().zip(&truth.cmd) {
        let _ = writeln!(
            thrust,
            "{:.4},{:.2},{:.2},{:.2},{:.3}",
            t, c[0], c[1], c[2], c[3]
        );
    }
    thrust
}

/// The DVL's sample interval, s (8 Hz).
pub const DVL_PERIOD_S: f64 = 0.125;
/// The DVL's velocity noise (standard deviation of each sample), m/s.
pub const DVL_NOISE_M_S: f64 = 0.01;

/// `nav.csv`: the navigation filter's output. DVL velocity (1 cm/s noise, at `dvl_at_m`) at
/// 8 Hz through an exponential low-pass, written at an irregular 5-7 Hz, `nav_latency_s` late; AHRS heading
/// with 0.4 deg noise.
fn nav_csv(h: &Hidden, truth: &Truth, end: f64, rng: &mut Rng) -> String {
    let mut nav = String::from("t,u_m_s,v_m_s,w_m_s,roll_deg,pitch_deg,yaw_deg\n");
    let mut filt = [0.0f64; 3];
    let (mut t_dvl, mut t_out) = (0.6, 0.6 + 0.2 * rng.uniform());
    while t_out < end - 0.6 {
        while t_dvl <= t_out - h.nav_latency_s {
            let (nu, _, _) = at(truth, t_dvl);
            let a = (-DVL_PERIOD_S / h.nav_filter_s).exp();
            let lever = [-nu[3] * h.dvl_at_m[1], nu[3] * h.dvl_at_m[0], 0.0];
            for i in 0..3 {
                let measured = nu[i] + lever[i];
                filt[i] = a * filt[i] + (1.0 - a) * (measured + DVL_NOISE_M_S * rng.normal());
            }
            t_dvl += DVL_PERIOD_S;
        }
        let (_, _, psi) = at(truth, t_out - h.nav_latency_s);
        let yaw = wrap(psi + 0.4f64.to_radians() * rng.normal()).to_degrees();
        let _ = writeln!(
            nav,
            "{:.4},{:.4},{:.4},{:.4},{:.2},{:.2},{:.2}",
            t_out,
            filt[0],
            filt[1],
            filt[2],
            0.3 * rng.normal(),
            0.3 * rng.normal(),
            yaw
        );
        t_out += 1.0 / (5.0 + 2.0 * rng.uniform());
    }
    nav
}

/// `depth.csv`: the depth sensor at 10 Hz, 1 cm noise.
fn depth_csv(truth: &Truth, end: f64, rng: &mut Rng) -> String {
    let mut depth = String::from("t,depth_m\n");
    let mut t = 0.4;
    while t < end - 0.3 {
        let (_, p, _) = at(truth, t);
        let _ = writeln!(depth, "{:.3},{:.4}", t, p[2] + 0.01 * rng.normal());
        t += 0.1;
    }
    depth
}

/// `uwb.csv`: horizontal UWB fixes at 10 Hz, 5 cm noise, 2 % jumps of 1.5 m.
fn uwb_csv(truth: &Truth, end: f64, rng: &mut Rng) -> String {
    let mut uwb = String::from("t,x_m,y_m\n");
    let mut t = 0.5;
    while t < end - 0.4 {
        let (_, p, _) = at(truth, t);
        let jump = if rng.uniform() < 0.02 { 1.5 } else { 0.0 };
        let _ = writeln!(
            uwb,
            "{:.3},{:.3},{:.3}",
            t,
            p[0] + 0.05 * rng.normal() + jump,
            p[1] + 0.05 * rng.normal()
        );
        t += 0.1;
    }
    uwb
}

/// True motion on the controller's clock: `t,u,v,w,r,x_m,y_m,z_m,psi_rad`.
pub fn truth_csv(truth: &Truth) -> String {
    let mut out = String::from("t,u,v,w,r,x_m,y_m,z_m,psi_rad\n");
    for k in (0..truth.t.len()).step_by(CONTROL_EVERY) {
        let (nu, p) = (truth.nu[k], truth.pos[k]);
        let _ = writeln!(
            out,
            "{:.3},{:.6},{:.6},{:.6},{:.6},{:.5},{:.5},{:.5},{:.6}",
            truth.t[k], nu[0], nu[1], nu[2], nu[3], p[0], p[1], p[2], truth.psi[k]
        );
    }
    out
}

/// Writes `cases_dir/<run>/` and `truth_dir/<run>.{csv,json}` for every run.
pub fn write_runs(
    cases_dir: &Path,
    truth_dir: &Path,
    runs: &[RunSpec],
    h: &Hidden,
    seed: u64,
) -> anyhow::Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for spec in runs {
        let truth = simulate(h, spec, seed);
        let record = serde_json::json!({"run": spec.name, "seed": seed, "hidden": h, "spec": spec, "vehicle": vehicle(), "hydro": {"added": hydro().added, "lin": hydro().lin, "quad": hydro().quad}});
        written.push(super::write_run(
            cases_dir,
            truth_dir,
            &spec.name,
            &render(h, spec, &truth, seed),
            &truth_csv(&truth),
            &record,
        )?);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The controller keeps every flight in the pool, the thrusters saturate at times (as a
    /// real controller's do), and the vehicle moves in every DOF.
    #[test]
    fn flights_stay_in_the_pool_and_exercise_the_vehicle() {
        let h = Hidden::default();
        let mut all_peaks = [0.0f64; 4];
        for spec in default_runs() {
            let truth = simulate(&h, &spec, 1);
            for p in &truth.pos {
                assert!(
                    p[0] > 0.5
                        && p[0] < POOL.length_m - 0.5
                        && p[1] > 0.5
                        && p[1] < POOL.width_m - 0.5
                        && p[2] > 0.1
                        && p[2] < POOL.depth_m,
                    "{}: {p:?}",
                    spec.name
                );
            }
            let peak: [f64; 4] =
                std::array::from_fn(|j| truth.nu.iter().fold(0.0f64, |a, n| a.max(n[j].abs())));
            // Every flight turns and translates; together they move the vehicle in every DOF.
            assert!(
                peak[3] > 0.02 && peak[..3].iter().any(|p| *p > 0.1) && peak[0] < 2.0,
                "{}: peaks {peak:?}",
                spec.name
            );
            for j in 0..4 {
                all_peaks[j] = all_peaks[j].max(peak[j]);
            }
        }
        assert!(
            all_peaks.iter().all(|p| *p > 0.1),
            "a DOF no flight moves in: {all_peaks:?}"
        );
        let t = simulate(&h, &default_runs()[2], 1);
        let clipped = t
            .cmd
            .iter()
            .filter(|c| (0..4).any(|i| c[i].abs() > h.limits[i]))
            .count();
        assert!(clipped > 0, "transects never saturate the thrusters");
    }
}
