//! End-to-end discovery beyond the named effects (examples/pool_wave): the seed-001 ROV's pool
//! runs with a wave maker's vertical force, which no effect of the table describes. The build
//! reports it as `unexplained` with its closed form, proven on the held-out runs.

mod common;
use common::*;

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
