use super::*;

const OK: &str = "vehicle:\n  mass_kg: 35.2\n  inertia_kg_m2: {zz: 1.38}\n  dofs: [surge, yaw]\nstages:\n  cfd:\n    kind: starccm\n    inputs: [\"cases/*.csv\"]\n  fit:\n    kind: fit\n    from: [cfd]\n    settings:\n      method: ols\n  validate:\n    kind: validate\n    from: [fit, cfd]\n  report:\n    kind: report\n    from: [fit, cfd, validate]\n";

fn err(text: &str) -> String {
    match parse("pipeline.yaml", text, crate::kinds::KINDS) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn parses_and_orders_stages() {
    let s = parse("pipeline.yaml", OK, crate::kinds::KINDS).unwrap();
    let names: Vec<&str> = s.stages.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["cfd", "fit", "validate", "report"]);
    assert_eq!(s.vehicle.mass_kg, 35.2);
}

/// The report shows the validate stage's scores of the models on the CFD cases: a report that
/// reads models and CFD responses names the stage to add, or the stages its validate lacks.
#[test]
fn a_report_of_models_on_cfd_cases_reads_a_validate_stage_that_scored_them_all() {
    let without = OK.replace("from: [fit, cfd, validate]", "from: [fit, cfd]");
    let e = err(&without);
    assert!(
        e.contains("stage `report` shows models (fit) on CFD cases (cfd) but reads no stage that scores them"),
        "{e}"
    );
    assert!(
        e.contains("add `validate: {kind: validate, from: [fit, cfd]}`"),
        "{e}"
    );
    let partial = OK.replace("from: [fit, cfd]\n  report", "from: [fit]\n  report");
    let e = err(&partial);
    assert!(
        e.contains("but `validate`, which scores the models on them, does not read cfd")
            && e.contains("add cfd to `validate`'s `from`"),
        "{e}"
    );
    // Models alone, or CFD cases alone, need no scores.
    parse(
        "pipeline.yaml",
        &OK.replace("from: [fit, cfd, validate]", "from: [fit]"),
        crate::kinds::KINDS,
    )
    .unwrap();
}

#[test]
fn unknown_top_level_key_suggests_the_nearest() {
    let e = err(&OK.replace("stages:", "stagess:"));
    assert!(
        e.starts_with("pipeline.yaml:5:1: unknown field `stagess`"),
        "{e}"
    );
    assert!(e.contains("did you mean `stages`?"), "{e}");
}

#[test]
fn unknown_setting_is_located_and_suggested() {
    let e = err(&OK.replace("method: ols", "methd: ols"));
    assert!(
        e.starts_with("pipeline.yaml:13:7: unknown field `methd`"),
        "{e}"
    );
    assert!(e.contains("did you mean `method`?"), "{e}");
}

#[test]
fn unknown_method_lists_the_registry() {
    let e = err(&OK.replace("method: ols", "method: olss"));
    assert!(e.contains("unknown variant `olss`"), "{e}");
    assert!(e.contains("did you mean `ols`?"), "{e}");
    assert!(e.starts_with("pipeline.yaml:13:15:"), "{e}");
}

#[test]
fn unknown_kind() {
    let e = err(&OK.replace("kind: starccm", "kind: starcm"));
    assert!(
        e.starts_with("pipeline.yaml:7:5: stage `cfd`: unknown kind `starcm`"),
        "{e}"
    );
    assert!(e.contains("did you mean `starccm`?"), "{e}");
}

#[test]
fn unknown_upstream() {
    let e = err(&OK.replace("from: [cfd]", "from: [cdf]"));
    assert!(
        e.starts_with("pipeline.yaml:11:5: stage `fit` reads from `cdf`, which is not a stage"),
        "{e}"
    );
    assert!(e.contains("did you mean `cfd`?"), "{e}");
}

#[test]
fn cycles_are_spelled_out() {
    // Today's kinds cannot form a cycle without a type error, so order raw stages directly.
    let text = "stages:\n  a:\n    from: [b]\n  b:\n    from: [c]\n  c:\n    from: [a]\n";
    let p = Parser {
        path: "pipeline.yaml",
        kinds: crate::kinds::KINDS,
        text,
        index: KeyIndex::new(text),
    };
    let kind = crate::kinds::kind("report").unwrap();
    let mk = |name: &str, from: &str| StageSpec {
        name: name.into(),
        kind,
        imp: (kind.parse)(serde_yaml_ng::Value::Null)
            .unwrap_or_else(|_| (kind.parse)(serde_yaml_ng::from_str("{}").unwrap()).unwrap()),
        inputs: vec![],
        from: vec![from.into()],
    };
    let stages = vec![mk("a", "b"), mk("b", "c"), mk("c", "a")];
    let e = match topo_order(&p, &stages) {
        Ok(_) => panic!("cycle not found"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.starts_with("pipeline.yaml:3:5: the stages form a cycle: a -> b -> c -> a"),
        "{e}"
    );
}

#[test]
fn a_stage_without_its_required_input_is_rejected() {
    let e = err(&OK.replace("    from: [fit, cfd, validate]\n", ""));
    assert!(
        e.contains("stage `report` (report) needs a stage that produces an identified model"),
        "{e}"
    );
}

#[test]
fn vehicle_problems_are_reported() {
    let e = err(&OK.replace("dofs: [surge, yaw]", "dofs: [surge, yaw, roll]"));
    assert!(
        e.starts_with("pipeline.yaml:1:1: vehicle: roll is a DOF but inertia_kg_m2.xx is not set"),
        "{e}"
    );
}

#[test]
fn bad_dof_name() {
    let e = err(&OK.replace("dofs: [surge, yaw]", "dofs: [surge, yaww]"));
    assert!(e.contains("unknown variant `yaww`"), "{e}");
    assert!(e.contains("did you mean `yaw`?"), "{e}");
    assert!(e.starts_with("pipeline.yaml:4:"), "{e}");
}

#[test]
fn inputs_outside_the_project() {
    let e = err(&OK.replace("cases/*.csv", "../other/*.csv"));
    assert!(e.contains("is outside the project"), "{e}");
}

#[test]
fn each_method_reads_only_its_own_settings() {
    let e = err(&OK.replace("method: ols", "method: ols\n      population: 60"));
    assert!(e.contains("unknown field `population`"), "{e}");
    assert!(e.contains("method ols reads no settings of its own"), "{e}");
    let e = err(&OK.replace("method: ols", "method: qpso\n      populaton: 60"));
    assert!(e.contains("did you mean `population`?"), "{e}");
    let e = err(&OK.replace("method: ols", "method: qpso\n      skip_start: 0.2"));
    assert!(e.contains("did you mean `skip_start_s`?"), "{e}");
    for key in [
        "thrust_gain",
        "median_filter",
        "added_mass_window_s",
        "population",
    ] {
        assert!(e.contains(&format!("`{key}`")), "{key} listed: {e}");
    }
    let e = err(&OK.replace("method: ols", "method: rls\n      forgetting: 1.5"));
    assert!(e.contains("outside (0, 1]"), "{e}");
    let s = parse(
        "pipeline.yaml",
        &OK.replace("method: ols", "method: qpso\n      population: 60"),
        crate::kinds::KINDS,
    )
    .unwrap();
    let fit = s.stages.iter().find(|st| st.name == "fit").unwrap();
    let settings = fit.imp.settings();
    assert_eq!(settings["population"], 60);
    assert_eq!(
        settings["iterations"], 2000,
        "defaults filled in: {settings}"
    );
    assert!(settings.get("forgetting").is_none(), "{settings}");
}
