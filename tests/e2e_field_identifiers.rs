//! End-to-end for the field-trial identifiers of the other papers, each on its example
//! project: ARX with order selection on the tank twin (seed 002, examples/tank_submarine).
//! The twins fly with simulators of their own (src/twin/tank.rs); the identifiers never see
//! that code, and the truth they are checked against comes from the twin's own model.

mod common;
use common::*;
use serde_json::Value;
use std::path::Path;

fn identifier<'a>(field: &'a Value, stage: &str) -> &'a Value {
    field["identifiers"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["stage"] == stage)
        .unwrap_or_else(|| panic!("no identifier {stage}"))
}

fn model<'a>(arx: &'a Value, name: &str) -> &'a Value {
    arx["detail"]["models"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"] == name || (name == "selected" && m["selected"] == true))
        .unwrap_or_else(|| panic!("no model {name}"))
}

fn fit(m: &Value) -> f64 {
    m["validation"][0]["fit_pct"]
        .as_f64()
        .unwrap_or(f64::NEG_INFINITY)
}

fn truth(dir: &Path, name: &str) -> f64 {
    read(dir, "truth/transfer.csv")
        .lines()
        .find_map(|l| {
            let mut it = l.split(',');
            (it.next() == Some(name)).then(|| it.next().unwrap().parse().unwrap())
        })
        .unwrap()
}

#[test]
fn arx_on_the_tank_twin_selects_simulates_and_ranks_as_the_paper() {
    let p = example("tank_submarine");
    let dir = p.path();
    ok(dir, &["build"]);
    let field = json(dir, "reports/field.json");

    // Pitch from the elevator: the selected structure simulates the held-out run closely,
    // with the twin's steady gain and dominant pole pair (e^{sh} of its continuous poles).
    let pitch = identifier(&field, "pitch");
    let sel = model(pitch, "selected");
    assert!(fit(sel) > 75.0, "pitch fit {}", fit(sel));
    let gain = sel["gain"].as_f64().unwrap();
    let g = truth(dir, "pitch_gain");
    assert!((gain - g).abs() < 0.1 * g.abs(), "pitch gain {gain} vs {g}");
    let h = pitch["detail"]["sample_s"].as_f64().unwrap();
    let (re, im) = (truth(dir, "pole1_re"), truth(dir, "pole1_im"));
    let z_true = (re * h).exp();
    let p0 = &sel["poles"][0];
    let z = p0[0].as_f64().unwrap().hypot(p0[1].as_f64().unwrap());
    assert!(
        (z - z_true).abs() < 0.08 * z_true,
        "dominant |z| {z} vs {z_true}"
    );
    let angle = p0[1].as_f64().unwrap().atan2(p0[0].as_f64().unwrap()).abs();
    assert!(
        (angle - im * h).abs() < 0.3 * im * h,
        "pole angle {angle} vs {}",
        im * h
    );

    // Depth rate (seed 002 Fig. 4 in form): tf1 matches poorly, tf3 and tf4 best and alike.
    let dr = identifier(&field, "depth_rate");
    let (tf1, tf3, tf4) = (
        fit(model(dr, "tf1")),
        fit(model(dr, "tf3")),
        fit(model(dr, "tf4")),
    );
    assert!(
        tf3 > tf1 + 30.0 && tf4 > tf1 + 30.0,
        "tf1 {tf1}, tf3 {tf3}, tf4 {tf4}"
    );
    assert!((tf3 - tf4).abs() < 3.0, "tf3 {tf3} vs tf4 {tf4}");
    assert!(fit(model(dr, "selected")) > 55.0);

    // Every coefficient is in parameters.json with its stage's provenance down to blake3.
    let params = json(dir, "reports/parameters.json");
    let tf3_b1 = params["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["model"] == "depth_rate.tf3" && p["name"] == "b1")
        .expect("tf3's b1");
    assert!(tf3_b1["stderr"].as_f64().unwrap() > 0.0);
    let inputs = tf3_b1["inputs"].as_array().unwrap();
    assert!(
        inputs
            .iter()
            .any(|i| i["path"] == "cases/pool/test1/actuators.csv")
    );
    assert!(
        inputs
            .iter()
            .all(|i| i["blake3"].as_str().unwrap().len() == 64)
    );

    let html = read(dir, "reports/index.html");
    for s in [
        "id=\"field-pitch\"",
        "id=\"field-depth_rate\"",
        "<td>tf4</td>",
        "truth pole",
    ] {
        assert!(html.contains(s), "report lacks {s}");
    }
}

#[test]
fn a_run_without_a_force_log_is_refused_by_a_force_driven_fit() {
    let p = example("tank_submarine");
    let dir = p.path();
    let text = read(dir, "pipeline.yaml").replace(
        "  report:\n",
        "  fit:\n    kind: fit\n    from: [pool]\n\n  report:\n",
    );
    std::fs::write(dir.join("pipeline.yaml"), text).unwrap();
    let o = run(dir, &["build"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("has no thrust.csv") && e.contains("arx"), "{e}");
}
