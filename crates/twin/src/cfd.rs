//! Synthetic STAR-CCM+ DFBI exports of the reference vehicle: a constant body-frame force or
//! moment applied from rest, velocity and acceleration monitors sampled every 0.02 s
//! (seed 001 section 3.3-3.4: 13 surge force levels, plus sway, heave and yaw cases).

use hydrofit_core::dof::Dof;
use hydrofit_core::model::{Hydro, Plant, Vehicle};
use hydrofit_core::rng::Rng;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

pub const DT: f64 = 0.02;

/// One DFBI run: constant applied loads, how long it runs and how it is exported.
#[derive(Debug, Clone)]
pub struct Case {
    pub name: String,
    pub loads: Vec<(Dof, f64)>,
    pub duration_s: f64,
    pub export: Export,
}

#[derive(Debug, Clone, Copy, Default)]
pub struct Export {
    /// Inner iterations per time step written out (1 = converged rows only).
    pub inner_rows: usize,
    /// Angular quantities in degrees (deg/s, deg/s^2), as a monitor set up in degrees exports them.
    pub degrees: bool,
    /// Leave out the acceleration monitors.
    pub no_acceleration: bool,
}

fn level_name(v: f64) -> String {
    let s = format!("{v}");
    s.replace('.', "p")
}

/// The shipped set: seed 001's 13 surge levels, six each in sway, heave and yaw, and two
/// combined runs in which the Coriolis and Munk terms (eq. 6-7) act.
pub fn default_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    let plain = Export {
        inner_rows: 1,
        ..Default::default()
    };
    let mut add = |dof: Dof, levels: &[f64], duration_s: f64, unit: &str| {
        for (i, f) in levels.iter().enumerate() {
            // Every third run written with its inner iterations, as a monitor set to
            // "every iteration" exports; one surge run without acceleration monitors.
            let export = Export {
                inner_rows: if i % 3 == 1 { 3 } else { 1 },
                degrees: dof == Dof::Yaw && i % 2 == 1,
                no_acceleration: dof == Dof::Surge && *f == 50.0,
            };
            cases.push(Case {
                name: format!("{dof}_{}{unit}", level_name(*f)),
                loads: vec![(dof, *f)],
                duration_s,
                export,
            });
        }
    };
    // Seed 001 lists 2 N, 5 N and 10-100 N every 10 N (12 levels) yet counts 13 cases:
    // 15 N fills the gap where the drag changes from mostly linear to mostly quadratic.
    let surge_levels: Vec<f64> = [2.0, 5.0, 15.0]
        .into_iter()
        .chain((1..=10).map(|k| 10.0 * k as f64))
        .collect();
    add(Dof::Surge, &surge_levels, 24.0, "N");
    add(Dof::Sway, &[2.0, 5.0, 10.0, 20.0, 40.0, 60.0], 20.0, "N");
    add(Dof::Heave, &[5.0, 10.0, 20.0, 40.0, 60.0, 80.0], 16.0, "N");
    add(Dof::Yaw, &[0.5, 1.0, 2.0, 4.0, 6.0, 8.0], 16.0, "Nm");
    cases.push(Case {
        name: "surge_yaw_40N_2Nm".into(),
        loads: vec![(Dof::Surge, 40.0), (Dof::Yaw, 2.0)],
        duration_s: 20.0,
        export: plain,
    });
    cases.push(Case {
        name: "sway_yaw_10N_1Nm".into(),
        loads: vec![(Dof::Sway, 10.0), (Dof::Yaw, 1.0)],
        duration_s: 20.0,
        export: plain,
    });
    cases
}

/// A simulated run before export: samples at t = DT, 2 DT, ...
struct Run {
    t: Vec<f64>,
    tau: Vec<[f64; 6]>,
    nu: Vec<[f64; 6]>,
    nu_dot: Vec<[f64; 6]>,
}

/// Integrates the plant with a small unsteady wake load on top of the applied force: CFD
/// forces are never perfectly smooth (vortex shedding, pressure oscillations), so neither are
/// the velocities. The ripple is 0.5 % of the load at ~0.7 Hz, zero-mean.
fn simulate(plant: &Plant, case: &Case, rng: &mut Rng) -> Run {
    let n = (case.duration_s / DT).round() as usize;
    let mut applied = [0.0; 6];
    for (d, f) in &case.loads {
        applied[d.index()] = *f;
    }
    let phase = rng.uniform() * std::f64::consts::TAU;
    let freq = 0.6 + 0.2 * rng.uniform();
    let sub = 10;
    let h = DT / sub as f64;
    let mut nu = [0.0; 6];
    let mut run = Run {
        t: vec![],
        tau: vec![],
        nu: vec![],
        nu_dot: vec![],
    };
    let load_at = |t: f64| -> [f64; 6] {
        let ripple = 1.0 + 0.005 * (std::f64::consts::TAU * freq * t + phase).sin();
        applied.map(|f| f * ripple)
    };
    for k in 1..=n {
        for s in 0..sub {
            let t0 = (k - 1) as f64 * DT + s as f64 * h;
            nu = rk4(plant, &nu, t0, h, &load_at);
        }
        let t = k as f64 * DT;
        run.t.push(t);
        run.tau.push(applied);
        run.nu.push(nu);
        run.nu_dot.push(plant.accel(&nu, &load_at(t)));
    }
    run
}

fn rk4(plant: &Plant, nu: &[f64; 6], t: f64, h: f64, load: &dyn Fn(f64) -> [f64; 6]) -> [f64; 6] {
    let add = |a: &[f64; 6], k: &[f64; 6], s: f64| -> [f64; 6] {
        std::array::from_fn(|i| a[i] + s * k[i])
    };
    let k1 = plant.accel(nu, &load(t));
    let k2 = plant.accel(&add(nu, &k1, h / 2.0), &load(t + h / 2.0));
    let k3 = plant.accel(&add(nu, &k2, h / 2.0), &load(t + h / 2.0));
    let k4 = plant.accel(&add(nu, &k3, h), &load(t + h));
    std::array::from_fn(|i| nu[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
}

fn monitor_headers(d: Dof, degrees: bool, no_acc: bool) -> Vec<String> {
    let a = d.axis();
    let (fu, vu, au) = match (d.is_angular(), degrees) {
        (false, _) => ("N", "m/s", "m/s^2"),
        (true, false) => ("N-m", "rad/s", "rad/s^2"),
        (true, true) => ("N-m", "deg/s", "deg/s^2"),
    };
    let (f, v, acc) = if d.is_angular() {
        (
            format!("Applied Moment {a} Monitor: Moment ({fu})"),
            format!("Body Angular Velocity {a} Monitor: Angular Velocity ({vu})"),
            format!("Body Angular Acceleration {a} Monitor: Angular Acceleration ({au})"),
        )
    } else {
        (
            format!("Applied Force {a} Monitor: Force ({fu})"),
            format!("Body Velocity {a} Monitor: Velocity ({vu})"),
            format!("Body Acceleration {a} Monitor: Acceleration ({au})"),
        )
    };
    let mut h = vec![f, v];
    if !no_acc {
        h.push(acc);
    }
    h
}

/// Renders a run as STAR-CCM+ writes a table export: quoted header, an Iteration column,
/// and, when `inner_rows > 1`, unconverged inner-iteration rows before each converged one.
fn render(case: &Case, run: &Run, rng: &mut Rng) -> String {
    // Every DOF that moves is exported, loaded or not: in a combined run the Coriolis terms
    // drive the free DOFs too (surge + yaw makes the vehicle sway), and a DFBI export records them.
    let moves = |d: Dof| run.nu.iter().any(|nu| nu[d.index()].abs() > 1e-6);
    let dofs: Vec<Dof> = Dof::ALL
        .into_iter()
        .filter(|d| case.loads.iter().any(|(l, _)| l == d) || moves(*d))
        .collect();
    let mut header = vec![
        "Iteration".to_string(),
        "Physical Time: Physical Time (s)".to_string(),
    ];
    for d in &dofs {
        header.extend(monitor_headers(
            *d,
            case.export.degrees,
            case.export.no_acceleration,
        ));
    }
    let mut out = header
        .iter()
        .map(|h| format!("\"{h}\""))
        .collect::<Vec<_>>()
        .join(",");
    out.push('\n');
    // Numerical noise: 0.05 % of the final speed on velocity, 1 % of the initial acceleration
    // on the acceleration monitor (derived from noisy pressure integrals).
    let last = run.nu.last().copied().unwrap_or([0.0; 6]);
    let mut iteration = 0;
    for k in 0..run.t.len() {
        let inner = case.export.inner_rows.max(1);
        for j in 0..inner {
            iteration += 5;
            let unconverged = (inner - 1 - j) as f64;
            let _ = write!(out, "{iteration},{:.2}", run.t[k]);
            for d in &dofs {
                let i = d.index();
                let scale = if d.is_angular() && case.export.degrees {
                    180.0 / std::f64::consts::PI
                } else {
                    1.0
                };
                let a0 = run.nu_dot[0][i].abs();
                let v = run.nu[k][i]
                    + 5e-4 * last[i].abs() * rng.normal()
                    + unconverged * 0.02 * last[i].abs() * rng.normal();
                let a = run.nu_dot[k][i]
                    + 0.01 * a0 * rng.normal()
                    + unconverged * 0.2 * a0 * rng.normal();
                let _ = write!(out, ",{:.8e},{:.8e}", run.tau[k][i], v * scale);
                if !case.export.no_acceleration {
                    let _ = write!(out, ",{:.8e}", a * scale);
                }
            }
            out.push('\n');
        }
    }
    out
}

/// Simulates and renders one case; deterministic in (`seed`, case name).
pub fn export(vehicle: &Vehicle, hydro: Hydro, case: &Case, seed: u64) -> String {
    let plant = Plant::new(vehicle, hydro);
    let mut rng = Rng::derive(seed, &case.name);
    let run = simulate(&plant, case, &mut rng);
    render(case, &run, &mut rng)
}

/// Writes every case into `dir` as `<name>.csv`; returns the files written.
pub fn write_cases(dir: &Path, cases: &[Case], seed: u64) -> std::io::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let vehicle = Vehicle::reference();
    let mut written = Vec::new();
    for case in cases {
        let path = dir.join(format!("{}.csv", case.name));
        hydrofit_core::fsutil::write_atomic(
            &path,
            export(&vehicle, Hydro::reference(), case, seed).as_bytes(),
        )?;
        written.push(path);
    }
    Ok(written)
}
