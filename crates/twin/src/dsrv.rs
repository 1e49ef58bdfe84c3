//! The DSRV twin of seed 000: the longitudinal (diving) dynamics of a Deep Submergence Rescue
//! Vehicle at its 8-knot cruise, in Healey's non-dimensional stability derivatives as Fossen's
//! GNC toolbox gives them (the model seed 000 section 2.1 identifies), driven open loop by a
//! pseudo-random binary sequence on the stern plane. On the `drift` run the stern plane loses
//! 40 % of its effectiveness half-way (fouling or damage): the parameter RLS must follow.
//! Written as pool runs: `actuators.csv` (stern plane), `nav.csv` (DVL velocities, AHRS pitch
//! and pitch rate), `depth.csv`; no `thrust.csv`. Simulated here with its own RK4; the
//! identifier never sees this code.

use hydrofit_core::rng::Rng;
use serde::Serialize;

/// Healey's DSRV (non-dimensional, prime system) at speed `u0` (m/s), length `l` (m).
#[derive(Debug, Clone, Serialize)]
pub struct Dsrv {
    pub l: f64,
    pub u0: f64,
    pub iy: f64,
    pub m: f64,
    pub m_qdot: f64,
    pub z_qdot: f64,
    pub m_wdot: f64,
    pub z_wdot: f64,
    pub m_q: f64,
    pub z_q: f64,
    pub m_w: f64,
    pub z_w: f64,
    pub m_theta: f64,
    pub m_delta: f64,
    pub z_delta: f64,
}

impl Dsrv {
    pub fn healey() -> Dsrv {
        let u0 = 4.11;
        Dsrv {
            l: 8.534,
            u0,
            iy: 0.001925,
            m: 0.036391,
            m_qdot: -0.001573,
            z_qdot: -0.000130,
            m_wdot: -0.000146,
            z_wdot: -0.031545,
            m_q: -0.01131,
            z_q: -0.017455,
            m_w: 0.011175,
            z_w: -0.043938,
            m_theta: -0.156276 / (u0 * u0),
            m_delta: -0.012797,
            z_delta: 0.027695,
        }
    }

    /// d/dt of (w, q, theta, depth) under stern plane `delta` (rad), SI states.
    pub fn deriv(&self, x: &[f64; 4], delta: f64) -> [f64; 4] {
        let [w, q, th, _] = *x;
        let (wn, qn) = (w / self.u0, q * self.l / self.u0);
        let z = self.z_q * qn + self.z_w * wn + self.z_delta * delta;
        let mm = self.m_q * qn + self.m_w * wn + self.m_theta * th + self.m_delta * delta;
        let (m11, m12) = (self.m - self.z_wdot, -self.z_qdot);
        let (m21, m22) = (-self.m_wdot, self.iy - self.m_qdot);
        let det = m11 * m22 - m12 * m21;
        let s = self.u0 * self.u0 / self.l;
        [
            (m22 * z - m12 * mm) / det * s,
            (-m21 * z + m11 * mm) / det * s / self.l,
            q,
            w * th.cos() - self.u0 * th.sin(),
        ]
    }

    /// The coefficients of `dw/dt` and `dq/dt` in w, q, pitch and stern: what the integrated
    /// regressor identifies (seed 000's 8-vector theta), exact since the model is linear in
    /// them.
    pub fn coefficients(&self) -> [[f64; 4]; 2] {
        let base = self.deriv(&[0.0; 4], 0.0);
        let mut c = [[0.0; 4]; 2];
        for j in 0..4 {
            let mut x = [0.0; 4];
            let mut d = 0.0;
            if j < 3 {
                x[j] = 1.0;
            } else {
                d = 1.0;
            }
            let f = self.deriv(&x, d);
            c[0][j] = f[0] - base[0];
            c[1][j] = f[1] - base[1];
        }
        c
    }
}

/// One run: PRBS seed, length, role, and when (if ever) the stern plane loses effectiveness.
#[derive(Debug, Clone, Serialize)]
pub struct Run {
    pub name: String,
    pub role: &'static str,
    pub seed: u64,
    pub duration_s: f64,
    pub drift_at_s: Option<f64>,
}

/// Stern-plane effectiveness after the drift.
pub const DRIFT_FACTOR: f64 = 0.6;
const AMPLITUDE: f64 = 0.087;
const DT: f64 = 0.01;

pub fn default_runs() -> Vec<Run> {
    let run = |name: &str, role, seed, duration_s, drift_at_s| Run {
        name: name.into(),
        role,
        seed,
        duration_s,
        drift_at_s,
    };
    vec![
        run("steady_1", "train", 1, 1000.0, None),
        run("steady_2", "validate", 2, 500.0, None),
        run("drift", "train", 3, 1000.0, Some(500.0)),
    ]
}

/// True states at 10 Hz.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Record {
    pub t: Vec<f64>,
    pub delta: Vec<f64>,
    pub x: Vec<[f64; 4]>,
}

/// Flies `run`: the stern plane at +-5 degrees, a new random bit every 2 s.
pub fn fly(base: &Dsrv, run: &Run) -> Record {
    let mut rng = Rng::derive(run.seed, "dsrv-prbs");
    let mut x = [0.0, 0.0, 0.0, 50.0];
    let mut delta = AMPLITUDE;
    let mut rec = Record::default();
    let n = (run.duration_s / DT).round() as usize;
    let mut v = base.clone();
    for k in 0..=n {
        let t = k as f64 * DT;
        if run.drift_at_s.is_some_and(|d| t >= d) {
            v.m_delta = base.m_delta * DRIFT_FACTOR;
        }
        if k % 200 == 0 {
            delta = if rng.uniform() < 0.5 {
                AMPLITUDE
            } else {
                -AMPLITUDE
            };
        }
        if k % 10 == 0 {
            rec.t.push(t);
            rec.delta.push(delta);
            rec.x.push(x);
        }
        let add = |a: &[f64; 4], b: &[f64; 4], s: f64| std::array::from_fn(|i| a[i] + s * b[i]);
        let k1 = v.deriv(&x, delta);
        let k2 = v.deriv(&add(&x, &k1, DT / 2.0), delta);
        let k3 = v.deriv(&add(&x, &k2, DT / 2.0), delta);
        let k4 = v.deriv(&add(&x, &k3, DT), delta);
        x = std::array::from_fn(|i| x[i] + DT / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
    }
    rec
}

/// The run's files with sensor noise: DVL w 5 mm/s, AHRS pitch 0.02 deg, pitch rate
/// 0.02 deg/s, depth 1 cm.
pub fn files(run: &Run, rec: &Record, u0: f64, seed: u64) -> Vec<(&'static str, String)> {
    let mut rng = Rng::derive(seed ^ run.seed, "dsrv-noise");
    let mut act = String::from("t,stern_deg\n");
    let mut nav = String::from("t,u_m_s,w_m_s,pitch_deg,q_dps\n");
    let mut depth = String::from("t,depth_m\n");
    for (k, t) in rec.t.iter().enumerate() {
        let [w, q, th, z] = rec.x[k];
        act += &format!("{t:.1},{:.4}\n", rec.delta[k].to_degrees());
        nav += &format!(
            "{t:.1},{:.4},{:.5},{:.4},{:.4}\n",
            u0 + 0.005 * rng.normal(),
            w + 0.005 * rng.normal(),
            th.to_degrees() + 0.02 * rng.normal(),
            q.to_degrees() + 0.02 * rng.normal()
        );
        depth += &format!("{t:.1},{:.3}\n", z + 0.01 * rng.normal());
    }
    let drift = run.drift_at_s.map_or(String::new(), |d| {
        format!(", stern plane effectiveness x{DRIFT_FACTOR} from {d} s")
    });
    let meta = format!(
        "role: {}\ndescription: \"DSRV twin (synthetic): 8 kn, PRBS +-5 deg on the stern plane, seed {}{drift}\"\n",
        run.role, run.seed
    );
    vec![
        ("run.yaml", meta),
        ("actuators.csv", act),
        ("nav.csv", nav),
        ("depth.csv", depth),
    ]
}

/// The names seed 000's parameters take in the `integrated` stage of examples/dsrv.
pub const NAMES: [[&str; 4]; 2] = [
    ["dw/dt:w", "dw/dt:q", "dw/dt:pitch", "dw/dt:stern"],
    ["dq/dt:w", "dq/dt:q", "dq/dt:pitch", "dq/dt:stern"],
];

/// `truth/coefficients.csv`: every coefficient, and the stern plane's after the drift as
/// `<name>@<t>`.
pub fn truth_csv(v: &Dsrv, drift_at: f64) -> String {
    let mut s = String::from("name,value\n");
    let c = v.coefficients();
    for (names, row) in NAMES.iter().zip(c) {
        for (n, x) in names.iter().zip(row) {
            s += &format!("{n},{x}\n");
        }
    }
    let mut after = v.clone();
    after.m_delta *= DRIFT_FACTOR;
    let c = after.coefficients();
    for i in 0..2 {
        s += &format!("{}@{drift_at},{}\n", NAMES[i][3], c[i][3]);
    }
    s
}

/// Writes every run into `cases_dir` and the truth into `truth_dir`.
pub fn write_runs(
    cases_dir: &std::path::Path,
    truth_dir: &std::path::Path,
    seed: u64,
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    let v = Dsrv::healey();
    let mut out = Vec::new();
    for run in default_runs() {
        let rec = fly(&v, &run);
        let mut csv = String::from("t,u,w,q,pitch_rad,depth_m,stern_rad\n");
        for (k, t) in rec.t.iter().enumerate() {
            let [w, q, th, z] = rec.x[k];
            csv += &format!("{t},{},{w},{q},{th},{z},{}\n", v.u0, rec.delta[k]);
        }
        let files = files(&run, &rec, v.u0, seed);
        out.push(super::write_run(
            cases_dir, truth_dir, &run.name, &files, &csv, &run,
        )?);
    }
    let drift = default_runs()
        .iter()
        .find_map(|r| r.drift_at_s)
        .unwrap_or(0.0);
    hydrofit_core::fsutil::write_atomic(
        &truth_dir.join("coefficients.csv"),
        truth_csv(&v, drift).as_bytes(),
    )?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dsrv_is_stable_and_the_prbs_keeps_it_near_level() {
        let v = Dsrv::healey();
        let c = v.coefficients();
        // The (w, q, theta) system matrix has eigenvalues in the left half plane.
        let a = nalgebra::Matrix3::new(
            c[0][0], c[0][1], c[0][2], c[1][0], c[1][1], c[1][2], 0.0, 1.0, 0.0,
        );
        let ev = a.complex_eigenvalues();
        assert!(ev.iter().all(|z| z.re < 0.0), "{ev:?}");
        let rec = fly(&v, &default_runs()[0]);
        let pitch = rec.x.iter().map(|x| x[2].abs()).fold(0.0, f64::max);
        assert!(pitch > 0.01 && pitch < 0.3, "pitch excursion {pitch}");
    }
}
