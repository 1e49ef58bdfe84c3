//! The folder a proposal is written to: the command (`thrust.csv`, and `thrusters.csv` per
//! thruster where they are described), a `run.yaml`, the planned track (`plan.csv`,
//! `trajectory.svg`), `design.json`, and the PRBS it was compared with (`prbs_thrust.csv`);
//! and the table printed of it.

use super::propose::Proposal;
use super::written::Written;
use super::{Candidate, DT};
use std::fmt::Write as _;
use std::path::Path;

/// Every file a design writes (`hydrofit clean` removes them from a `design` stage's folder).
pub const FILES: &[&str] = &[
    "thrust.csv",
    "prbs_thrust.csv",
    super::thrusters::FILE,
    "plan.csv",
    "run.yaml",
    "trajectory.svg",
    "design.json",
];

impl Proposal {
    /// Writes the proposal's files into `dir` (created).
    pub fn write(&self, dir: &Path) -> anyhow::Result<()> {
        use crate::core::fsutil::{write_atomic, write_json};
        let (w, best, prbs) = (&self.written, &self.best, &self.prbs);
        std::fs::create_dir_all(dir)?;
        write_atomic(&dir.join("thrust.csv"), thrust_csv(&best.cmd).as_bytes())?;
        write_atomic(
            &dir.join("prbs_thrust.csv"),
            thrust_csv(&prbs.cmd).as_bytes(),
        )?;
        if let Some(m) = &self.mixed {
            write_atomic(&dir.join(super::thrusters::FILE), m.csv().as_bytes())?;
        }
        write_atomic(&dir.join("plan.csv"), plan_csv(best).as_bytes())?;
        write_atomic(&dir.join("run.yaml"), run_yaml(w).as_bytes())?;
        write_atomic(
            &dir.join("trajectory.svg"),
            trajectory(w, best, prbs)?.as_bytes(),
        )?;
        write_json(&dir.join("design.json"), w)
    }
}

fn thrust_csv(cmd: &[[f64; 4]]) -> String {
    let mut out = format!("t,{}\n", super::signal::LABELS.join(","));
    for (k, c) in cmd.iter().enumerate() {
        let _ = writeln!(
            out,
            "{:.2},{:.1},{:.1},{:.1},{:.1}",
            k as f64 * DT,
            c[0],
            c[1],
            c[2],
            c[3]
        );
    }
    out
}

fn plan_csv(c: &Candidate) -> String {
    let mut out = String::from("t,x_m,y_m,z_m,psi_rad,u,v,w,r\n");
    for (k, s) in c.states.iter().enumerate() {
        let _ = writeln!(
            out,
            "{:.2},{:.4},{:.4},{:.4},{:.5},{:.5},{:.5},{:.5},{:.5}",
            k as f64 * DT,
            s.pos[0],
            s.pos[1],
            s.pos[2],
            s.psi,
            s.nu[0],
            s.nu[1],
            s.nu[2],
            s.nu[5]
        );
    }
    out
}

fn run_yaml(w: &Written) -> String {
    // A run that is to tell two effects apart is held out: the diagnosis decides on held-out
    // costs. A run for the parameters trains.
    let role = if w.separates.is_some() {
        "validate"
    } else {
        "train"
    };
    format!(
        "role: {role}\ndescription: \"designed by hydrofit design for {}: {}; start at x {:.1} m, y {:.1} m, depth {:.1} m, heading {:.0} deg\"\npool: {{length_m: {}, width_m: {}, depth_m: {}}}\n",
        w.model,
        w.description.replace('"', "'"),
        w.start[0],
        w.start[1],
        w.start[2],
        w.start[3],
        w.pool.length_m,
        w.pool.width_m,
        w.pool.depth_m
    )
}

/// The planned track seen from above, in the pool's outline and its margin.
fn trajectory(w: &Written, best: &Candidate, prbs: &Candidate) -> anyhow::Result<String> {
    use crate::core::plot::lines::{Chart, Series, chart};
    let (l, b, m) = (w.pool.length_m, w.pool.width_m, w.margin_m);
    let outline = |inset: f64| {
        let x = vec![inset, l - inset, l - inset, inset, inset];
        let y = vec![inset, inset, b - inset, b - inset, inset];
        (x, y)
    };
    let (px, py) = outline(0.0);
    let (mx, my) = outline(m);
    let xs = |c: &Candidate| c.states.iter().map(|s| s.pos[0]).collect::<Vec<_>>();
    let ys = |c: &Candidate| c.states.iter().map(|s| s.pos[1]).collect::<Vec<_>>();
    let (bx, by, qx, qy) = (xs(best), ys(best), xs(prbs), ys(prbs));
    chart(&Chart {
        title: "Planned track in the pool (seen from above)",
        x_desc: "x along the pool, m",
        y_desc: "y across, m",
        series: vec![
            Series {
                label: "designed run",
                x: &bx,
                y: &by,
                reference: false,
            },
            Series {
                label: "PRBS, same limits",
                x: &qx,
                y: &qy,
                reference: false,
            },
            Series {
                label: "pool walls",
                x: &px,
                y: &py,
                reference: true,
            },
            Series {
                label: "margin",
                x: &mx,
                y: &my,
                reference: true,
            },
        ],
        hlines: Vec::new(),
        stems: false,
    })
}

impl Written {
    /// What the proposal buys, as printed after a design: the run, the separation or the
    /// standard errors of the parameters it is for, the per-thruster commands.
    pub fn table(&self) -> Vec<String> {
        let w = self;
        let mut out = Vec::new();
        out.push(format!("next run: {}", w.description));
        if let Some(s) = &w.separates {
            out.push(format!(
            "  tells {} from {}: their predicted recordings differ by {:.1} times the noise floor (the recorded runs: {:.1}; the PRBS: {:.1}; the diagnosis needs {:.1})",
            s.kept,
            s.alike,
            s.designed,
            s.recorded,
            s.prbs,
            s.margin
        ));
            out.push(
                "  fly it twice: once with role train (the effects' parameters are fitted on it) and once held out as run.yaml says (role validate: the diagnosis decides on it)".into(),
            );
        }
        if let Some(t) = &w.thrusters {
            let e = t.max_wrench_error;
            out.push(format!(
            "  per thruster ({:?} commands) in {}: the commands give the designed wrench to within X {:.1} N, Y {:.1} N, Z {:.1} N, N {:.2} N m",
            t.command,
            t.file,
            e[0],
            e[1],
            e[2],
            e[3]
        ));
            if t.clipped_samples > 0 {
                out.push(format!(
                "  warning: at {} of {} samples a thruster would need more thrust than its curve gives; lower vehicle.command_limits so the plan can be flown as designed",
                t.clipped_samples,
                t.samples
            ));
            }
        }
        out.push(format!(
        "  {:.0} s from x {:.1} m, y {:.1} m, depth {:.1} m, heading {:.0} deg; closest {:.2} m to a wall, the floor or the surface (margin {} m)",
        w.duration_s,
        w.start[0],
        w.start[1],
        w.start[2],
        w.start[3],
        w.clearance_m,
        w.margin_m
    ));
        out.push(format!(
            "  {:<10} {:>12} {:>12} {:>12} {:>12}",
            "parameter", "value", "stderr now", "after run", "after PRBS"
        ));
        for r in w.parameters.iter().filter(|r| r.target) {
            out.push(format!(
                "  {:<10} {:>12.4} {:>12.4} {:>12.4} {:>12.4}  {}",
                r.name, r.value, r.stderr_now, r.predicted_after, r.predicted_after_prbs, r.unit
            ));
        }
        out
    }
}
