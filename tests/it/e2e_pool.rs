//! End-to-end: pool runs through import, fusion and validation, on the real binary.

use crate::common::*;

#[test]
fn a_new_pool_run_reruns_only_its_fusion_and_the_validation() {
    let p = project();
    let dir = p.path();
    ok(dir, &["build"]);
    hydrofit::core::fsutil::copy_dir(
        &dir.join("cases/pool/mixed"),
        &dir.join("cases/pool/mixed_again"),
    )
    .unwrap();
    let status = stdout(&run(dir, &["status"]));
    let lines: Vec<&str> = status.lines().collect();
    assert_eq!(lines.len(), 5, "{status}");
    assert!(
        lines[0].starts_with("pool[mixed_again]: never built"),
        "{status}"
    );
    assert!(
        lines
            .iter()
            .any(|l| l.starts_with("validate: new upstream pool[mixed_again]")),
        "{status}"
    );
    assert!(
        lines
            .iter()
            .any(|l| l.starts_with("compare: new upstream pool[mixed_again]")),
        "{status}"
    );
    assert!(
        lines
            .iter()
            .any(|l| l.starts_with("diagnose: new upstream pool[mixed_again]")),
        "{status}"
    );
    assert!(lines[4].starts_with("report: "), "{status}");
    assert_eq!(ran(&ok(dir, &["build"])), 5);
}

#[test]
fn the_report_scores_the_model_on_every_pool_run_and_states_fusion_accuracy() {
    let p = project();
    let dir = p.path();
    ok(dir, &["build"]);
    let v = json(dir, "reports/validation.json");
    let runs = v["models"][0]["runs"].as_array().unwrap();
    for name in [
        "surge_steps",
        "sway_heave",
        "yaw_turns",
        "prbs_a",
        "mixed",
        "prbs_b",
    ] {
        let r = runs
            .iter()
            .find(|r| r["run"] == name)
            .unwrap_or_else(|| panic!("{name} not scored"));
        let role = read(dir, &format!("cases/pool/{name}/run.yaml"));
        assert!(
            role.contains(&format!("role: {}", r["role"].as_str().unwrap())),
            "{name}"
        );
        for dof in ["surge", "sway", "heave", "yaw"] {
            let m = &r["dofs"][dof];
            for k in ["mae", "nmae", "rmse_pct", "residual_acf_outside_band"] {
                assert!(
                    m[k].as_f64().is_some_and(f64::is_finite),
                    "{name} {dof} {k}: {m}"
                );
            }
        }
        // The shipped runs conceal thruster lag and tether drag: the CFD model must visibly
        // miss them (a residual far from white), which is what the diagnosis has to explain.
        assert!(
            r["dofs"]["surge"]["residual_acf_outside_band"]
                .as_f64()
                .unwrap()
                > 0.5,
            "{name}"
        );
    }
    let f = json(dir, "reports/fusion.json");
    for r in f["runs"].as_array().unwrap() {
        let a = &r["accuracy_against_truth"];
        for dof in ["surge", "sway"] {
            let e = a["rmse"][dof].as_f64().unwrap();
            assert!(e < 0.02, "{} {dof}: fusion rmse {e} m/s", r["run"]);
            let z = a["error_over_std"][dof].as_f64().unwrap();
            assert!((0.6..1.5).contains(&z), "{} {dof}: error/std {z}", r["run"]);
        }
        assert!(a["rmse"]["heave"].as_f64().unwrap() < 0.012);
        assert!(a["rmse"]["yaw"].as_f64().unwrap() < 0.008);
    }
    let html = read(dir, "reports/index.html");
    for id in [
        "id=\"fusion\"",
        "id=\"fusion-accuracy\"",
        "id=\"pool-validation\"",
        "id=\"cross-validation\"",
        "id=\"pool-mixed\"",
    ] {
        assert!(html.contains(id), "{id} missing from the report");
    }
}

#[test]
fn bad_pool_runs_stop_only_themselves() {
    let p = project();
    let dir = p.path();
    hydrofit::core::fsutil::copy_dir(
        &dir.join("cases/pool/mixed"),
        &dir.join("cases/pool/broken"),
    )
    .unwrap();
    std::fs::remove_file(dir.join("cases/pool/broken/thrust.csv")).unwrap();
    let o = run(dir, &["build"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("cases/pool/broken/thrust.csv: the run has no command log"),
        "{err}"
    );
    assert!(err.contains("help:"), "{err}");
    // Optional sensors may go: a run without sonar and depth still fuses.
    std::fs::remove_dir_all(dir.join("cases/pool/broken")).unwrap();
    std::fs::remove_file(dir.join("cases/pool/mixed/sonar.csv")).unwrap();
    std::fs::remove_file(dir.join("cases/pool/mixed/depth.csv")).unwrap();
    ok(dir, &["build"]);
    let uwb = read(dir, "cases/pool/prbs_b/uwb.csv").replacen("\n0.", "\n0;", 1);
    std::fs::write(dir.join("cases/pool/prbs_b/uwb.csv"), uwb).unwrap();
    let err = stderr(&run(dir, &["build"]));
    assert!(err.contains("cases/pool/prbs_b/uwb.csv:2:"), "{err}");
}
