//! The next run to fly, and the promise kept: a pool-only fit of the twin from runs (surge
//! steps, sway and heave steps, yaw turns; no PRBS) that leave its heave inertia and quadratic
//! drag correlated and its linear drag loose; `hydrofit design` proposes a run and
//! predicts the flagged parameters' standard errors after it; the twin flies it (and, in a
//! copy of the project, the PRBS of the same length and limits the design compares with);
//! rebuilt with the flown run, the standard errors shrink as predicted, and more than with the
//! PRBS. Every planned and flown track stays in the pool and every command in the limits.

mod common;

use common::{json, ok, read};
use std::path::Path;

const PIPELINE: &str = "vehicle:
  name: open-frame ROV (seed 001)
  mass_kg: 35.2
  inertia_kg_m2: {zz: 1.38}
  dofs: [surge, sway, heave, yaw]
  structure: diagonal
  command_limits: {surge: 60, sway: 50, heave: 40, yaw: 6}
stages:
  pool: {kind: pool, inputs: [\"cases/pool/*/\"]}
  fit: {kind: fit, from: [pool]}
  report: {kind: report, from: [fit, pool]}
";

/// The project: twin runs with nothing concealed, without the training PRBS.
fn project() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    ok(
        root,
        &[
            "twin",
            "pool",
            "--out",
            "cases/pool",
            "--truth",
            "truth",
            "--effect",
            "none",
        ],
    );
    std::fs::remove_dir_all(root.join("cases/pool/prbs_a")).unwrap();
    std::fs::write(root.join("pipeline.yaml"), PIPELINE).unwrap();
    ok(root, &["build"]);
    d
}

/// Standard error per parameter in the last build's report.
fn stderrs(root: &Path) -> std::collections::BTreeMap<String, f64> {
    json(root, "reports/parameters.json")["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            (
                p["name"].as_str().unwrap().to_string(),
                p["stderr"].as_f64().unwrap_or(f64::INFINITY),
            )
        })
        .collect()
}

/// Copies a project's inputs (not its cache or reports) to a new folder.
fn copy_inputs(from: &Path) -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    let status = std::process::Command::new("cp")
        .arg("-r")
        .arg(from.join("cases"))
        .arg(from.join("pipeline.yaml"))
        .arg(from.join("reports"))
        .arg(d.path())
        .status()
        .unwrap();
    assert!(status.success());
    d
}

/// Every row of a flown run's truth is inside the twin's 25 x 12 x 4 m pool.
fn stays_in_pool(root: &Path, run: &str) {
    let truth = read(root, &format!("truth/{run}.csv"));
    for line in truth.lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let (x, y, z) = (v[5], v[6], v[7]);
        assert!(
            (0.0..25.0).contains(&x) && (0.0..12.0).contains(&y) && (0.0..4.0).contains(&z),
            "{run} left the pool: {line}"
        );
    }
}

#[test]
fn the_designed_run_shrinks_the_flagged_errors_as_predicted_and_beats_a_prbs() {
    let p = project();
    let root = p.path();
    let before = stderrs(root);
    ok(root, &["design", "--duration", "90", "--candidates", "25"]);
    let design = json(root, "reports/design/design.json");
    let targets: Vec<&serde_json::Value> = design["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["target"] == true)
        .collect();
    assert!(!targets.is_empty(), "nothing to design for: {design}");
    // The plan keeps the margin, and every command its limit.
    assert!(design["clearance_m"].as_f64().unwrap() >= 1.0);
    let limits = [60.0, 50.0, 40.0, 6.0];
    for line in read(root, "reports/design/thrust.csv").lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        assert_eq!(v.len(), 5);
        for d in 0..4 {
            assert!(v[d + 1].abs() <= limits[d] + 1e-9, "{line}");
        }
    }
    assert!(read(root, "reports/design/trajectory.svg").contains("<svg"));
    // The PRBS's copy of the project, before the designed run is added.
    let q = copy_inputs(root);
    for (dir, file) in [(root, "thrust.csv"), (q.path(), "prbs_thrust.csv")] {
        ok(
            dir,
            &[
                "twin",
                "fly",
                &format!("reports/design/{file}"),
                "--name",
                "next",
                "--out",
                "cases/pool",
                "--truth",
                "truth",
                "--effect",
                "none",
                "--seed",
                "7",
            ],
        );
        ok(dir, &["build"]);
    }
    stays_in_pool(root, "next");
    let (designed, prbs) = (stderrs(root), stderrs(q.path()));
    // The report holds the designed run to its promise (the PRBS run carries no design).
    let page = read(root, "reports/index.html");
    let promise = format!(
        "The promise kept for {n} of {n} parameters",
        n = targets.len()
    );
    assert!(page.contains(&promise), "no '{promise}' in the report");
    assert!(!read(q.path(), "reports/index.html").contains("Designed runs"));
    let mut log_gain = (0.0, 0.0);
    for r in &targets {
        let name = r["name"].as_str().unwrap();
        let predicted = r["predicted_after"].as_f64().unwrap();
        let got = designed[name];
        // The promise kept: the standard error after the flown run is what the design said,
        // within 30 %.
        assert!(
            got <= 1.3 * predicted && got >= predicted / 1.3,
            "{name}: {} now, predicted {predicted}, got {got}",
            before[name]
        );
        log_gain.0 += got.ln();
        log_gain.1 += prbs[name].ln();
    }
    // Over the targets, the designed run determines them better than the PRBS of the same
    // length and limits (geometric mean of the standard errors).
    assert!(
        log_gain.0 < log_gain.1,
        "designed {:?} vs PRBS {:?}",
        log_gain.0,
        log_gain.1
    );
}

#[test]
fn a_design_says_what_it_needs_when_it_cannot_run() {
    let p = project();
    let root = p.path();
    let o = common::run(root, &["design", "--for", "X_nope"]);
    assert!(!o.status.success());
    assert!(common::stderr(&o).contains("--for X_nope: the model has no such parameter"));
    let o = common::run(root, &["design", "--start", "0.5,6,2,0"]);
    assert!(!o.status.success());
    assert!(
        common::stderr(&o).contains("within the 1 m margin"),
        "{}",
        common::stderr(&o)
    );
    let o = common::run(root, &["design", "--pool", "25x12"]);
    assert!(!o.status.success());
    assert!(common::stderr(&o).contains("LENGTHxWIDTHxDEPTH"));
}
