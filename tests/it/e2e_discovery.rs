//! End-to-end discovery beyond the named effects (examples/pool_wave): the seed-001 ROV's pool
//! runs with a wave maker's vertical force, which no effect of the table describes. The build
//! reports it as `unexplained` with its closed form, proven on the held-out runs. With a CFD
//! fit and a pool fit of the same vehicle among `from`, the diagnosis starts from the CFD
//! model and reports the held-out error of both; with two pool fits, from the better one.

use crate::common::*;

#[test]
fn the_wave_example_reports_the_discovered_sine() {
    let p = example("pool_wave");
    let dir = p.path();
    ok(dir, &["build"]);
    let d = json(dir, "reports/diagnosis.json");
    let effects = d["effects"].as_array().unwrap();
    let e = effects
        .iter()
        .find(|e| e.get("candidate").is_some())
        .unwrap_or_else(|| panic!("no candidate: {}", d["verdict"]));
    assert_eq!(e["name"], "unexplained", "a wave is no named effect");
    let c = &e["candidate"];
    assert_eq!(c["dof"], "heave");
    let term = &c["terms"][0];
    // The twin's wave (truth/pool/*.json): 12 N at 0.42 Hz.
    let f = term["frequency_hz"].as_f64().unwrap();
    assert!((f - 0.42).abs() < 0.05 * 0.42, "{f} Hz");
    let a = term["coefficient"].as_f64().unwrap();
    assert!((a - 12.0).abs() < 0.3 * 12.0, "{a} N");
    let [lo, hi] = [0, 1].map(|i| term["interval"][i].as_f64().unwrap());
    assert!(lo <= a && a <= hi, "{lo} {a} {hi}");
    let (before, after) = (
        c["validation_nmae_before"]["heave"].as_f64().unwrap(),
        c["validation_nmae_after"]["heave"].as_f64().unwrap(),
    );
    assert!(
        after < 0.5 * before,
        "held-out heave NMAE {before} -> {after}"
    );
    let html = read(dir, "reports/index.html");
    let expression = c["expression"].as_str().unwrap();
    assert!(expression.starts_with("Z += ") && expression.contains("sin(2 pi 0.42"));
    assert!(
        html.contains("Discovered beyond the named effects") && html.contains(expression),
        "the report shows the expression"
    );
    assert!(d["verdict"].as_str().unwrap().contains(expression));
}

#[test]
fn the_diagnosis_starts_from_the_cfd_model_and_reports_the_pool_fit_beside_it() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    ok(root, &["twin", "starccm", "--out", "cases/cfd"]);
    ok(
        root,
        &["twin", "pool", "--out", "cases/pool", "--truth", "truth"],
    );
    let pipeline = "vehicle:
  name: open-frame ROV (seed 001)
  mass_kg: 35.2
  inertia_kg_m2: {zz: 1.38}
  dofs: [surge, sway, heave, yaw]
  structure: diagonal
stages:
  cfd: {kind: starccm, inputs: [\"cases/cfd/*.csv\"]}
  pool: {kind: pool, inputs: [\"cases/pool/*/\"]}
  fit: {kind: fit, from: [cfd], settings: {method: ols, objective: equation_error}}
  fit_pool: {kind: fit, from: [pool]}
  diagnose: {kind: diagnose, from: [fit, fit_pool, pool]}
  diagnose_cfd: {kind: diagnose, from: [fit, pool], settings: {model: fit}}
  diagnose_pool: {kind: diagnose, from: [fit_pool, pool]}
  fit_pool_ls: {kind: fit, from: [pool], settings: {method: ols}}
  diagnose_two_pool: {kind: diagnose, from: [fit_pool, fit_pool_ls, pool]}
  report: {kind: report, from: [fit, fit_pool, pool, diagnose]}
";
    std::fs::write(root.join("pipeline.yaml"), pipeline).unwrap();
    ok(root, &["build"]);
    let d = json(root, "reports/diagnosis.json");
    let starts = d["started_from"].as_array().expect("started_from");
    let cost = |m: &str| -> f64 {
        starts.iter().find(|s| s["model"] == m).unwrap()["validation_cost"]
            .as_f64()
            .unwrap()
    };
    let (cfd, pool) = (cost("fit"), cost("fit_pool"));
    let chosen: Vec<&serde_json::Value> = starts.iter().filter(|s| s["chosen"] == true).collect();
    assert_eq!(chosen.len(), 1, "{starts:?}");
    // The CFD model is diagnosed although the pool fit predicts the pool runs better: it is
    // what the diagnosis is for.
    assert!(pool < cfd, "pool fit {pool}, CFD fit {cfd}");
    assert_eq!(chosen[0]["model"], "fit");
    assert_eq!(d["baseline"]["model"], "fit");
    assert_eq!(d["started_from"][0]["from_cfd"], true);
    // Two pool fits: the one that predicts the held-out runs better.
    let two = diagnosis_of(root, "diagnose_two_pool");
    let starts = two["started_from"].as_array().unwrap();
    let best = starts
        .iter()
        .min_by(|a, b| {
            let c = |s: &serde_json::Value| s["validation_cost"].as_f64().unwrap();
            c(a).total_cmp(&c(b))
        })
        .unwrap();
    assert_eq!(two["baseline"]["model"], best["model"], "{starts:?}");
    // Each score is the baseline the diagnosis of that model alone reports.
    for (stage, model, score) in [
        ("diagnose_cfd", "fit", cfd),
        ("diagnose_pool", "fit_pool", pool),
    ] {
        let alone = diagnosis_of(root, stage);
        assert_eq!(alone["baseline"]["model"], model);
        let c = alone["baseline"]["validation_cost"].as_f64().unwrap();
        assert!(
            (c - score).abs() <= 1e-9 * c.abs(),
            "{stage}: {c} vs {score}"
        );
    }
    assert!(read(root, "reports/index.html").contains("Started from <code>"));
}

/// The diagnosis.json of diagnose stage `stage`, from the cache.
fn diagnosis_of(root: &std::path::Path, stage: &str) -> serde_json::Value {
    let plan = hydrofit::pipeline::Plan::load(root, hydrofit::kinds::KINDS).unwrap();
    let i = plan
        .graph
        .instances
        .iter()
        .position(|x| x.id == stage)
        .unwrap();
    let path = plan.cache().object(&plan.keys[i]).join("diagnosis.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}
