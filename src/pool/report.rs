//! The pool part of the report: how each fused run was made and how accurate the fusion is where
//! a twin's truth exists.

use crate::core::dof::Dof;
use crate::core::model::thrusters::{Allocation, Command, Thrusters};

use crate::pool::fusion::run::FusedRun;
use crate::pool::fusion::run::POOL_DOFS;
use crate::pool::fusion::{Fused, interp};
use crate::pool::import::csvlog;
use maud::{Markup, html};
use serde::Serialize;
use std::collections::BTreeMap;

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
pub fn section(runs: &[FusedRun], accuracy: &[FusionAccuracy]) -> Markup {
    if runs.is_empty() {
        return Markup::default();
    }
    let latency = crate::pool::fusion::latency::Summary::of_runs(runs);
    html! {
        (fusion_table(runs))
        @if let Some(s) = latency {
            p id="nav-latency" { "Navigation-log latency: " (s.sentence()) "." }
        }
        (repairs(runs))
        (accuracy_table(accuracy))
    }
}

/// The DOFs whose velocity the sensors of run `r` gave, in the order surge .. yaw: u, v, w, r
/// from the fusion, p and q where a gyro or a navigation log had them.
fn dofs_known(r: &FusedRun) -> Vec<&'static str> {
    use crate::core::dof::Dof;
    let rates = &r.fused.roll_pitch.rate;
    Dof::ALL
        .iter()
        .filter(|d| match d {
            Dof::Roll => rates[0].is_some(),
            Dof::Pitch => rates[1].is_some(),
            d => POOL_DOFS
                .iter()
                .position(|p| p == *d)
                .is_some_and(|j| r.meta.known[j]),
        })
        .map(|d| d.name())
        .collect()
}

/// The fusion heading and its table: per run, the sensors used, the fixes kept and rejected,
/// the gyro bias, the UWB noise and the DOFs the fusion knows.
fn fusion_table(runs: &[FusedRun]) -> Markup {
    html! {
        h2 id="fusion" { "Pool runs: sensor fusion" }
        p {
            "UWB, sonar, depth and IMU fused by a Kalman filter with a Rauch-Tung-Striebel smoother (heading with gyro bias; position and velocity driven by the accelerometers, UWB fixes screened by a median filter and a chi-square gate). Noise levels estimated from each log unless set."
        }
        table {
            tr {
                th { "run" } th { "role" } th { "sensors" } th { "UWB fixes (multipath rejected)" }
                th { "sonar fixes" } th { "gyro bias (°/s)" } th { "UWB σ (m)" } th { "DOFs known" }
            }
            @for r in runs {
                @let s = &r.meta.stats;
                @let known = dofs_known(r);
                tr {
                    td { (r.meta.run) }
                    td { (r.meta.role.as_str()) }
                    td { (r.meta.sensors.join(", ")) }
                    td { (s.uwb_fixes) " (" (s.uwb_rejected_median) " + " (s.uwb_rejected_gate) ")" }
                    td { (s.sonar_fixes) }
                    td { (s.gyro_bias_dps.map_or("–".into(), |b| format!("{b:.3}"))) }
                    td { @if s.uwb_fixes > 0 { (format!("{:.3}", s.noise.uwb_m[0])) } @else { "–" } }
                    td { (known.join(", ")) }
                }
            }
        }
    }
}

/// The list of timing repairs and navigation-log noise, for the runs that have any.
fn repairs(runs: &[FusedRun]) -> Markup {
    let repaired: Vec<&FusedRun> = runs
        .iter()
        .filter(|r| !r.meta.repairs.is_empty() || !r.meta.stats.nav.is_empty())
        .collect();
    html! {
        @if !repaired.is_empty() {
            h3 id="repairs" { "Timing repairs and navigation-log noise" }
            ul {
                @for r in repaired {
                    @for rep in &r.meta.repairs {
                        li { code { (r.meta.run) } ": " (rep) }
                    }
                    @for (ch, n) in &r.meta.stats.nav {
                        li {
                            code { (r.meta.run) } " nav " code { (ch) }
                            (format!(
                                ": noise σ {:.4} m/s (lag-1 estimate {:.4}); errors correlated over {:.1} samples",
                                n.sigma, n.sigma_lag1, n.correlated_samples
                            ))
                            @if n.correlated_samples > 2.0 {
                                " — the log was filtered before it was written, so its samples count for less"
                            }
                        }
                    }
                }
            }
        }
    }
}

/// The fusion's accuracy against the twin's truth, per run and DOF (nothing without truth).
fn accuracy_table(accuracy: &[FusionAccuracy]) -> Markup {
    html! {
        @if !accuracy.is_empty() {
            h3 id="fusion-accuracy" { "Fusion accuracy against the twin's truth" }
            p {
                "These runs are synthetic: their true velocities are in the truth files named below (outside "
                code { "cases/" }
                ", never read by the fusion). RMSE of the fused velocity, with and without the sonar; error/σ is the RMS of the error divided by the stated standard deviation (near 1 when the uncertainty is honest)."
            }
            table {
                tr {
                    th { "run" } th { "DOF" } th { "RMSE" } th { "RMSE without sonar" }
                    th { "error/σ" } th { "truth" }
                }
                @for a in accuracy {
                    @for (d, e) in &a.rmse {
                        @let ns = a
                            .rmse_without_sonar
                            .as_ref()
                            .and_then(|m| m.get(d))
                            .map_or("no sonar in run".into(), |x| format!("{x:.4} {}", unit(*d)));
                        tr {
                            td { (a.run) }
                            td { (d) }
                            td { (format!("{e:.4} {}", unit(*d))) }
                            td { (ns) }
                            td { (format!("{:.2}", a.error_over_std[d])) }
                            td { code { (a.truth) } }
                        }
                    }
                }
            }
        }
    }
}

/// The thrusters, when runs log per-thruster commands: each unit, the allocation matrix that
/// turns thrusts into the body wrench, its rank and the DOFs it actuates, and the thrust
/// curve the commands go through.
pub fn thrusters_section(t: Option<&Thrusters>) -> anyhow::Result<Markup> {
    let Some(t) = t else {
        return Ok(Markup::default());
    };
    let a = t.allocation();
    let (rank, dofs) = a.actuated();
    let names: Vec<String> = dofs.iter().map(|d| d.to_string()).collect();
    let actuates = if names.is_empty() {
        "no DOF".into()
    } else {
        names.join(", ")
    };
    let curve = match (t.command, &t.curve) {
        (Command::Newtons, None) => html! {
            p { "The logged commands are thrusts in newtons (gain " (t.gain) "), used as they are: no curve." }
        },
        _ => thrust_curve(t, &a)?,
    };
    Ok(html! {
        h2 id="thrusters" { "Thrusters" }
        p {
            "Per-thruster commands become the body wrench τ = B f before any model sees them: column i of B is [d"
            sub { "i" } "; r" sub { "i" } " × d" sub { "i" } "] for thruster i at r" sub { "i" }
            " pushing along d" sub { "i" }
            " (body frame, x forward, y starboard, z down; Fossen 2011 eq. 11.8). B has rank "
            (rank) " and actuates " (actuates) "."
        }
        (allocation_table(&a))
        (curve)
    })
}

/// Each thruster's position and its column of the allocation matrix B.
fn allocation_table(a: &Allocation) -> Markup {
    let positions = ["position x (m)", "position y (m)", "position z (m)"];
    let rows = [
        "X (N/N)",
        "Y (N/N)",
        "Z (N/N)",
        "K (N m/N)",
        "M (N m/N)",
        "N (N m/N)",
    ];
    html! {
        table {
            tr {
                th {}
                @for u in &a.units {
                    th { (u.name) }
                }
            }
            @for (label, row) in positions.iter().zip(0..3) {
                tr {
                    td { (label) }
                    @for u in &a.units {
                        td { (format!("{:.3}", u.position_m[row])) }
                    }
                }
            }
            @for (label, row) in rows.iter().zip(0..6) {
                tr {
                    td { "B: " (label) }
                    @for c in &a.columns {
                        td { (format!("{:.3}", c[row] + 0.0)) }
                    }
                }
            }
        }
    }
}

/// The figure of the thrust curve every thruster's command goes through.
fn thrust_curve(t: &Thrusters, a: &Allocation) -> anyhow::Result<Markup> {
    let (x, y) = a.curve_points(201);
    let x_desc = match t.command {
        Command::Pwm => "command (PWM, us)",
        Command::Normalised => "command (normalised)",
        Command::Rpm => "shaft speed (rpm)",
        Command::Newtons => "thrust command (N)",
    };
    crate::core::plot::lines::figure(
        "thrust-curve",
        html! {
            "The thrust curve every thruster's command goes through (gain " (t.gain)
            "); a command beyond its ends is held at them."
        },
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
    )
}
