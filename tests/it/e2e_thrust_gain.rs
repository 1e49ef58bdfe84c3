//! `thrust_gain: fit`: the gain of the pool runs' logged command, identified against the CFD
//! cases' force scale. The twin's pool runs with their command logged 25 % high (a thrust
//! curve that overstates what the thrusters give) yield a gain of 0.8 in every DOF, and the
//! model with it predicts the held-out runs far better than the one that takes the command as
//! the force; runs logged right yield 1. From pool runs alone the gain is refused.

use crate::common::{json, ok, run, stderr};
use std::path::Path;

const PIPELINE: &str = "vehicle:
  name: twin ROV
  mass_kg: 35.2
  inertia_kg_m2: {zz: 1.38}
  dofs: [surge, sway, heave, yaw]
  structure: diagonal
stages:
  cfd: {kind: starccm, inputs: [\"cases/cfd/starccm/*.csv\"]}
  pool: {kind: pool, inputs: [\"cases/pool/*/\"]}
  fixed: {kind: fit, from: [cfd, pool], settings: {method: ols}}
  gain: {kind: fit, from: [cfd, pool], settings: {method: ols, thrust_gain: fit}}
  validate: {kind: validate, from: [fixed, gain, pool]}
  report: {kind: report, from: [fixed, gain, pool, validate]}
";

/// A project of the twin's CFD cases and effect-free pool runs whose logged command is
/// `logged` times the force the twin applied.
fn project(root: &Path, logged: f64) {
    ok(root, &["twin", "starccm", "--out", "cases/cfd/starccm"]);
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
    for e in std::fs::read_dir(root.join("cases/pool")).unwrap() {
        let f = e.unwrap().path().join("thrust.csv");
        let text = std::fs::read_to_string(&f).unwrap();
        let mut lines = text.lines();
        let mut out = format!("{}\n", lines.next().unwrap());
        for l in lines {
            let mut cells = l.split(',');
            out += cells.next().unwrap();
            for c in cells {
                out += &format!(",{}", c.parse::<f64>().unwrap() * logged);
            }
            out += "\n";
        }
        std::fs::write(&f, out).unwrap();
    }
    std::fs::write(root.join("pipeline.yaml"), PIPELINE).unwrap();
}

/// The `gain` fit's estimate: (value, per DOF, consistent).
fn gain(root: &Path) -> (f64, Vec<(String, f64)>, bool) {
    let params = json(root, "reports/parameters.json");
    let k = params["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "k_thrust" && p["stage"] == "gain")
        .expect("k_thrust in parameters.json");
    let note = k["note"].as_str().unwrap();
    assert!(
        note.contains("against the CFD cases' force scale"),
        "{note}"
    );
    let fit = std::fs::read_dir(root.join(".hydrofit/objects"))
        .unwrap()
        .map(|e| e.unwrap().path().join("fit.json"))
        .filter(|p| p.exists())
        .map(|p| {
            serde_json::from_str::<serde_json::Value>(&std::fs::read_to_string(p).unwrap()).unwrap()
        })
        .find(|f| f["stage"] == "gain")
        .expect("the gain fit's fit.json");
    let g = &fit["fit"]["thrust_gain"];
    let per_dof = g["per_dof"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(d, v)| (d.clone(), v[0].as_f64().unwrap()))
        .collect();
    (
        k["value"].as_f64().unwrap(),
        per_dof,
        g["consistent"].as_bool().unwrap(),
    )
}

/// Held-out NMAE per DOF of `model`.
fn held_out(root: &Path, model: &str) -> Vec<(String, f64)> {
    let v = json(root, "reports/validation.json");
    let m = v["models"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["model"] == model)
        .unwrap_or_else(|| panic!("{model} in validation.json"));
    let mut out = Vec::new();
    for r in m["runs"].as_array().unwrap() {
        if r["role"] == "validate" {
            for (d, s) in r["dofs"].as_object().unwrap() {
                out.push((format!("{} {d}", r["run"]), s["nmae"].as_f64().unwrap()));
            }
        }
    }
    out
}

#[test]
fn a_thrust_curve_that_overstates_is_found_against_the_cfd_force_scale() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    project(root, 1.25);
    ok(root, &["build"]);
    let (k, per_dof, consistent) = gain(root);
    assert!((k - 0.8).abs() < 0.016, "gain {k}, true 0.8");
    assert_eq!(per_dof.len(), 4, "{per_dof:?}");
    for (d, k) in &per_dof {
        assert!((k - 0.8).abs() < 0.024, "{d}: gain {k}, true 0.8");
    }
    assert!(consistent, "the DOFs agree: {per_dof:?}");
    // The model with the gain predicts every held-out DOF at least twice as well.
    let (fixed, with) = (held_out(root, "fixed"), held_out(root, "gain"));
    assert!(!with.is_empty());
    for ((what, a), (_, b)) in fixed.iter().zip(&with) {
        assert!(
            *b < 0.5 * a,
            "{what}: held-out NMAE {b} with the gain, {a} without"
        );
    }
}

#[test]
fn a_command_logged_right_has_a_gain_of_one_and_pool_runs_alone_cannot_say() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    project(root, 1.0);
    ok(root, &["build"]);
    let (k, per_dof, _) = gain(root);
    assert!((k - 1.0).abs() < 0.02, "gain {k}, true 1");
    for (d, k) in &per_dof {
        assert!((k - 1.0).abs() < 0.03, "{d}: gain {k}, true 1");
    }
    std::fs::write(
        root.join("pipeline.yaml"),
        PIPELINE.replace(
            "from: [cfd, pool], settings: {method: ols, thrust_gain",
            "from: [pool], settings: {method: ols, thrust_gain",
        ),
    )
    .unwrap();
    let out = run(root, &["build"]);
    assert!(!out.status.success());
    let e = stderr(&out);
    assert!(e.contains("thrust_gain: fit needs CFD cases"), "{e}");
}
