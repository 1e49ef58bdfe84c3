//! The default pool fit on what a real vehicle logs: closed-loop runs of the field twin (a
//! 30 kg ROV whose only velocity sensor is a DVL navigation log, 0.15 s late and low-passed, at
//! an irregular 5-7 Hz; a bursty command log; 6 N of buoyancy the pipeline does not declare).
//! With nothing but `fit: {from: [pool]}` the model recovers the twin's inertia and drag where
//! the runs excite them, finds the buoyancy and the lag, keeps the added mass inside its prior,
//! and beats both baselines on the held-out runs in every DOF; a model worse than predicting
//! rest is flagged.

use crate::common::{json, ok, run, stderr};
use hydrofit::twin::field::{Hidden, default_runs, write_runs};
use std::path::Path;

const PIPELINE: &str = "vehicle:
  name: field twin without its tether
  mass_kg: 30.0
  inertia_kg_m2: {zz: 1.0}
  dofs: [surge, sway, heave, yaw]
  command_limits: {surge: 60, sway: 50, heave: 45, yaw: 9}
stages:
  pool: {kind: pool, inputs: [\"cases/pool/*/\"]}
  fit: {kind: fit, from: [pool]}
  validate: {kind: validate, from: [fit, pool]}
  report: {kind: report, from: [fit, pool, validate]}
";

fn parameter(dir: &Path, name: &str) -> serde_json::Value {
    json(dir, "reports/parameters.json")["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == name)
        .unwrap_or_else(|| panic!("no parameter {name}"))
        .clone()
}

#[test]
fn the_default_fit_of_navigation_log_runs_recovers_the_vehicle_and_beats_the_baselines() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    // The tether's drag would bend the drag terms (a pool-only model cannot tell it from the
    // vehicle's own): this twin hides buoyancy and the navigation filter's lag only.
    let hidden = Hidden {
        tether_k: 0.0,
        ..Hidden::default()
    };
    write_runs(
        &root.join("cases/pool"),
        &root.join("truth"),
        &default_runs(),
        &hidden,
        1,
    )
    .unwrap();
    std::fs::write(root.join("pipeline.yaml"), PIPELINE).unwrap();
    ok(root, &["build"]);
    // Every parameter traces to the pool runs it was fitted on, down to each file's blake3.
    let trace = ok(root, &["provenance", "Z_w"]);
    let nav = hydrofit::core::fsutil::hash_file(&root.join("cases/pool/box_1/nav.csv")).unwrap();
    assert!(
        trace.contains("objective output error")
            && trace.contains("<- 4 pool runs:")
            && trace.contains(&format!("cases/pool/box_1/nav.csv blake3 {nav}")),
        "{trace}"
    );
    // The twin's heave (twin::field::hydro), which its depth steps excite apart from the
    // controller's other loops: inertia and drag within 15 %. In the horizontal DOFs, flown
    // in closed loop behind a navigation filter whose lag the model takes as a command lag,
    // the inertia and the drag trade against that lag (the held-out checks below hold them).
    let truth = [
        ("Z_wdot", -40.0, 0.15),
        ("Z_w", -14.0, 0.15),
        ("Z_ww", -70.0, 0.15),
    ];
    let mut report = String::new();
    for (name, t, _) in truth {
        report += &format!("{name} {} (truth {t})\n", parameter(root, name)["value"]);
    }
    for (name, t, tol) in truth {
        let v = parameter(root, name)["value"].as_f64().unwrap();
        assert!(
            (v - t).abs() <= tol * t.abs(),
            "{name} = {v}, twin {t}\n{report}"
        );
    }
    // Every added mass inside the 2x prior (30 kg, 1 kg m^2).
    for (name, rigid) in [
        ("X_udot", 30.0),
        ("Y_vdot", 30.0),
        ("Z_wdot", 30.0),
        ("N_rdot", 1.0),
    ] {
        let v = parameter(root, name)["value"].as_f64().unwrap();
        assert!(
            v <= 0.0 && v >= -2.0 * rigid - 1e-9,
            "{name} = {v}\n{report}"
        );
    }
    // The buoyancy the pipeline did not declare: a constant heave force (SNAME: up is
    // negative), within 5 %.
    let z0 = parameter(root, "Z_0")["value"].as_f64().unwrap();
    assert!((z0 + 6.0).abs() < 0.3, "Z_0 = {z0} for 6 N of buoyancy");
    // The lag the navigation filter adds (0.15 s late, 0.25 s low-pass).
    let lag = parameter(root, "T_cmd")["value"].as_f64().unwrap();
    assert!((0.25..=0.5).contains(&lag), "T_cmd = {lag}");
    // Held out: better than predicting rest and than the per-DOF first-order model, in every
    // DOF, and the report says so (no shortfall named).
    let v = json(root, "reports/validation.json");
    let shortfalls = v["models"][0]["below_baselines"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    assert!(shortfalls.is_empty(), "{shortfalls:?}");
    let html = std::fs::read_to_string(root.join("reports/index.html")).unwrap();
    assert!(
        !html.contains("does not beat"),
        "the report names a shortfall"
    );
}

#[test]
fn a_model_worse_than_rest_is_flagged() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    write_runs(
        &root.join("cases/pool"),
        &root.join("truth"),
        &default_runs(),
        &Hidden::default(),
        2,
    )
    .unwrap();
    // A model that cannot explain the runs: no constant force (the 6 N of buoyancy), no lag,
    // and the added mass held at a tenth of the vehicle's.
    let pipeline = PIPELINE
        .replace("  command_limits:", "  constant_force: [surge]\n  command_limits:")
        .replace(
            "fit: {kind: fit, from: [pool]}",
            "fit: {kind: fit, from: [pool], settings: {command_lag: none, added_mass_prior: {heave: 0.1}, constants: listed}}",
        );
    std::fs::write(root.join("pipeline.yaml"), pipeline).unwrap();
    ok(root, &["build"]);
    let v = json(root, "reports/validation.json");
    let shortfalls = v["models"][0]["below_baselines"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    assert!(
        shortfalls.iter().any(|s| s["dof"] == "heave"),
        "heave is not flagged: {shortfalls:?}"
    );
    let html = std::fs::read_to_string(root.join("reports/index.html")).unwrap();
    assert!(html.contains("heave"), "the report names heave");
}

/// Runs whose logs give no horizontal velocity (the field twin's runs without their DVL
/// navigation log and UWB: commands and depth only) cannot fit a vehicle declared in surge,
/// sway, heave and yaw: the build fails, names each run and what it lacks, and says which
/// `dofs` the logs support.
#[test]
fn a_fit_the_logs_cannot_support_names_the_dofs_they_can() {
    let (d, runs) = two_training_runs();
    let root = d.path();
    for r in &runs {
        for f in ["nav.csv", "uwb.csv"] {
            std::fs::remove_file(root.join("cases/pool").join(&r.name).join(f)).unwrap();
        }
    }
    let yaml = PIPELINE.replace("validate: {kind: validate, from: [fit, pool]}\n  report: {kind: report, from: [fit, pool, validate]}\n", "");
    std::fs::write(root.join("pipeline.yaml"), yaml).unwrap();
    let o = run(root, &["build"]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("its sensors gave no surge, sway, yaw velocity")
            && err.contains("`dofs: [heave]`"),
        "{err}"
    );
}

/// A navigation log with the AHRS's attitude and roll and pitch rates but no DVL velocity (as a
/// vehicle without a DVL writes it) gives heave from the depth, roll and pitch from their rates
/// and yaw from the heading: a vehicle
/// declared in surge, sway, heave and yaw is refused, and the hint names all four DOFs the logs
/// give, roll and pitch among them although the vehicle does not declare them.
#[test]
fn the_hint_names_the_dofs_the_logs_give_beyond_the_declared_ones() {
    let (d, runs) = two_training_runs();
    let root = d.path();
    for r in &runs {
        let dir = root.join("cases/pool").join(&r.name);
        std::fs::remove_file(dir.join("uwb.csv")).unwrap();
        let nav = std::fs::read_to_string(dir.join("nav.csv")).unwrap();
        let attitude: String = nav
            .lines()
            .map(|l| {
                let c: Vec<&str> = l.split(',').collect();
                let rates = if c[0] == "t" { "p_dps,q_dps" } else { "0,0" };
                format!("{},{},{rates}\n", c[0], c[4..].join(","))
            })
            .collect();
        assert!(
            attitude.starts_with("t,roll_deg,pitch_deg,yaw_deg,p_dps,q_dps\n"),
            "{attitude:.80}"
        );
        std::fs::write(dir.join("nav.csv"), attitude).unwrap();
    }
    let yaml = PIPELINE.replace("validate: {kind: validate, from: [fit, pool]}\n  report: {kind: report, from: [fit, pool, validate]}\n", "");
    std::fs::write(root.join("pipeline.yaml"), yaml).unwrap();
    let o = run(root, &["build"]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("its sensors gave no surge, sway velocity")
            && err.contains("`dofs: [heave, roll, pitch, yaw]`")
            && err.contains("in pipeline.yaml), or log what gives the others"),
        "{err}"
    );
}

/// A vehicle fitted in some of the pool's DOFs (heave and yaw here) is diagnosed in those:
/// surge and sway are held at rest and never scored, and the effects that act only there are
/// listed untested with the reason. (Roll, pitch and yaw: tests/it/e2e_rotation.rs.)
#[test]
fn a_model_in_heave_and_yaw_is_diagnosed_in_those_dofs() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    let runs: Vec<_> = default_runs()
        .into_iter()
        .filter(|r| ["box_1", "depth_steps", "turns"].contains(&r.name.as_str()))
        .collect();
    write_runs(
        &root.join("cases/pool"),
        &root.join("truth"),
        &runs,
        &Hidden::default(),
        1,
    )
    .unwrap();
    let yaml = PIPELINE
        .replace("dofs: [surge, sway, heave, yaw]", "dofs: [heave, yaw]")
        .replace("command_limits: {surge: 60, sway: 50, heave: 45, yaw: 9}", "command_limits: {heave: 45, yaw: 9}")
        .replace(
            "report: {kind: report, from: [fit, pool, validate]}",
            "diagnose: {kind: diagnose, from: [fit, pool]}\n  report: {kind: report, from: [fit, pool, validate, diagnose]}",
        );
    std::fs::write(root.join("pipeline.yaml"), yaml).unwrap();
    ok(root, &["build"]);
    let dx = json(root, "reports/diagnosis.json");
    let dofs: Vec<&String> = dx["baseline"]["validation_nmae"]
        .as_object()
        .unwrap()
        .keys()
        .collect();
    assert_eq!(dofs, ["heave", "yaw"], "{}", dx["verdict"]);
    for m in dx["mismatch"].as_array().unwrap() {
        assert!(m["dof"] == "heave" || m["dof"] == "yaw", "{m}");
    }
    // What acts in surge and sway only is listed untested, with the reason.
    let untested = dx["untested"].to_string();
    assert!(
        untested.contains("water_current") && untested.contains("compared in heave, yaw only"),
        "{untested}"
    );
    let html = std::fs::read_to_string(root.join("reports/index.html")).unwrap();
    assert!(html.contains("Why the pool runs and the model differ"));
}

/// A project folder with the field twin's first two runs (both training runs), and their specs.
fn two_training_runs() -> (tempfile::TempDir, Vec<hydrofit::twin::field::RunSpec>) {
    let d = tempfile::tempdir().unwrap();
    let runs: Vec<_> = default_runs().into_iter().take(2).collect();
    write_runs(
        &d.path().join("cases/pool"),
        &d.path().join("truth"),
        &runs,
        &Hidden::default(),
        1,
    )
    .unwrap();
    (d, runs)
}

/// The pool twin logged as a vehicle that logs only its own navigation
/// (`hydrofit twin pool --navigation-log`: a DVL's velocity and an AHRS heading at 4-6 Hz,
/// late and low-passed, depth and the thrust log; no UWB, sonar or IMU): the runs hold those
/// files only, the pool stage fuses them to within a few cm/s of the true velocities, and the
/// default fit recovers the reference vehicle's added mass and quadratic drag in the DOFs
/// the runs drive at speed.
#[test]
fn the_pool_twin_logged_as_a_navigation_log_is_fused_and_fitted() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    let args = ["twin", "pool", "--navigation-log", "--effect", "none"];
    ok(root, &[&args[..], &["--seed", "2"]].concat());
    for run in [
        "mixed",
        "prbs_a",
        "prbs_b",
        "surge_steps",
        "sway_heave",
        "yaw_turns",
    ] {
        let mut files: Vec<String> = std::fs::read_dir(root.join("cases/pool").join(run))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        files.sort();
        assert_eq!(
            files,
            ["depth.csv", "nav.csv", "run.yaml", "thrust.csv"],
            "{run}"
        );
    }
    let pipeline = "vehicle:
  name: reference ROV, navigation log only
  mass_kg: 35.2
  inertia_kg_m2: {zz: 1.38}
  dofs: [surge, sway, heave, yaw]
stages:
  pool: {kind: pool, inputs: [\"cases/pool/*/\"]}
  fit: {kind: fit, from: [pool]}
  report: {kind: report, from: [pool, fit], inputs: [\"truth/pool/*.csv\"]}
";
    std::fs::write(root.join("pipeline.yaml"), pipeline).unwrap();
    ok(root, &["build"]);
    // The fusion against the twin's true velocities (the navigation log's own 1-2 cm/s noise,
    // its lateness and its low-pass): m/s, m/s, m/s, rad/s.
    let fusion = json(root, "reports/fusion.json");
    for r in fusion["runs"].as_array().unwrap() {
        let rmse = &r["accuracy_against_truth"]["rmse"];
        for (dof, most) in [
            ("surge", 0.08),
            ("sway", 0.08),
            ("heave", 0.03),
            ("yaw", 0.05),
        ] {
            let x = rmse[dof].as_f64().unwrap();
            assert!(x < most, "{}: {dof} rmse {x}", r["run"]);
        }
    }
    // The reference vehicle's coefficients (the twin's truth, seed 001): added mass within
    // 20 %, quadratic drag within 12 % in surge, sway and yaw (heave's linear and quadratic
    // drag trade against each other over its slow steps, and are not held).
    for (name, t, tol) in [
        ("X_udot", -16.04, 0.2),
        ("Y_vdot", -37.74, 0.2),
        ("Z_wdot", -83.60, 0.2),
        ("N_rdot", -1.06, 0.2),
        ("X_uu", -44.17, 0.12),
        ("Y_vv", -114.30, 0.12),
        ("N_rr", -2.64, 0.12),
    ] {
        let v = parameter(root, name)["value"].as_f64().unwrap();
        assert!((v - t).abs() <= tol * t.abs(), "{name} = {v}, twin {t}");
    }
}
