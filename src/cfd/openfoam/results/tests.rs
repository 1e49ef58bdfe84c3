//! On output captured from real pimpleFoam v1912 runs of the shipped cylinder case
//! (tests/data/openfoam; the middle of the long logs is cut out, marked in the file).

use super::*;

fn data(name: &str) -> String {
    std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/openfoam")
            .join(name),
    )
    .unwrap()
}

#[test]
fn a_finished_log_gives_every_step_and_its_cpu_time() {
    let log = parse_log(&data("finished.log"));
    assert_eq!(log.end, LogEnd::Finished);
    assert_eq!(log.steps.len(), 7);
    assert_eq!(log.steps[0].t, 0.02);
    let last = log.steps.last().unwrap();
    assert_eq!(last.t, 4.0);
    assert!(
        (last.linear_velocity.unwrap()[0] - 0.0826188).abs() < 1e-7,
        "{last:?}"
    );
    assert_eq!(last.angular_velocity, Some([0.0, 0.0, 0.0]));
    assert!(log.execution_time_s.unwrap() > 1.0 && log.clock_time_s.is_some());
}

#[test]
fn a_killed_solver_leaves_a_truncated_log_without_its_half_step() {
    let log = parse_log(&data("truncated.log"));
    assert_eq!(log.end, LogEnd::Truncated);
    // `Time = 0.12` started but its motion was never reported: dropped.
    assert_eq!(log.steps.last().unwrap().t, 0.1);
    assert!(log.steps.iter().all(|s| s.linear_velocity.is_some()));
}

#[test]
fn a_diverged_run_is_a_crash_with_the_reason() {
    let log = parse_log(&data("diverged.log"));
    match &log.end {
        LogEnd::Crashed(why) => assert!(why.contains("sigFpe::sigHandler"), "{why}"),
        e => panic!("{e:?}"),
    }
    assert!(
        log.steps
            .iter()
            .any(|s| s.linear_velocity.unwrap()[0].abs() > 1e100)
    );
    assert!(tail(&data("diverged.log"), 5).contains("pimpleFoam"));
}

#[test]
fn the_state_table_reads_by_column_name() {
    let t = parse_vector_table(&data("state.dat")).unwrap();
    assert_eq!(t.angle_units.as_deref(), Some("radians"));
    assert_eq!(
        t.columns,
        [
            "centreOfRotation",
            "centreOfMass",
            "rotation",
            "velocity",
            "omega"
        ]
    );
    assert_eq!(t.t.len(), 9);
    assert_eq!(t.t[0], 0.02);
    assert!((t.column("velocity").unwrap()[1][0] - 9.236938e-4).abs() < 1e-12);
    let torn = parse_vector_table(&data("state_torn.dat")).unwrap();
    assert_eq!(torn.t.len(), 9, "the torn last line is dropped");
}

#[test]
fn the_force_table_has_total_pressure_and_viscous() {
    let t = parse_vector_table(&data("force.dat")).unwrap();
    assert_eq!(t.columns.len(), 3, "{:?}", t.columns);
    let total = t.column(&t.columns[0]).unwrap();
    assert!((total[0][0] + 0.2453088).abs() < 1e-9);
}

#[test]
fn a_corrupt_row_in_the_middle_is_an_error_with_its_line() {
    let mut text = data("state.dat");
    text = text.replacen("(3.183091e-06", "(3.18x", 1);
    let e = parse_vector_table(&text).unwrap_err();
    assert_eq!(e.line, 4);
}

#[test]
fn restarted_runs_keep_the_last_row_of_each_time() {
    let text = "# Time\tvelocity\n0.1\t(1 0 0)\n0.2\t(2 0 0)\n0.15\t(9 0 0)\n0.2\t(3 0 0)\n";
    let t = parse_vector_table(text).unwrap();
    assert_eq!(t.t, vec![0.1, 0.15, 0.2]);
    assert_eq!(t.rows[2][0], [3.0, 0.0, 0.0]);
}

#[test]
fn a_time_overwritten_by_zero_or_a_nan_is_an_error_not_a_restart() {
    let text =
        "# Time\tvelocity\n0.1\t(1 0 0)\n0.2\t(2 0 0)\n0\t(2.5 0 0)\n0.4\t(3 0 0)\n0.5\t(3 0 0)\n";
    let e = parse_vector_table(text).unwrap_err();
    assert_eq!(e.line, 4, "{e}");
    assert!(e.msg.contains("out of order"), "{e}");
    let text = "# Time\tvelocity\n0.1\t(1 0 0)\n0.2\t(nan 0 0)\n0.3\t(3 0 0)\n";
    let e = parse_vector_table(text).unwrap_err();
    assert_eq!(e.line, 3, "{e}");
    assert!(e.msg.contains("not a finite number"), "{e}");
}
