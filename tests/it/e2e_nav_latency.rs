//! The navigation log's latency, measured against the depth gauge and taken out
//! (`src/pool/fusion/latency.rs`, `src/diagnose/latency.rs`), on the field twin
//! (examples/field_rov), whose navigation filter is a first-order low-pass (`nav_filter_s`)
//! behind a transport latency (`nav_latency_s`) while its depth gauge is prompt.

use crate::common::*;

/// The report's measured latency: the median over the runs and how many of them told it.
fn measured(dir: &std::path::Path) -> (f64, usize) {
    let html = read(dir, "reports/index.html");
    let key = "the navigation log runs ";
    let at = html.find(key).expect("a latency in the report") + key.len();
    let rest = &html[at..];
    let value: f64 = rest[..rest.find(' ').unwrap()].parse().unwrap();
    let of = rest.find("(median of ").unwrap() + "(median of ".len();
    let runs: usize = rest[of..of + rest[of..].find(' ').unwrap()]
        .parse()
        .unwrap();
    (value, runs)
}

/// Measured on the runs that change depth, the latency lies between the transport latency and
/// that plus the filter's time constant (a low-pass delays a motion by up to its time
/// constant, less the faster the motion). The diagnosis of the example's model (no command
/// lag) takes it out and names no lag: the twin's thrusters have none. Set in the pool stage's
/// settings, it is taken out of every run before the fusion; the diagnosis then has nothing
/// left to take out and names no lag either; the hidden buoyancy within 15 % both times.
#[test]
fn a_navigation_logs_latency_is_measured_and_taken_out() {
    let p = example("field_rov");
    let dir = p.path();
    ok(dir, &["build"]);
    let h = json(dir, "truth/box_1.json")["hidden"].clone();
    let (latency, filter) = (
        h["nav_latency_s"].as_f64().unwrap(),
        h["nav_filter_s"].as_f64().unwrap(),
    );
    let (value, runs) = measured(dir);
    assert!(
        value >= latency && value <= latency + filter,
        "measured {value} s; the log's latency {latency} s behind a {filter} s filter"
    );
    assert!(runs >= 3, "told by {runs} runs");
    let d = json(dir, "reports/diagnosis.json");
    let out = d["runs"]["latency_taken_out_s"].as_f64();
    assert!(
        out.is_some_and(|x| (x - value).abs() < 0.006),
        "the diagnosis took out {out:?}, the runs measured {value}"
    );
    no_lag_and_the_buoyancy(&d, &h);

    let pipeline = read(dir, "pipeline.yaml");
    let at = "    inputs: [\"cases/pool/*/\"]\n";
    assert!(pipeline.contains(at));
    let set = format!("{at}    settings: {{fusion: {{nav_latency_s: {value}}}}}\n");
    std::fs::write(dir.join("pipeline.yaml"), pipeline.replacen(at, &set, 1)).unwrap();
    ok(dir, &["build"]);
    let d = json(dir, "reports/diagnosis.json");
    assert!(
        d["runs"]["latency_taken_out_s"].is_null(),
        "taken out twice"
    );
    no_lag_and_the_buoyancy(&d, &h);
    let html = read(dir, "reports/index.html");
    assert!(
        html.contains("read 0."),
        "the shift is not among the timing repairs"
    );

    // A latency no log has is refused with what the setting means.
    let wrong =
        read(dir, "pipeline.yaml").replace(&format!("nav_latency_s: {value}"), "nav_latency_s: 3");
    std::fs::write(dir.join("pipeline.yaml"), wrong).unwrap();
    let o = run(dir, &["build"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("fusion.nav_latency_s = 3"),
        "{}",
        stderr(&o)
    );
}

/// The diagnosis `d` names no lag, and the twin's hidden buoyancy (`h`) within 15 %.
fn no_lag_and_the_buoyancy(d: &serde_json::Value, h: &serde_json::Value) {
    let effects = d["effects"].as_array().unwrap();
    for e in effects {
        assert!(
            e["name"] != "thruster_lag" && e["name"] != "sensor_delay",
            "a lag named with the log's latency taken out: {}",
            d["verdict"]
        );
    }
    field_buoyancy_named(d, h);
}
