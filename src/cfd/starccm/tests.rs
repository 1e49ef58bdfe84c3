use super::*;

const HEAD: &str = "\"Iteration\",\"Physical Time: Physical Time (s)\",\"Applied Force X Monitor: Force (N)\",\"Body Velocity X Monitor: Velocity (m/s)\",\"Body Acceleration X Monitor: Acceleration (m/s^2)\"";
const DOFS: [Dof; 4] = [Dof::Surge, Dof::Sway, Dof::Heave, Dof::Yaw];

fn run(text: &str) -> Result<Imported, InputError> {
    run_with(text, BTreeMap::new())
}

fn run_with(text: &str, configured_force: BTreeMap<Dof, f64>) -> Result<Imported, InputError> {
    let columns = ColumnMap::default();
    parse(
        "case.csv",
        text,
        &ImportOptions {
            columns: &columns,
            dofs: &DOFS,
            configured_force,
        },
    )
}

fn msg(text: &str) -> String {
    run(text).unwrap_err().to_string()
}

#[test]
fn reads_a_surge_export_and_keeps_the_last_inner_iteration() {
    let text = format!(
        "{HEAD}\n1,0.02,10,0.001,0.5\n2,0.02,10,0.004,0.19\n3,0.04,10,0.008,0.18\n4,0.06,10,0.011,0.17\n"
    );
    let r = run(&text).unwrap();
    assert_eq!(r.rows_read, 4);
    assert_eq!(r.rows_kept, 3);
    let s = &r.response.dofs[&Dof::Surge];
    assert_eq!(r.response.t, [0.02, 0.04, 0.06]);
    assert_eq!(s.velocity, [0.004, 0.008, 0.011]);
    assert_eq!(s.accel, [0.19, 0.18, 0.17]);
    assert_eq!(s.force_source, Source::Column);
}

#[test]
fn converts_degrees_and_newton_metres() {
    let text = "\"Physical Time: Physical Time (s)\",\"Applied Moment Z Monitor: Moment (N-m)\",\"Body Angular Velocity Z Monitor: Angular Velocity (deg/s)\"\n0.0,2,0\n0.1,2,18\n0.2,2,36\n";
    let r = run(text).unwrap();
    let s = &r.response.dofs[&Dof::Yaw];
    assert!((s.velocity[1] - 0.1 * std::f64::consts::PI).abs() < 1e-12);
    assert_eq!(s.accel_source, Source::Differentiated);
    assert!((s.accel[1] - std::f64::consts::PI).abs() < 1e-9);
    assert!(r.notes.iter().any(|n| n.contains("deg/s")));
}

#[test]
fn takes_a_missing_force_from_the_configuration() {
    let text = "\"Physical Time: Physical Time (s)\",\"Body Velocity Y Monitor: Velocity (m/s)\"\n0,0\n0.02,0.01\n0.04,0.02\n";
    assert!(
        run(text)
            .unwrap_err()
            .to_string()
            .contains("no applied-force column for sway")
    );
    let r = run_with(text, [(Dof::Sway, 7.5)].into()).unwrap();
    assert_eq!(r.response.dofs[&Dof::Sway].force, [7.5; 3]);
    assert_eq!(r.response.dofs[&Dof::Sway].force_source, Source::Configured);
}

#[test]
fn ignores_columns_of_dofs_the_vehicle_lacks() {
    let text = "\"Physical Time: Physical Time (s)\",\"Applied Force X Monitor: Force (N)\",\"Body Velocity X Monitor: Velocity (m/s)\",\"Body Angular Velocity X Monitor: Angular Velocity (rad/s)\"\n0,1,0,0\n0.1,1,0.1,0\n0.2,1,0.2,0\n";
    let r = run(text).unwrap();
    assert_eq!(
        r.response.dofs.keys().copied().collect::<Vec<_>>(),
        [Dof::Surge]
    );
    assert!(
        r.notes
            .iter()
            .any(|n| n.contains("roll is not one of the vehicle's DOFs"))
    );
}

#[test]
fn empty_file() {
    assert!(msg("").starts_with("case.csv: the file is empty"));
    assert!(msg("\n \n").contains("empty"));
}

#[test]
fn header_only() {
    let m = msg(&format!("{HEAD}\n"));
    assert!(m.starts_with("case.csv:1: 0 data rows"), "{m}");
}

#[test]
fn wrong_delimiter() {
    let m = msg(
        "\"Physical Time: Physical Time (s)\";\"Body Velocity X Monitor: Velocity (m/s)\"\n0;0\n",
    );
    assert!(
        m.starts_with("case.csv:1: the header is separated by ';', not commas"),
        "{m}"
    );
    assert!(m.contains("help: STAR-CCM+ exports are comma-separated"));
}

#[test]
fn missing_velocity_column_lists_what_was_found() {
    let m = msg("\"Physical Time: Physical Time (s)\",\"Thrust: Force (N)\"\n0,1\n");
    assert!(m.contains("no velocity column"), "{m}");
    assert!(m.contains("\"Thrust: Force (N)\""), "{m}");
    assert!(m.contains("settings.columns.velocity"), "{m}");
}

#[test]
fn missing_time_column() {
    let m = msg("\"Body Velocity X Monitor: Velocity (m/s)\"\n0\n");
    assert!(m.contains("no time column"), "{m}");
}

#[test]
fn unparsable_number_names_line_and_column() {
    let text = format!("{HEAD}\n1,0.02,10,0.001,0.5\n2,0.04,10,0.0o4,0.19\n3,0.06,10,0.01,0.18\n");
    let m = msg(&text);
    assert!(m.starts_with("case.csv:3:11: cannot read \"0.0o4\" in column \"Body Velocity X Monitor: Velocity (m/s)\""), "{m}");
    assert!(m.contains("\n    |           ^\n"), "{m}");
}

#[test]
fn nan_and_inf_are_errors() {
    for bad in ["NaN", "inf", "-inf"] {
        let text = format!("{HEAD}\n1,0.02,10,0.001,0.5\n2,0.04,10,{bad},0.19\n");
        let m = msg(&text);
        assert!(m.starts_with("case.csv:3:11:"), "{m}");
        assert!(m.contains("diverged"), "{m}");
    }
}

#[test]
fn time_going_backwards() {
    let text = format!("{HEAD}\n1,0.02,10,0.001,0.5\n2,0.04,10,0.002,0.5\n3,0.03,10,0.003,0.5\n");
    let m = msg(&text);
    assert!(
        m.starts_with("case.csv:4:3: time goes backwards: 0.03 s after 0.04 s"),
        "{m}"
    );
}

#[test]
fn short_row() {
    let text = format!("{HEAD}\n1,0.02,10,0.001,0.5\n2,0.04,10\n");
    assert!(msg(&text).starts_with("case.csv:3: expected 5 fields like the header, found 3"));
}

#[test]
fn wrong_unit() {
    let m = msg(
        "\"Physical Time: Physical Time (s)\",\"Applied Force X Monitor: Force (N)\",\"Body Velocity X Monitor: Velocity (km/h)\"\n0,1,0\n",
    );
    assert!(m.contains("its unit is (km/h), expected (m/s)"), "{m}");
    assert!(m.starts_with("case.csv:1:73:"), "{m}");
}

#[test]
fn custom_monitor_names() {
    let columns = ColumnMap {
        velocity: [(Dof::Surge, "Vx".to_string())].into(),
        force: [(Dof::Surge, "Thrust".to_string())].into(),
        ..Default::default()
    };
    let text = "\"Physical Time: Physical Time (s)\",\"Thrust: Force (N)\",\"Vx: Velocity (m/s)\"\n0,1,0\n0.1,1,0.1\n0.2,1,0.2\n";
    let opts = ImportOptions {
        columns: &columns,
        dofs: &DOFS,
        configured_force: BTreeMap::new(),
    };
    let r = parse("c.csv", text, &opts).unwrap();
    assert_eq!(r.response.dofs[&Dof::Surge].force, [1.0; 3]);
}
