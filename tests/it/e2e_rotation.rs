//! The diagnosis in roll and pitch, on the six-DOF twin's trials (crates/twin/src/six.rs, a
//! simulator written apart from the product's): a model in roll, pitch and yaw alone (a
//! vehicle whose logs have attitude, rates and depth but whose model leaves the translations
//! out) with position held, open-loop moments and a thruster lag concealed between the logged
//! command and the moment the body feels; and a six-DOF model with a roll moment concealed.

use crate::common::*;

/// Builds the twin's trials (position held, the default moments, `lag_s` concealed) with a
/// `[roll, pitch, yaw]` model, its default fit with `fit` settings, validation and diagnosis;
/// the diagnosis.
fn diagnosed(lag_s: f64, fit: &str, seed: u64) -> serde_json::Value {
    let stages = format!(
        "  fit: {{kind: fit, from: [pool], settings: {fit}}}\n  validate: {{kind: validate, from: [fit, pool]}}\n  diagnose: {{kind: diagnose, from: [fit, pool]}}\n  report: {{kind: report, from: [fit, pool, validate, diagnose]}}\n"
    );
    let p = built("[roll, pitch, yaw]", &stages, seed, |t| {
        t.position = t
            .position
            .map(|s| hydrofit::twin::six::Sines { mag: [0.0; 2], ..s });
        t.lag_s = lag_s;
    });
    let mut d = json(p.path(), "reports/diagnosis.json");
    d["_parameters"] = json(p.path(), "reports/parameters.json");
    d
}

/// A six-DOF twin project with the vehicle in `dofs` and `stages`, its cases the twin's default
/// trials (two minutes each) of `seed` changed by `trial`, built.
fn built(
    dofs: &str,
    stages: &str,
    seed: u64,
    trial: impl Fn(&mut hydrofit::twin::six::Trial),
) -> tempfile::TempDir {
    use hydrofit::twin::six;
    let p = crate::e2e_six_dof::six_dof_project(dofs, stages);
    let dir = p.path();
    let cases = dir.join("cases/pool");
    std::fs::remove_dir_all(&cases).unwrap();
    let trials: Vec<six::Trial> = six::default_trials()
        .into_iter()
        .map(|mut t| {
            t.duration_s = t.duration_s.min(120.0);
            trial(&mut t);
            t
        })
        .collect();
    six::render::write_trials(&cases, &dir.join("truth/concealed"), &trials, seed).unwrap();
    ok(dir, &["build"]);
    p
}

/// The names of the effects a diagnosis kept.
fn named(d: &serde_json::Value) -> Vec<String> {
    d["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["name"].as_str().unwrap().to_string())
        .collect()
}

/// Nothing concealed: what a model in roll, pitch and yaw leaves out of the twin is its
/// cross-coupled drag. No effect of the table is fitted, and discovery proposes the largest
/// such term in pitch, the twin's M_{|r|r} of -3.85 N m s^2 (crates/twin/src/six.rs: 11 % of
/// the pitch row's 70, halved off the diagonal, negative), named `coupled_drag`.
#[test]
fn a_model_in_roll_pitch_and_yaw_is_diagnosed_and_its_missing_cross_drag_found() {
    for seed in [3, 4] {
        cross_drag_found(&diagnosed(0.0, "{}", seed));
    }
}

fn cross_drag_found(d: &serde_json::Value) {
    // Off-diagonal drag is `coupled_drag` (docs/formats.md): discovery's term is reported
    // under that name, with its closed form.
    assert_eq!(named(d), ["coupled_drag"], "{}", d["verdict"]);
    let c = &d["effects"][0]["candidate"];
    assert_eq!(c["dof"], "pitch", "{c}");
    let term = c["terms"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["term"] == "|r| r")
        .unwrap_or_else(|| panic!("{c}"));
    let k = term["coefficient"].as_f64().unwrap();
    assert!((k / -3.85 - 1.0).abs() < 0.1, "M_|r|r {k}");
    // The effects that act in surge, sway or heave are listed untested, never scored.
    let untested: Vec<&str> = d["untested"]
        .as_array()
        .unwrap()
        .iter()
        .map(|u| u["name"].as_str().unwrap())
        .collect();
    for e in [
        "net_buoyancy",
        "tether_drag",
        "water_current",
        "coupled_drag",
    ] {
        assert!(untested.contains(&e), "{e}: {untested:?}");
    }
    let before = d["baseline"]["validation_nmae"].as_object().unwrap();
    assert_eq!(before.len(), 3, "{before:?}");
}

/// A thruster lag of 0.4 s concealed: the default fit takes it in as its command lag (0.28 s
/// here, asserted within a factor 1.6 of the truth), and the diagnosis, which runs the model
/// under that lag, does not name a thruster lag a second time.
#[test]
fn a_concealed_lag_is_the_fits_and_the_diagnosis_does_not_name_it_twice() {
    let d = diagnosed(0.4, "{}", 3);
    let lag = d["_parameters"]["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "T_cmd")
        .and_then(|p| p["value"].as_f64())
        .expect("the default fit estimates a command lag");
    assert!((0.25..0.64).contains(&lag), "T_cmd {lag}");
    assert!(
        !named(&d).iter().any(|n| n == "thruster_lag"),
        "{}",
        d["verdict"]
    );
}

/// A six-DOF model is diagnosed in roll and pitch too. The twin's trials (translations flown
/// closed-loop, open-loop moments) with a roll moment concealed that grows with the square of
/// the surge speed (`K += c |u| u`, c = 600 N m s^2/m^2; no coupling the fit has): discovery
/// proposes it in roll, named `coupled_drag` (off-diagonal drag), with its coefficient within
/// 15 % (measured: 575 on seed 3), and it lowers the held-out roll NMAE by a third or more
/// (0.50 to 0.25 on seed 3). Scored in surge, sway, heave and yaw alone, as the diagnosis once
/// scored a six-DOF model, roll was never compared: the verdict on these runs was
/// `unexplained` with no closed form.
#[test]
fn a_roll_moment_a_six_dof_model_lacks_is_found_in_roll() {
    for seed in [3, 4] {
        let c = 600.0;
        let d = six_dof_diagnosed(c, seed);
        let effect = d["effects"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["candidate"]["dof"] == "roll")
            .unwrap_or_else(|| panic!("seed {seed}: nothing proposed in roll: {}", d["verdict"]));
        assert_eq!(effect["name"], "coupled_drag", "{effect}");
        let terms = effect["candidate"]["terms"].as_array().unwrap();
        let k = terms
            .iter()
            .find(|t| t["term"] == "|u| u")
            .and_then(|t| t["coefficient"].as_f64())
            .unwrap_or_else(|| panic!("seed {seed}: {}", effect["candidate"]["expression"]));
        assert!(
            (k / c - 1.0).abs() < 0.15,
            "seed {seed}: K_|u|u {k}, hidden {c}"
        );
        let nmae = |w: &str| effect[w]["roll"].as_f64().unwrap();
        let (before, after) = (
            nmae("validation_nmae_before"),
            nmae("validation_nmae_after"),
        );
        assert!(
            after < 0.67 * before,
            "seed {seed}: roll NMAE {before} -> {after}"
        );
    }
}

/// The diagnosis of a diagonal six-DOF model on the twin's default trials (two minutes each)
/// with `roll_from_surge` concealed.
fn six_dof_diagnosed(roll_from_surge: f64, seed: u64) -> serde_json::Value {
    let p = built(
        "[surge, sway, heave, roll, pitch, yaw]",
        "  fit: {kind: fit, from: [pool]}\n  diagnose: {kind: diagnose, from: [fit, pool]}\n  report: {kind: report, from: [fit, pool, diagnose]}\n",
        seed,
        |t| t.roll_from_surge = roll_from_surge,
    );
    json(p.path(), "reports/diagnosis.json")
}
