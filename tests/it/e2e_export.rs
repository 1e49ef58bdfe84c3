//! The model where it is used: a build writes the identified model for gz-sim, uuv_simulator,
//! MSS and hydrofit's own YAML with its provenance; `hydrofit export` writes it from the
//! cache; and a simulator's model with its damping 30 % off, read by a `model` stage, is
//! flagged by the validation against the pool runs beside the identified model.

use crate::common::{json, ok, run, stderr};
use std::path::Path;

const PIPELINE: &str = "vehicle:
  name: seed-001 ROV
  mass_kg: 35.2
  inertia_kg_m2: {zz: 1.38}
  dofs: [surge, sway, heave, yaw]
  structure: diagonal
stages:
  pool: {kind: pool, inputs: [\"cases/pool/*/\"]}
  fit: {kind: fit, from: [pool], settings: {command_lag: none}}
  sim: {kind: model, inputs: [\"models/*\"]}
  validate: {kind: validate, from: [fit, sim, pool]}
  export: {kind: export, from: [fit]}
  report: {kind: report, from: [fit, sim, pool, validate]}
";

/// The twin's vehicle (seed 001, Table 1) as a simulator would hold it, with its linear and
/// quadratic damping scaled by `k`.
fn simulator_model(k: f64) -> String {
    let c = [
        ("X_udot", -16.04, 1.0),
        ("Y_vdot", -37.74, 1.0),
        ("Z_wdot", -83.60, 1.0),
        ("N_rdot", -1.06, 1.0),
        ("X_u", -2.41, k),
        ("Y_v", -1.50, k),
        ("Z_w", -21.75, k),
        ("N_r", -1.18, k),
        ("X_uu", -44.17, k),
        ("Y_vv", -114.30, k),
        ("Z_ww", -121.30, k),
        ("N_rr", -2.64, k),
    ];
    let lines: String = c
        .iter()
        .map(|(n, v, s)| format!("  \"{n}\": {}\n", v * s))
        .collect();
    format!(
        "name: twin in a simulator\nmass_kg: 35.2\ninertia_kg_m2: [0.0, 0.0, 1.38]\ndofs: [surge, sway, heave, yaw]\ncoefficients:\n{lines}"
    )
}

fn held_out_nmae(root: &Path, model: &str) -> Vec<f64> {
    let v = json(root, "reports/validation.json");
    let m = v["models"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["model"] == model)
        .unwrap_or_else(|| panic!("no model {model}"))
        .clone();
    m["runs"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["role"] == "validate")
        .flat_map(|r| {
            r["dofs"]
                .as_object()
                .unwrap()
                .values()
                .map(|d| d["nmae"].as_f64().unwrap())
                .collect::<Vec<_>>()
        })
        .collect()
}

#[test]
fn a_simulator_model_with_wrong_damping_is_flagged_and_the_model_is_exported() {
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
    std::fs::create_dir_all(root.join("models")).unwrap();
    std::fs::write(root.join("models/sim.model.yaml"), simulator_model(1.3)).unwrap();
    std::fs::write(root.join("pipeline.yaml"), PIPELINE).unwrap();
    ok(root, &["build"]);
    // The simulator's model is validated beside the identified one, and falls short.
    let v = json(root, "reports/validation.json");
    let sim = v["models"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["model"].as_str().unwrap().starts_with("sim"))
        .unwrap()
        .clone();
    let flagged = sim["behind_identified"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let dofs: Vec<&str> = flagged.iter().filter_map(|b| b["dof"].as_str()).collect();
    assert!(
        dofs.contains(&"surge") && dofs.contains(&"sway") && dofs.contains(&"yaw"),
        "the simulator's model is not flagged where its damping is off: {flagged:?}"
    );
    let html = std::fs::read_to_string(root.join("reports/index.html")).unwrap();
    assert!(html.contains("predicts the held-out runs worse than the model identified"));
    let fit = held_out_nmae(root, "fit");
    let wrong = held_out_nmae(root, sim["model"].as_str().unwrap());
    let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
    assert!(mean(&wrong) > 1.2 * mean(&fit), "{wrong:?} against {fit:?}");
    // The export stage published the model in every default format, with its provenance.
    for f in [
        "fit.sdf",
        "fit.uuv.xacro",
        "hydrofit_fit.m",
        "fit.model.yaml",
    ] {
        let text = std::fs::read_to_string(root.join("reports").join(f)).unwrap();
        assert!(text.contains("fit stage `fit`, method pem"), "{f}");
        assert!(
            text.contains("cases/pool/prbs_a/thrust.csv"),
            "{f}: the inputs travel"
        );
    }
    roxmltree::Document::parse(&std::fs::read_to_string(root.join("reports/fit.sdf")).unwrap())
        .expect("the SDF parses");
    // hydrofit export writes it from the cache; import-model reads it back to the same model.
    let o = run(root, &["export", "--to", "yaml", "gazebo", "--out", "out"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let back = ok(
        root,
        &["import-model", root.join("out/fit.sdf").to_str().unwrap()],
    );
    let exported = std::fs::read_to_string(root.join("out/fit.model.yaml")).unwrap();
    let coefficient = |text: &str, name: &str| -> f64 {
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{name}:")))
            .unwrap();
        line.split(':').nth(1).unwrap().trim().parse().unwrap()
    };
    for name in ["X_udot", "Y_vv", "N_r"] {
        let (a, b) = (coefficient(&exported, name), coefficient(&back, name));
        assert!(
            (a - b).abs() <= 1e-9 * a.abs(),
            "{name}: {a} exported, {b} read back"
        );
    }
    // A model file whose format hydrofit cannot tell is a clear error.
    std::fs::write(root.join("models/sim.model.yaml"), "name: x\n").unwrap();
    let o = run(root, &["build", "sim"]);
    assert!(
        !o.status.success() && stderr(&o).contains("models/sim.model.yaml"),
        "{}",
        stderr(&o)
    );
}
