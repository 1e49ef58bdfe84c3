//! The six-DOF twin's trials written as a vehicle records them (seed 003 Table III): the
//! command log with K and M, a navigation log from a DVL (sigma 3 mm/s, pinging at 5 Hz with
//! jitter) and an inertial navigation system (attitude 0.01 deg, heading 0.02 deg, rates
//! 0.01 deg/s, 10 Hz), a depth gauge; the true motion apart, in the truth folder.

use super::{Record, Trial};
use hydrofit_core::rng::Rng;
use std::fmt::Write;

/// Sensor noise, seed 003 Table III (depth: a Paroscientific gauge, about 2 mm).
const DVL_SIGMA: f64 = 0.003;
const ATTITUDE_SIGMA_DEG: f64 = 0.01;
const HEADING_SIGMA_DEG: f64 = 0.02;
const RATE_SIGMA_DPS: f64 = 0.01;
const DEPTH_SIGMA: f64 = 0.002;

/// The record linearly interpolated at time `t`.
fn at(rec: &Record, t: f64) -> ([f64; 6], [f64; 6]) {
    let x = (t / super::STEP).clamp(0.0, (rec.t.len() - 1) as f64);
    let i = (x.floor() as usize).min(rec.t.len() - 2);
    let w = x - i as f64;
    let l = |a: &[f64; 6], b: &[f64; 6]| std::array::from_fn(|j| a[j] + w * (b[j] - a[j]));
    (
        l(&rec.nu[i], &rec.nu[i + 1]),
        l(&rec.eta[i], &rec.eta[i + 1]),
    )
}

/// Sample times at `rate` Hz with up to a fifth of a period of jitter, inside the record.
fn jittered(rec: &Record, rate: f64, rng: &mut Rng) -> Vec<f64> {
    let end = *rec.t.last().expect("a record has samples");
    let period = 1.0 / rate;
    (0..)
        .map(|k| k as f64 * period + 0.2 * period * rng.uniform())
        .take_while(|t| *t <= end)
        .collect()
}

fn thrust_csv(rec: &Record) -> String {
    let mut s = String::from("t,X_N,Y_N,Z_N,N_Nm,K_Nm,M_Nm\n");
    for k in (0..rec.t.len()).step_by(super::COMMAND_EVERY) {
        let c = rec.tau[k];
        let _ = writeln!(
            s,
            "{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3}",
            rec.t[k], c[0], c[1], c[2], c[5], c[3], c[4]
        );
    }
    s
}

/// The navigation log: a row every 0.1 s from the inertial system; the DVL's velocity
/// columns are filled every other row (its 5 Hz pings) and empty in between.
fn nav_csv(rec: &Record, rng: &mut Rng) -> String {
    let mut s = String::from("t,u_m_s,v_m_s,w_m_s,roll_deg,pitch_deg,yaw_deg,p_dps,q_dps,r_dps\n");
    for (k, t) in jittered(rec, 10.0, rng).into_iter().enumerate() {
        let (nu, eta) = at(rec, t);
        let mut n = |sigma: f64| sigma * rng.normal();
        let vel = match k % 2 {
            0 => (0..3)
                .map(|j| format!("{:.4}", nu[j] + n(DVL_SIGMA)))
                .collect::<Vec<_>>()
                .join(","),
            _ => ",,".into(),
        };
        let deg = f64::to_degrees;
        let yaw = deg(eta[5]).rem_euclid(360.0);
        let _ = writeln!(
            s,
            "{t:.3},{vel},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
            deg(eta[3]) + n(ATTITUDE_SIGMA_DEG),
            deg(eta[4]) + n(ATTITUDE_SIGMA_DEG),
            yaw + n(HEADING_SIGMA_DEG),
            deg(nu[3]) + n(RATE_SIGMA_DPS),
            deg(nu[4]) + n(RATE_SIGMA_DPS),
            deg(nu[5]) + n(RATE_SIGMA_DPS),
        );
    }
    s
}

fn depth_csv(rec: &Record, rng: &mut Rng) -> String {
    let mut s = String::from("t,depth_m\n");
    for t in jittered(rec, 10.0, rng) {
        let (_, eta) = at(rec, t);
        let _ = writeln!(s, "{t:.3},{:.4}", eta[2] + DEPTH_SIGMA * rng.normal());
    }
    s
}

/// The true motion at the command times: t, body velocities, pose.
pub fn truth_csv(rec: &Record) -> String {
    let mut s = String::from("t,u,v,w,p,q,r,x,y,z,roll,pitch,yaw\n");
    for k in (0..rec.t.len()).step_by(super::COMMAND_EVERY) {
        let row: Vec<String> = rec.nu[k]
            .iter()
            .chain(&rec.eta[k])
            .map(|x| format!("{x:.6}"))
            .collect();
        let _ = writeln!(s, "{:.3},{}", rec.t[k], row.join(","));
    }
    s
}

/// The run folder's files of a flown trial.
pub fn files(trial: &Trial, rec: &Record, seed: u64) -> Vec<(&'static str, String)> {
    let mut rng = Rng::new(seed);
    let yaml = format!(
        "role: {}\ndescription: \"{} of a 240 kg 6-DOF ROV, {:.0} s: closed-loop sinusoidal surge, sway, heave references and open-loop roll, pitch, yaw moments (seed 003 Table II; synthetic: hydrofit twin six-dof)\"\n",
        trial.role.as_str(),
        trial.name,
        trial.duration_s
    );
    vec![
        ("run.yaml", yaml),
        ("thrust.csv", thrust_csv(rec)),
        ("nav.csv", nav_csv(rec, &mut rng)),
        ("depth.csv", depth_csv(rec, &mut rng)),
    ]
}

/// Flies and writes every trial: runs into `cases_dir`, truth into `truth_dir`.
pub fn write_trials(
    cases_dir: &std::path::Path,
    truth_dir: &std::path::Path,
    trials: &[Trial],
    seed: u64,
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    let v = super::vehicle();
    let h = super::truth();
    let body = super::Body::new(&v, &h);
    let layout = hydrofit_core::model::ParamLayout::of(&v);
    let mut table = String::from("name,value\n");
    for (name, value) in layout.names().iter().zip(layout.from_hydro(&h)) {
        let _ = writeln!(table, "{name},{value}");
    }
    std::fs::create_dir_all(truth_dir)?;
    hydrofit_core::fsutil::write_atomic(&truth_dir.join("parameters.csv"), table.as_bytes())?;
    let mut out = Vec::new();
    for (i, trial) in trials.iter().enumerate() {
        let rec = super::fly(&body, &v, trial);
        let files = files(trial, &rec, seed.wrapping_add(i as u64 * 7919));
        let record =
            serde_json::json!({"trial": trial, "truth": "twin::six::truth()", "seed": seed});
        out.push(super::super::write_run(
            cases_dir,
            truth_dir,
            &trial.name,
            &files,
            &truth_csv(&rec),
            &record,
        )?);
    }
    Ok(out)
}
