//! The tank twin of seed 002: a 1.6 m submarine model running free at 1 m/s in a towing tank,
//! its longitudinal motion (heave, pitch, depth) excited through its depth controller by a
//! pseudo-random binary sequence on the ordered depth (the paper's section 2 strategy), the
//! elevator behind a first-order servo whose angle is not measured: the command is logged,
//! as in the paper. Written as a pool run the field stages read: `actuators.csv` (elevator
//! command), `imu.csv` (inclinometer pitch and rate gyro), `depth.csv`, no `thrust.csv`.
//!
//! The plant is the linear stability-derivative model of seed 002 eq. 2.1 for heave and pitch
//! at constant speed, simulated here with its own 4th-order Runge-Kutta; the ARX stage never
//! sees this code.

use hydrofit_core::rng::Rng;
use nalgebra::{Matrix2, Matrix4, Vector2};
use serde::Serialize;

/// Stability derivatives (dimensional, SI) of the model at speed `u0`.
#[derive(Debug, Clone, Serialize)]
pub struct Plant {
    pub u0: f64,
    pub mass: f64,
    pub iyy: f64,
    pub z_wdot: f64,
    pub z_qdot: f64,
    pub m_wdot: f64,
    pub m_qdot: f64,
    pub z_w: f64,
    pub z_q: f64,
    pub m_w: f64,
    pub m_q: f64,
    /// Hydrostatic pitch stiffness `-z_G W`, N m/rad.
    pub m_theta: f64,
    pub z_delta: f64,
    pub m_delta: f64,
    /// Elevator servo time constant, s.
    pub servo_tau: f64,
}

impl Plant {
    pub fn model() -> Plant {
        Plant {
            u0: 1.0,
            mass: 60.0,
            iyy: 11.0,
            z_wdot: -52.0,
            z_qdot: -2.5,
            m_wdot: -2.5,
            m_qdot: -7.5,
            z_w: -75.0,
            z_q: -22.0,
            m_w: 14.0,
            m_q: -32.0,
            m_theta: -14.7,
            z_delta: -38.0,
            m_delta: -21.0,
            servo_tau: 0.25,
        }
    }

    fn mass_matrix(&self) -> Matrix2<f64> {
        Matrix2::new(
            self.mass - self.z_wdot,
            -self.z_qdot,
            -self.m_wdot,
            self.iyy - self.m_qdot,
        )
    }

    /// d/dt of (w, q, theta, z, delta) under elevator command `cmd` (z down, theta nose up).
    fn deriv(&self, x: &[f64; 5], cmd: f64) -> [f64; 5] {
        let [w, q, th, _z, d] = *x;
        let f = Vector2::new(
            self.z_w * w + (self.mass * self.u0 + self.z_q) * q + self.z_delta * d,
            self.m_w * w + self.m_q * q + self.m_theta * th + self.m_delta * d,
        );
        let acc = self
            .mass_matrix()
            .lu()
            .solve(&f)
            .expect("mass matrix invertible");
        [
            acc[0],
            acc[1],
            q,
            w * th.cos() - self.u0 * th.sin(),
            (cmd - d) / self.servo_tau,
        ]
    }

    /// The linearised system matrix over (w, q, theta, delta) (depth is an integrator).
    pub fn system(&self) -> Matrix4<f64> {
        let mut a = Matrix4::zeros();
        let x0 = [0.0; 5];
        let base = self.deriv(&x0, 0.0);
        for (j, col) in [0usize, 1, 2, 4].iter().enumerate() {
            let mut x = x0;
            x[*col] = 1.0;
            let d = self.deriv(&x, 0.0);
            for (i, row) in [0usize, 1, 2, 4].iter().enumerate() {
                a[(i, j)] = d[*row] - base[*row];
            }
        }
        a
    }

    /// Continuous poles of the system (w, q, theta, servo), as (re, im).
    pub fn poles(&self) -> Vec<[f64; 2]> {
        let mut p: Vec<[f64; 2]> = self
            .system()
            .complex_eigenvalues()
            .iter()
            .map(|z| [z.re, z.im])
            .collect();
        p.sort_by(|a, b| b[0].total_cmp(&a[0]));
        p
    }

    /// Steady (w, q, theta) per radian of elevator held (the model trimmed).
    fn trim(&self) -> nalgebra::Vector3<f64> {
        let a = self.system();
        let sub = a.fixed_view::<3, 3>(0, 0).into_owned();
        let b = a.fixed_view::<3, 1>(0, 3).into_owned();
        sub.lu().solve(&(-b)).expect("trimmable")
    }

    /// Steady pitch per radian of elevator.
    pub fn pitch_gain(&self) -> f64 {
        self.trim()[2]
    }

    /// Steady depth rate per radian of elevator (`w - U theta`, linearised).
    pub fn depth_rate_gain(&self) -> f64 {
        let x = self.trim();
        x[0] - self.u0 * x[2]
    }
}

/// One run: its PRBS seed, length, role.
#[derive(Debug, Clone, Serialize)]
pub struct Run {
    pub name: String,
    pub role: &'static str,
    pub seed: u64,
    pub duration_s: f64,
}

pub fn default_runs() -> Vec<Run> {
    vec![
        Run {
            name: "test1".into(),
            role: "train",
            seed: 1,
            duration_s: 240.0,
        },
        Run {
            name: "test2".into(),
            role: "validate",
            seed: 2,
            duration_s: 240.0,
        },
    ]
}

/// The true motion at the log rate (10 Hz).
#[derive(Debug, Clone, Serialize)]
pub struct Record {
    pub t: Vec<f64>,
    pub cmd: Vec<f64>,
    pub elevator: Vec<f64>,
    pub w: Vec<f64>,
    pub q: Vec<f64>,
    pub theta: Vec<f64>,
    pub z: Vec<f64>,
}

const DT: f64 = 0.01;
const LOG_EVERY: usize = 10;
/// Depth controller gains (rad per m, rad per rad, rad per rad/s) and its rate.
const KZ: f64 = 0.5;
const KTH: f64 = 1.6;
const KQ: f64 = 0.8;
const DEPTH: f64 = 1.5;
const LIMIT: f64 = 0.4;

/// Flies `run`: a PRBS of +-0.25 m on the ordered depth (one bit every 3 s, each bit random),
/// the controller and the logs at 10 Hz.
pub fn fly(p: &Plant, run: &Run) -> Record {
    let mut rng = Rng::derive(run.seed, "tank-prbs");
    let n = (run.duration_s / DT).round() as usize;
    let mut x = [0.0, 0.0, 0.0, DEPTH, 0.0];
    let mut rec = Record {
        t: vec![],
        cmd: vec![],
        elevator: vec![],
        w: vec![],
        q: vec![],
        theta: vec![],
        z: vec![],
    };
    let mut order = DEPTH;
    let mut cmd = 0.0;
    for k in 0..=n {
        let t = k as f64 * DT;
        if k % 300 == 0 && t >= 5.0 {
            order = DEPTH + if rng.uniform() < 0.5 { 0.25 } else { -0.25 };
        }
        if k % LOG_EVERY == 0 {
            // Controller at the log rate: nose down (negative pitch) to go deeper.
            cmd = (KZ * (order - x[3]) + KTH * x[2] + KQ * x[1]).clamp(-LIMIT, LIMIT);
            rec.t.push(t);
            rec.cmd.push(cmd);
            rec.elevator.push(x[4]);
            rec.w.push(x[0]);
            rec.q.push(x[1]);
            rec.theta.push(x[2]);
            rec.z.push(x[3]);
        }
        x = rk4(p, &x, cmd);
    }
    rec
}

fn rk4(p: &Plant, x: &[f64; 5], cmd: f64) -> [f64; 5] {
    let add = |a: &[f64; 5], b: &[f64; 5], s: f64| std::array::from_fn(|i| a[i] + s * b[i]);
    let k1 = p.deriv(x, cmd);
    let k2 = p.deriv(&add(x, &k1, DT / 2.0), cmd);
    let k3 = p.deriv(&add(x, &k2, DT / 2.0), cmd);
    let k4 = p.deriv(&add(x, &k3, DT), cmd);
    std::array::from_fn(|i| x[i] + DT / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
}

/// The run's files: run.yaml, actuators.csv, imu.csv (pitch and its rate only, with
/// inclinometer and gyro noise), depth.csv.
pub fn files(run: &Run, rec: &Record, seed: u64) -> Vec<(&'static str, String)> {
    let mut rng = Rng::derive(seed ^ run.seed, "tank-noise");
    let mut act = String::from("t,elevator_deg\n");
    let mut imu = String::from("t,pitch_deg,q_dps\n");
    let mut depth = String::from("t,depth_m\n");
    for k in 0..rec.t.len() {
        let t = rec.t[k];
        act += &format!("{t:.2},{:.3}\n", rec.cmd[k].to_degrees());
        let pitch = rec.theta[k].to_degrees() + 0.05 * rng.normal();
        let q = rec.q[k].to_degrees() + 0.1 * rng.normal();
        imu += &format!("{t:.2},{pitch:.4},{q:.4}\n");
        depth += &format!("{t:.2},{:.5}\n", rec.z[k] + 0.002 * rng.normal());
    }
    let meta = format!(
        "role: {}\ndescription: \"tank twin (synthetic): free run at 1 m/s, PRBS +-0.25 m on the ordered depth through the depth controller, seed {}\"\n",
        run.role, run.seed
    );
    vec![
        ("run.yaml", meta),
        ("actuators.csv", act),
        ("imu.csv", imu),
        ("depth.csv", depth),
    ]
}

/// The truth a report compares with: the plant's continuous poles and its steady pitch gain.
pub fn truth_csv(p: &Plant) -> String {
    let mut s = String::from("name,value,unit\n");
    s += &format!("pitch_gain,{},rad/rad\n", p.pitch_gain());
    s += &format!("depth_rate_gain,{},(m/s)/rad\n", p.depth_rate_gain());
    for (i, z) in p.poles().iter().enumerate() {
        s += &format!(
            "pole{}_re,{},1/s\npole{}_im,{},1/s\n",
            i + 1,
            z[0],
            i + 1,
            z[1]
        );
    }
    s
}

/// Writes every run into `cases_dir` and the truth into `truth_dir`.
pub fn write_runs(
    cases_dir: &std::path::Path,
    truth_dir: &std::path::Path,
    seed: u64,
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    let p = Plant::model();
    let mut out = Vec::new();
    for run in default_runs() {
        let rec = fly(&p, &run);
        let csv = record_csv(&rec);
        out.push(super::write_run(
            cases_dir,
            truth_dir,
            &run.name,
            &files(&run, &rec, seed),
            &csv,
            &run,
        )?);
    }
    hydrofit_core::fsutil::write_atomic(&truth_dir.join("transfer.csv"), truth_csv(&p).as_bytes())?;
    Ok(out)
}

/// The true motion in the truth-file layout (`t` and body velocities) with the elevator,
/// pitch and depth after them.
fn record_csv(rec: &Record) -> String {
    let mut s = String::from("t,u,w,q,cmd_rad,elevator_rad,pitch_rad,depth_m\n");
    for k in 0..rec.t.len() {
        s += &format!(
            "{},{},{},{},{},{},{},{}\n",
            rec.t[k], 1.0, rec.w[k], rec.q[k], rec.cmd[k], rec.elevator[k], rec.theta[k], rec.z[k]
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_model_is_stable_and_the_controller_holds_depth() {
        let p = Plant::model();
        assert!(p.poles().iter().all(|z| z[0] < 0.0), "{:?}", p.poles());
        let rec = fly(&p, &default_runs()[0]);
        let dev = rec.z.iter().map(|z| (z - DEPTH).abs()).fold(0.0, f64::max);
        assert!(dev < 0.6 && dev > 0.15, "depth excursion {dev}");
        let pitch = rec.theta.iter().map(|x| x.abs()).fold(0.0, f64::max);
        assert!(pitch < 0.35, "pitch {pitch}");
        let sat = rec.cmd.iter().filter(|c| c.abs() >= LIMIT).count();
        assert!(sat * 20 < rec.cmd.len(), "elevator saturated {sat} times");
    }
}
