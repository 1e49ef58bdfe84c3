//! The pool part of the report: how each fused run was made and how accurate the fusion is where
//! a twin's truth exists.

use crate::core::dof::Dof;
use crate::core::model::thrusters::{Command, Thrusters};

use crate::core::html::esc;
use crate::pool::fusion::run::FusedRun;
use crate::pool::fusion::run::POOL_DOFS;
use crate::pool::fusion::{Fused, interp};
use crate::pool::import::csvlog;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// Fusion error against a twin's true velocities, per DOF (m/s, rad/s).
#[derive(Debug, Clone, Serialize)]
pub struct FusionAccuracy {
    pub run: String,
    pub truth: String,
    pub rmse: BTreeMap<Dof, f64>,
    /// RMS of error / stated standard deviation (1 when the uncertainty is honest).
    pub error_over_std: BTreeMap<Dof, f64>,
    pub rmse_without_sonar: Option<BTreeMap<Dof, f64>>,
}

fn rmse_against(truth: &csvlog::Log, f: &Fused) -> (BTreeMap<Dof, f64>, BTreeMap<Dof, f64>) {
    let mut rmse = BTreeMap::new();
    let mut z = BTreeMap::new();
    let rp = &f.roll_pitch;
    let channels = POOL_DOFS
        .iter()
        .enumerate()
        .map(|(j, d)| (*d, j, &f.vel[j], &f.std[j]))
        .chain([
            (Dof::Roll, 4, &rp.rate[0], &rp.rate_std[0]),
            (Dof::Pitch, 5, &rp.rate[1], &rp.rate_std[1]),
        ]);
    for (d, j, v, s) in channels {
        let (Some(v), Some(s), true) = (v, s, truth.has(j)) else {
            continue;
        };
        let (mut se, mut sz) = (0.0, 0.0);
        for (k, &t) in f.t.iter().enumerate() {
            let e = v[k] - interp(&truth.t, &truth.cols[j], t);
            se += e * e;
            sz += (e / s[k]).powi(2);
        }
        let n = f.t.len().max(1) as f64;
        rmse.insert(d, (se / n).sqrt());
        z.insert(d, (sz / n).sqrt());
    }
    (rmse, z)
}

/// Compares each run with the truth file of the same name (`<run>.csv`: t,u,v,w,r,...).
pub fn fusion_accuracy(
    root: &std::path::Path,
    truth_files: &[String],
    runs: &[FusedRun],
) -> anyhow::Result<Vec<FusionAccuracy>> {
    let mut out = Vec::new();
    for run in runs {
        let Some(path) = truth_files
            .iter()
            .find(|p| p.rsplit('/').next() == Some(&format!("{}.csv", run.meta.run)))
        else {
            continue;
        };
        let text = std::fs::read_to_string(root.join(path))?;
        let cols = ["t", "u", "v", "w", "r", "p", "q"];
        let truth = csvlog::parse_subset(path, &text, &cols, "truth file", 2)?;
        let (rmse, z) = rmse_against(&truth, &run.fused);
        let rmse_without_sonar = run
            .without_sonar
            .as_ref()
            .map(|f| rmse_against(&truth, f).0);
        out.push(FusionAccuracy {
            run: run.meta.run.clone(),
            truth: path.clone(),
            rmse,
            error_over_std: z,
            rmse_without_sonar,
        });
    }
    Ok(out)
}

fn unit(d: Dof) -> &'static str {
    d.velocity_unit()
}

/// The HTML of the pool runs' fusion: how each run was fused, its timing repairs, and the
/// fusion's accuracy where a twin's truth exists.
pub fn section(runs: &[FusedRun], accuracy: &[FusionAccuracy]) -> String {
    let mut h = String::new();
    if runs.is_empty() {
        return h;
    }
    fusion_table(&mut h, runs);
    repairs(&mut h, runs);
    accuracy_table(&mut h, accuracy);
    h
}

/// The fusion heading and its table: per run, the sensors used, the fixes kept and rejected,
/// the gyro bias, the UWB noise and the DOFs the fusion knows.
fn fusion_table(h: &mut String, runs: &[FusedRun]) {
    h.push_str("<h2 id=\"fusion\">Pool runs: sensor fusion</h2>\n<p>UWB, sonar, depth and IMU fused by a Kalman filter with a Rauch-Tung-Striebel smoother (heading with gyro bias; position and velocity driven by the accelerometers, UWB fixes screened by a median filter and a chi-square gate). Noise levels estimated from each log unless set.</p>\n");
    h.push_str("<table><tr><th>run</th><th>role</th><th>sensors</th><th>UWB fixes (multipath rejected)</th><th>sonar fixes</th><th>gyro bias (°/s)</th><th>UWB σ (m)</th><th>DOFs known</th></tr>\n");
    for r in runs {
        let s = &r.meta.stats;
        let known: Vec<&str> = POOL_DOFS
            .iter()
            .enumerate()
            .filter(|(j, _)| r.meta.known[*j])
            .map(|(_, d)| d.name())
            .collect();
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{} ({} + {})</td><td>{}</td><td>{}</td><td>{:.3}</td><td>{}</td></tr>",
            esc(&r.meta.run),
            r.meta.role.as_str(),
            r.meta.sensors.join(", "),
            s.uwb_fixes,
            s.uwb_rejected_median,
            s.uwb_rejected_gate,
            s.sonar_fixes,
            s.gyro_bias_dps.map_or("–".into(), |b| format!("{b:.3}")),
            s.noise.uwb_m[0],
            known.join(", ")
        );
    }
    h.push_str("</table>\n");
}

/// The list of timing repairs and navigation-log noise, for the runs that have any.
fn repairs(h: &mut String, runs: &[FusedRun]) {
    let repaired: Vec<&FusedRun> = runs
        .iter()
        .filter(|r| !r.meta.repairs.is_empty() || !r.meta.stats.nav.is_empty())
        .collect();
    if repaired.is_empty() {
        return;
    }
    h.push_str("<h3 id=\"repairs\">Timing repairs and navigation-log noise</h3>\n<ul>\n");
    for r in repaired {
        for rep in &r.meta.repairs {
            let _ = writeln!(
                h,
                "<li><code>{}</code>: {}</li>",
                esc(&r.meta.run),
                esc(rep)
            );
        }
        for (ch, n) in &r.meta.stats.nav {
            let _ = writeln!(
                h,
                "<li><code>{}</code> nav <code>{ch}</code>: noise σ {:.4} m/s (lag-1 estimate {:.4}); errors correlated over {:.1} samples{}</li>",
                esc(&r.meta.run),
                n.sigma,
                n.sigma_lag1,
                n.correlated_samples,
                if n.correlated_samples > 2.0 {
                    " — the log was filtered before it was written, so its samples count for less"
                } else {
                    ""
                }
            );
        }
    }
    h.push_str("</ul>\n");
}

/// The fusion's accuracy against the twin's truth, per run and DOF (nothing without truth).
fn accuracy_table(h: &mut String, accuracy: &[FusionAccuracy]) {
    if accuracy.is_empty() {
        return;
    }
    h.push_str("<h3 id=\"fusion-accuracy\">Fusion accuracy against the twin's truth</h3>\n<p>These runs are synthetic: their true velocities are in the truth files named below (outside <code>cases/</code>, never read by the fusion). RMSE of the fused velocity, with and without the sonar; error/σ is the RMS of the error divided by the stated standard deviation (near 1 when the uncertainty is honest).</p>\n<table><tr><th>run</th><th>DOF</th><th>RMSE</th><th>RMSE without sonar</th><th>error/σ</th><th>truth</th></tr>\n");
    for a in accuracy {
        for (d, e) in &a.rmse {
            let ns = a
                .rmse_without_sonar
                .as_ref()
                .and_then(|m| m.get(d))
                .map_or("no sonar in run".into(), |x| format!("{x:.4} {}", unit(*d)));
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{d}</td><td>{e:.4} {}</td><td>{ns}</td><td>{:.2}</td><td><code>{}</code></td></tr>",
                esc(&a.run),
                unit(*d),
                a.error_over_std[d],
                esc(&a.truth)
            );
        }
    }
    h.push_str("</table>\n");
}

/// The thrusters, when runs log per-thruster commands: each unit, the allocation matrix that
/// turns thrusts into the body wrench, its rank and the DOFs it actuates, and the thrust
/// curve the commands go through.
pub fn thrusters_section(t: Option<&Thrusters>) -> anyhow::Result<String> {
    let Some(t) = t else {
        return Ok(String::new());
    };
    let a = t.allocation();
    let (rank, dofs) = a.actuated();
    let mut h = String::from("<h2 id=\"thrusters\">Thrusters</h2>\n");
    let names: Vec<String> = dofs.iter().map(|d| d.to_string()).collect();
    let _ = writeln!(
        h,
        "<p>Per-thruster commands become the body wrench τ = B f before any model sees them: column i of B is [d<sub>i</sub>; r<sub>i</sub> × d<sub>i</sub>] for thruster i at r<sub>i</sub> pushing along d<sub>i</sub> (body frame, x forward, y starboard, z down; Fossen 2011 eq. 11.8). B has rank {rank} and actuates {}.</p>",
        if names.is_empty() {
            "no DOF".into()
        } else {
            names.join(", ")
        }
    );
    h.push_str("<table><tr><th></th>");
    for u in &a.units {
        let _ = write!(h, "<th>{}</th>", esc(&u.name));
    }
    h.push_str("</tr>\n");
    for (label, row) in ["position x (m)", "position y (m)", "position z (m)"]
        .iter()
        .zip(0..3)
    {
        let _ = write!(h, "<tr><td>{label}</td>");
        for u in &a.units {
            let _ = write!(h, "<td>{:.3}</td>", u.position_m[row]);
        }
        h.push_str("</tr>\n");
    }
    for (label, row) in [
        "X (N/N)",
        "Y (N/N)",
        "Z (N/N)",
        "K (N m/N)",
        "M (N m/N)",
        "N (N m/N)",
    ]
    .iter()
    .zip(0..6)
    {
        let _ = write!(h, "<tr><td>B: {label}</td>");
        for c in &a.columns {
            let _ = write!(h, "<td>{:.3}</td>", c[row] + 0.0);
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n");
    let (x, y) = a.curve_points(201);
    let x_desc = match t.command {
        Command::Pwm => "command (PWM, us)",
        Command::Normalised => "command (normalised)",
        Command::Rpm => "shaft speed (rpm)",
    };
    h += &crate::core::plot::lines::figure(
        "thrust-curve",
        &format!(
            "The thrust curve every thruster's command goes through (gain {}); a command beyond its ends is held at them.",
            t.gain
        ),
        &crate::core::plot::lines::Chart {
            title: "thrust against command",
            x_desc,
            y_desc: "thrust (N)",
            series: vec![crate::core::plot::lines::Series {
                label: "thrust",
                x: &x,
                y: &y,
                reference: false,
            }],
            hlines: vec![],
            stems: false,
        },
    )?;
    Ok(h)
}
