//! End-to-end: the real binary on a temporary copy of the shipped project.

use crate::common::*;

#[test]
fn cold_build_then_nothing_to_do() {
    let p = project();
    let dir = p.path();
    let out = ok(dir, &["build"]);
    let n = count(dir, "cases/cfd/starccm")
        + count(dir, "cases/cfd/openfoam")
        + count(dir, "cases/cfd/sphere")
        + count(dir, "cases/pool");
    assert_eq!(ran(&out), n + SINGLE_STAGES, "{out}");
    for f in [
        "index.html",
        "parameters.json",
        "validation.json",
        "fusion.json",
        "fit.sdf",
        "fit.uuv.xacro",
        "hydrofit_fit.m",
        "fit.model.yaml",
    ] {
        assert!(dir.join("reports").join(f).is_file(), "reports/{f} missing");
    }
    // The shipped sphere cases were run as tasks of one Slurm array: the report says which.
    let html = read(dir, "reports/index.html");
    for case in ["sphere_0.5N_x", "sphere_2N_z"] {
        let stamp = json(dir, &format!("cases/cfd/sphere/{case}/hydrofit.run.json"));
        let job = stamp["slurm_job"].as_str().unwrap();
        assert!(
            html.contains(&format!("read from the case folder (Slurm job {job} on ")),
            "{case}: {job}"
        );
    }
    // Cases list in the order of their numbers, not of their characters.
    let at = |case: &str| {
        html.find(&format!(">{case}<"))
            .unwrap_or_else(|| panic!("{case}"))
    };
    assert!(at("surge_2N") < at("surge_10N") && at("surge_10N") < at("surge_100N"));
    let out = ok(dir, &["build"]);
    assert_eq!(ran(&out), 0, "{out}");
    assert!(out.contains("hydrofit: up to date"), "{out}");
    assert_eq!(stdout(&run(dir, &["status"])).trim(), "up to date");
}

#[test]
fn parameters_json_has_the_contract_shape_and_recovers_the_truth() {
    let p = project();
    let dir = p.path();
    ok(dir, &["build"]);
    let truth = [
        ("X_udot", -16.04),
        ("Y_vdot", -37.74),
        ("Z_wdot", -83.60),
        ("N_rdot", -1.06),
        ("X_u", -2.41),
        ("Y_v", -1.50),
        ("Z_w", -21.75),
        ("N_r", -1.18),
        ("X_uu", -44.17),
        ("Y_vv", -114.30),
        ("Z_ww", -121.30),
        ("N_rr", -2.64),
    ];
    let params = json(dir, "reports/parameters.json");
    // The vehicle's model; the OpenFOAM cylinder's parameters follow under model `cylinder`.
    let list: Vec<&serde_json::Value> = params["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| p["model"] == "fit")
        .collect();
    assert_eq!(list.len(), truth.len());
    for (name, t) in truth {
        let p = list
            .iter()
            .find(|p| p["name"] == name)
            .unwrap_or_else(|| panic!("{name} missing"));
        let v = p["value"].as_f64().unwrap();
        assert!(((v - t) / t).abs() < 0.02, "{name} = {v}, truth {t}");
        assert!(p["stderr"].as_f64().unwrap() > 0.0);
        assert!(!p["unit"].as_str().unwrap().is_empty());
        assert_eq!(p["stage"], "fit");
        assert_eq!(p["method"], "ols");
        assert!(p["settings"].as_object().unwrap().contains_key("seed"));
        let inputs = p["inputs"].as_array().unwrap();
        let first = &inputs[0];
        let path = first["path"].as_str().unwrap();
        assert!(path.starts_with("cases/cfd/starccm/"), "{path}");
        assert_eq!(
            first["blake3"].as_str().unwrap(),
            hydrofit::core::fsutil::hash_file(&dir.join(path)).unwrap()
        );
    }
    let v = json(dir, "reports/validation.json");
    let runs = v["models"][0]["runs"].as_array().unwrap();
    assert!(runs.len() > 30);
    for r in runs.iter().filter(|r| {
        dir.join("cases/cfd/starccm")
            .join(format!("{}.csv", r["run"].as_str().unwrap()))
            .is_file()
    }) {
        assert_eq!(r["role"], "train");
        for (dof, m) in r["dofs"].as_object().unwrap() {
            // The twin's model is the fitted structure: each run is reproduced within ~2 % of its peak.
            let pct = m["rmse_pct"].as_f64().unwrap();
            assert!(pct < 2.0, "{} {dof}: rmse {pct} %", r["run"]);
            assert!(m["nmae"].as_f64().unwrap() < 0.05);
        }
    }
}

/// The twin conceals a thruster lag in the motor's speed (thrust quadratic in it) and tether
/// drag on the cable paid out; the diagnosis fits a first-order lag on the force and drag on
/// the straight-line distance plus slack. It must name both, with what its forms can say of
/// them, and leave what its forms cannot say as unexplained rather than as a third name.
#[test]
fn the_shipped_diagnosis_names_the_concealed_lag_and_tether() {
    let p = project();
    let dir = p.path();
    ok(dir, &["build"]);
    let truth: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(manifest_dir().join("truth/pool/mixed.json")).unwrap(),
    )
    .unwrap();
    let hidden = |name: &str, key: &str| {
        truth["effects"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["name"] == name)
            .and_then(|e| e[key].as_f64())
            .unwrap()
    };
    let d = json(dir, "reports/diagnosis.json");
    let effects = d["effects"].as_array().unwrap();
    let names: Vec<&str> = effects
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    // Both are named, in either order (the greedy rounds pick first whichever alone explains
    // more per parameter it needs; here they are within a parameter's penalty of each other).
    let mut two = names[..2.min(names.len())].to_vec();
    two.sort();
    assert!(
        two == ["tether_drag", "thruster_lag"] && names[2..].iter().all(|n| *n == "unexplained"),
        "{names:?}: {}",
        d["verdict"]
    );
    let (il, it) = match names[0] {
        "thruster_lag" => (0, 1),
        _ => (1, 0),
    };
    // A real motor lag is told apart from a late sensor: no look-alike is listed.
    assert!(
        effects[0]["alike"].is_null() && effects[1]["alike"].is_null(),
        "{}",
        d["verdict"]
    );
    let param = |i: usize, k: &str| effects[i]["parameters"][k].as_f64().unwrap();
    // The lag of a motor whose thrust goes with its speed's square: its own time constant,
    // with the thrust law's exponent near 2 (as a force lag it came out 1.2-1.25 times long).
    let tau = hidden("thruster_lag", "time_constant_s");
    let lag = param(il, "time_constant_s");
    let exponent = param(il, "thrust_law_exponent");
    assert!(
        (0.9 * tau..1.1 * tau).contains(&lag) && exponent > 1.7,
        "lag {lag} (thrust law exponent {exponent}) vs motor {tau}"
    );
    let evidence = effects[il]["evidence"].as_str().unwrap();
    assert!(
        evidence.contains("(the thrusters' speed lags, the thrust going with its square)"),
        "{evidence}"
    );
    // Only the drag per unit |v| v at the distances the runs go compares: c (d + s) against
    // the twin's c (horizontal run + depth + slack), at 11 m from the anchor, 1.5 m deep.
    let (run, depth) = (11.0f64, 1.5f64);
    let want =
        hidden("tether_drag", "coefficient") * (run + depth + hidden("tether_drag", "slack_m"));
    let got = param(it, "coefficient") * (run.hypot(depth) + param(it, "slack_m"));
    assert!(
        (got - want).abs() < 0.25 * want,
        "tether drag at 11 m: {got} vs {want}"
    );
    let before = effects[0]["validation_cost_before"].as_f64().unwrap();
    let after = effects[1]["validation_cost_after"].as_f64().unwrap();
    assert!(after < 0.1 * before, "held-out cost {before} -> {after}");
    // The figure of the recording against both simulations gives each one's RMS error and
    // the word the two numbers call for.
    let html = read(dir, "reports/index.html");
    let caption = html
        .split("<figcaption>")
        .find(|c| c.contains("where the model misses most"))
        .expect("the recording-and-simulations figure");
    let rms: Vec<f64> = caption
        .split("RMS error ")
        .skip(1)
        .map(|s| s.split(' ').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(rms.len(), 2, "{caption}");
    assert!(rms[1] < 0.5 * rms[0], "{caption}");
    assert!(
        caption.contains(", lower)") && caption.contains(&format!("{} and {}", names[0], names[1])),
        "{caption}"
    );
}

#[test]
fn a_new_case_reruns_only_its_import_and_what_depends_on_it() {
    let p = project();
    let dir = p.path();
    ok(dir, &["build"]);
    let src = dir.join("cases/cfd/starccm/surge_40N.csv");
    let text = std::fs::read_to_string(&src).unwrap();
    std::fs::write(dir.join("cases/cfd/starccm/surge_40N_rerun.csv"), text).unwrap();
    let status = stdout(&run(dir, &["status"]));
    let lines: Vec<&str> = status.lines().collect();
    assert_eq!(lines.len(), 7, "{status}");
    assert_eq!(
        lines[0],
        "cfd[surge_40N_rerun]: new input cases/cfd/starccm/surge_40N_rerun.csv (never built)"
    );
    for want in [
        "fit: new upstream cfd[surge_40N_rerun]",
        "compare: new upstream cfd[surge_40N_rerun]",
        "validate: upstream fit changed; new upstream cfd[surge_40N_rerun]",
        "diagnose: upstream fit changed",
        "export: upstream fit changed",
    ] {
        assert!(lines.contains(&want), "{want}: {status}");
    }
    assert!(lines[6].starts_with("report: "), "{status}");
    let out = ok(dir, &["build", "--explain"]);
    assert_eq!(ran(&out), 7, "{out}");
}

#[test]
fn a_changed_setting_reruns_the_fit_but_not_the_imports() {
    let p = project();
    let dir = p.path();
    ok(dir, &["build"]);
    let spec = read(dir, "pipeline.yaml").replace(
        "objective: equation_error",
        "objective: equation_error\n      skip_start_s: 0.1",
    );
    std::fs::write(dir.join("pipeline.yaml"), spec).unwrap();
    let status = stdout(&run(dir, &["status"]));
    assert!(
        status.starts_with("fit: setting.skip_start_s changed: 0.0 -> 0.1\n"),
        "{status}"
    );
    assert_eq!(status.lines().count(), 5, "{status}");
    assert_eq!(ran(&ok(dir, &["build"])), 5);
    // A new vehicle mass reruns the fits (fit, compare, cylinder, sphere_fit: a fit's key holds
    // the vehicle section even when the fit names its own body) and what reads them (validate,
    // diagnose, export, report), not the imports or the fusion (they depend on the DOF list only).
    let spec = read(dir, "pipeline.yaml").replace("mass_kg: 35.2", "mass_kg: 35.3");
    std::fs::write(dir.join("pipeline.yaml"), spec).unwrap();
    assert_eq!(ran(&ok(dir, &["build"])), 8);
}

#[test]
fn an_edited_case_names_the_file_that_changed() {
    let p = project();
    let dir = p.path();
    ok(dir, &["build"]);
    let f = dir.join("cases/cfd/starccm/sway_10N.csv");
    let text = std::fs::read_to_string(&f).unwrap();
    std::fs::write(&f, text.replacen("\n", "\n\n", 1)).unwrap();
    let status = stdout(&run(dir, &["status"]));
    assert!(
        status.starts_with("cfd[sway_10N]: input cases/cfd/starccm/sway_10N.csv changed (blake3 "),
        "{status}"
    );
}

#[test]
fn provenance_traces_a_parameter_to_its_files() {
    let p = project();
    let dir = p.path();
    let before = run(dir, &["provenance", "X_uu"]);
    assert!(!before.status.success());
    assert!(
        stderr(&before).contains("run `hydrofit build` first"),
        "{}",
        stderr(&before)
    );
    ok(dir, &["build"]);
    let out = stdout(&run(dir, &["provenance", "X_uu"]));
    // The vehicle's X_uu (and the OpenFOAM cylinder's, under stage cylinder).
    assert!(out.lines().any(|l| l.starts_with("X_uu = -4")), "{out}");
    assert!(
        out.contains("<- stage cylinder (kind fit")
            && out.contains("cylinder_2N/constant/dynamicMeshDict blake3 "),
        "{out}"
    );
    assert!(out.contains("<- stage fit (kind fit, key "), "{out}");
    let h =
        hydrofit::core::fsutil::hash_file(&dir.join("cases/cfd/starccm/surge_100N.csv")).unwrap();
    assert!(out.contains(&"cfd[surge_100N] (key ".to_string()), "{out}");
    assert!(
        out.contains(&format!("<- cases/cfd/starccm/surge_100N.csv blake3 {h}")),
        "{out}"
    );
    assert!(
        out.starts_with("X_uu is identified by 3 models (cylinder, fit, sphere_fit)"),
        "{out}"
    );
    let one = stdout(&run(dir, &["provenance", "X_uu", "--model", "fit"]));
    assert!(
        one.starts_with("X_uu = -4") && !one.contains("stage cylinder"),
        "{one}"
    );
    let typo = run(dir, &["provenance", "X_uuu"]);
    assert!(
        stderr(&typo).contains("did you mean X_uu?"),
        "{}",
        stderr(&typo)
    );
}

#[test]
fn graph_and_clean() {
    let p = project();
    let dir = p.path();
    let text = stdout(&run(dir, &["graph"]));
    assert!(text.contains("fit (fit) <- cfd["), "{text}");
    assert!(
        text.contains("cfd[surge_2N] (starccm) <- cases/cfd/starccm/surge_2N.csv"),
        "{text}"
    );
    let dot = stdout(&run(dir, &["graph", "--dot"]));
    assert!(
        dot.starts_with("digraph hydrofit {") && dot.contains("\"fit\" -> \"report\";"),
        "{dot}"
    );
    ok(dir, &["build"]);
    ok(dir, &["clean"]);
    // The lock file stays (a waiting build holds it); nothing else does.
    let left: Vec<String> = std::fs::read_dir(dir.join(".hydrofit"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left, vec!["lock".to_string()]);
    assert!(!dir.join("reports/index.html").exists());
    assert!(stdout(&run(dir, &["status"])).contains("never built"));
}

#[test]
fn only_the_named_stage_and_its_upstream_are_built() {
    let p = project();
    let dir = p.path();
    let out = ok(dir, &["build", "cfd[surge_10N]"]);
    assert_eq!(ran(&out), 1, "{out}");
    let bad = run(dir, &["build", "fti"]);
    assert!(
        stderr(&bad).contains("did you mean `fit`?"),
        "{}",
        stderr(&bad)
    );
}
