use super::*;

fn folder(files: &[(&str, &str)]) -> (tempfile::TempDir, Vec<String>) {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(d.path().join("cases/pool/r1")).unwrap();
    let mut list = Vec::new();
    for (n, text) in files {
        std::fs::write(d.path().join("cases/pool/r1").join(n), text).unwrap();
        list.push(format!("cases/pool/r1/{n}"));
    }
    (d, list)
}

fn thrust() -> String {
    let mut s = String::from("t,X_N,Y_N,Z_N,N_Nm\n");
    for k in 0..20 {
        s += &format!("{},{},0,0,0\n", k as f64 * 0.05, k);
    }
    s
}

#[test]
fn optional_sensors_may_be_missing_and_units_are_converted() {
    let t = thrust();
    let (d, files) = folder(&[
        ("run.yaml", "role: validate\n"),
        ("thrust.csv", &t),
        (
            "imu.csv",
            "t,roll_deg,pitch_deg,yaw_deg,p_dps,q_dps,r_dps,ax_g,ay_g,az_g\n0,0,0,90,0,0,180,0,0,-1\n0.02,0,0,90,0,0,180,0,0,-1\n",
        ),
        ("notes.txt", "x"),
    ]);
    let run = load(d.path(), "cases/pool/r1", &files, None).unwrap();
    assert_eq!(run.meta.role, Role::Validate);
    assert!(run.uwb.is_none() && run.sonar.is_none() && run.depth.is_none() && run.nav.is_none());
    let imu = run.imu.unwrap();
    assert!((imu.cols[2][0] - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    assert!((imu.cols[5][0] - std::f64::consts::PI).abs() < 1e-12);
    assert!((imu.cols[8][0] + G).abs() < 1e-12);
    assert!(run.notes.iter().any(|n| n.contains("notes.txt")));
}

#[test]
fn a_missing_thrust_log_or_bad_run_yaml_is_an_error() {
    let (d, files) = folder(&[("run.yaml", "role: train\n")]);
    let e = load(d.path(), "cases/pool/r1", &files, None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no command log") && e.contains("actuators.csv"),
        "{e}"
    );
    let t = thrust();
    let (d, files) = folder(&[("run.yaml", "role: tran\n"), ("thrust.csv", &t)]);
    let e = load(d.path(), "cases/pool/r1", &files, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("run.yaml:1:") && e.contains("tran"), "{e}");
    let (d, files) = folder(&[("thrust.csv", &t)]);
    let e = load(d.path(), "cases/pool/r1", &files, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no run.yaml"), "{e}");
}

#[test]
fn a_bad_run_yaml_or_a_folder_for_a_file_is_located() {
    let t = thrust();
    let cases = [
        (
            "role: train\npool: {length_m: .nan, width_m: 2, depth_m: 1}\n",
            "run.yaml:2:",
        ),
        (
            "role: train\npool:\n  length_m: 10\n  width_m: -2\n  depth_m: 1\n",
            "run.yaml:4:",
        ),
        (
            "role: train\nrole: validate\n",
            "run.yaml:2:1: duplicate entry",
        ),
        (
            "role: train\ntether_anchor_m: [0, .inf, 0]\n",
            "run.yaml:2:",
        ),
    ];
    for (yaml, want) in cases {
        let (d, files) = folder(&[("run.yaml", yaml), ("thrust.csv", &t)]);
        let e = load(d.path(), "cases/pool/r1", &files, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains(want) && e.contains("help:"), "{yaml:?}: {e}");
    }
    let (d, files) = folder(&[("run.yaml", "\u{feff}role: train\n"), ("thrust.csv", &t)]);
    std::fs::create_dir_all(d.path().join("cases/pool/r1/imu.csv")).unwrap();
    let e = load(d.path(), "cases/pool/r1", &files, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("imu.csv: is a folder"), "{e}");
    std::fs::remove_dir(d.path().join("cases/pool/r1/imu.csv")).unwrap();
    assert!(
        load(d.path(), "cases/pool/r1", &files, None).is_ok(),
        "BOM in run.yaml"
    );
}

/// A navigation log as a DVL writes it when it loses bottom lock: empty or `nan` values in
/// some rows, no rate columns. The gaps are NaN in their own channel only, the rest of the
/// row is kept, and both the gaps and the missing columns are said.
#[test]
fn a_navigation_log_with_gaps_and_no_rates_is_read() {
    let t = thrust();
    let nav = "t,u_m_s,v_m_s,w_m_s,yaw_deg\n0.0,0.10,0.00,0.01,90\n0.2,,nan,0.02,91\n0.4,0.12,NaN,0.02,92\n0.6,0.13,0.01,0.03,93\n";
    let (d, files) = folder(&[
        ("run.yaml", "role: train\n"),
        ("thrust.csv", &t),
        ("nav.csv", nav),
    ]);
    let run = load(d.path(), "cases/pool/r1", &files, None).unwrap();
    let nav = run.nav.unwrap();
    assert_eq!(nav.len(), 4);
    assert!(nav.cols[0][1].is_nan() && nav.cols[1][1].is_nan() && nav.cols[1][2].is_nan());
    assert_eq!(nav.cols[2][1], 0.02);
    assert!((nav.cols[5][3] - 93f64.to_radians()).abs() < 1e-12);
    assert!(!nav.has(6) && !nav.has(8), "no rates in this log");
    let notes = run.notes.join("\n");
    assert!(notes.contains("3 values missing"), "{notes}");
    assert!(
        notes.contains("no roll_deg, pitch_deg, p_dps, q_dps, r_dps columns"),
        "{notes}"
    );
    // Time itself may not be missing.
    let bad = "t,u_m_s\n0.0,0.1\n,0.2\n";
    let (d, files) = folder(&[
        ("run.yaml", "role: train\n"),
        ("thrust.csv", &t),
        ("nav.csv", bad),
    ]);
    assert!(load(d.path(), "cases/pool/r1", &files, None).is_err());
}

/// A simulator's tables: each of two thrusters' thrust (N) on its own topic, at its own times,
/// and a navigation table, read as a log with the command spread over `{0..2}`; the wrench at
/// each command sample holds the other thruster's latest thrust.
#[test]
fn a_command_spread_over_one_topic_per_thruster_is_merged() {
    use crate::core::model::thrusters::{Command, Thrusters};
    let d = tempfile::tempdir().unwrap();
    let logs = d.path().join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    let table = |name: &str, header: &str, rows: &dyn Fn(usize) -> String| {
        let text: String = (0..40).map(|k| rows(k) + "\n").collect();
        std::fs::write(logs.join(name), format!("{header}\n{text}")).unwrap();
    };
    // Thruster 0 at 20 Hz from 10.0 s, thruster 1 at 10 Hz from 10.02 s.
    table("thrust_0.csv", "time,data", &|k| {
        format!("{:.3},{}", 10.0 + 0.05 * k as f64, k)
    });
    table("thrust_1.csv", "time,data", &|k| {
        format!("{:.3},-2.5", 10.02 + 0.1 * k as f64)
    });
    table("nav.csv", "time,u,v,w", &|k| {
        format!("{:.3},0.1,0,0", 10.0 + 0.1 * k as f64)
    });
    let yaml = "role: train\nlog:\n  file: ../../../logs\n  command: {topic: 'thrust_{0..2}', fields: [data]}\n  velocity: {topic: nav, fields: [u, v, w]}\n";
    let files = vec!["cases/pool/r1/run.yaml".to_string()];
    std::fs::create_dir_all(d.path().join("cases/pool/r1")).unwrap();
    std::fs::write(d.path().join("cases/pool/r1/run.yaml"), yaml).unwrap();
    let thrusters: Thrusters = serde_yaml_ng::from_str(
        "command: newtons\nunits:\n  - {position_m: [0, 0.1, 0], direction: [1, 0, 0]}\n  - {position_m: [0, -0.1, 0], direction: [1, 0, 0]}\n",
    )
    .unwrap();
    assert_eq!(thrusters.command, Command::Newtons);
    let run = load(d.path(), "cases/pool/r1", &files, Some(&thrusters)).unwrap();
    let x = &run.thrust.cols[0];
    // From 10.02 s (both have spoken): thruster 0's k-th thrust plus -2.5 of thruster 1.
    assert!(
        (run.thrust.t[0] - 0.02).abs() < 1e-9,
        "{:?}",
        &run.thrust.t[..3]
    );
    assert!((x[0] - (0.0 - 2.5)).abs() < 1e-9, "{:?}", &x[..4]);
    let k = run
        .thrust
        .t
        .iter()
        .position(|t| (t - 0.5).abs() < 1e-9)
        .unwrap();
    assert!((x[k] - (10.0 - 2.5)).abs() < 1e-9, "at 0.5 s: {}", x[k]);
    // The moment of the two, 0.1 m either side: N = -0.1 X0 + 0.1 X1 (x forward, y starboard).
    let n = &run.thrust.cols[3];
    assert!(
        (n[k] - (-0.1 * 10.0 + 0.1 * -2.5)).abs() < 1e-9,
        "N at 0.5 s: {}",
        n[k]
    );
}

/// A table timed in whole milliseconds a second apart reads as microseconds unless run.yaml
/// says `time_unit: ms`.
#[test]
fn run_yaml_says_the_unit_of_a_tables_time() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(d.path().join("cases/pool/r1")).unwrap();
    let rows: String = (0..30)
        .map(|k| format!("{},{},0,0,0\n", 5000 + 1000 * k, k))
        .collect();
    std::fs::write(d.path().join("wrench.csv"), format!("time,X,Y,Z,N\n{rows}")).unwrap();
    let step = |unit: &str| {
        let yaml = format!(
            "role: train\nlog:\n  file: ../../../wrench.csv\n  {unit}\n  wrench: {{topic: wrench, fields: [X, Y, Z, N]}}\n"
        );
        std::fs::write(d.path().join("cases/pool/r1/run.yaml"), yaml).unwrap();
        let files = vec!["cases/pool/r1/run.yaml".to_string()];
        let run = load(d.path(), "cases/pool/r1", &files, None).unwrap();
        run.thrust.t[1] - run.thrust.t[0]
    };
    assert!((step("time_unit: ms") - 1.0).abs() < 1e-9);
    assert!(
        (step("time: auto") - 1e-3).abs() < 1e-12,
        "read from its values: us"
    );
}

/// A motion-capture position in ENU (`frame: enu`) becomes the pool frame's x north, y east,
/// z down; without a frame it is read as the pool frame; a body frame is refused.
#[test]
fn a_position_in_enu_is_turned_into_the_pool_frame() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(d.path().join("cases/pool/r1")).unwrap();
    let rows: String = (0..30)
        .map(|k| format!("{},{},0,0,0\n", 0.05 * k as f64, k))
        .collect();
    std::fs::write(d.path().join("wrench.csv"), format!("t,X,Y,Z,N\n{rows}")).unwrap();
    let rows: String = (0..30)
        .map(|k| {
            format!(
                "{},{},{},{}\n",
                0.05 * k as f64,
                1.0 + 0.01 * k as f64,
                2.0,
                -0.5
            )
        })
        .collect();
    std::fs::write(d.path().join("mocap.csv"), format!("t,x,y,z\n{rows}")).unwrap();
    let read = |frame: &str| {
        let yaml = format!(
            "role: train\nlog:\n  file: ../../..\n  wrench: {{topic: wrench, fields: [X, Y, Z, N]}}\n  \
             position: {{topic: mocap, fields: [x, y, z]{frame}}}\n"
        );
        std::fs::write(d.path().join("cases/pool/r1/run.yaml"), yaml).unwrap();
        let files = vec!["cases/pool/r1/run.yaml".to_string()];
        load(d.path(), "cases/pool/r1", &files, None)
    };
    let enu = read(", frame: enu").unwrap().uwb.unwrap();
    let k = 10;
    assert_eq!(
        [enu.cols[0][k], enu.cols[1][k], enu.cols[2][k]],
        [2.0, 1.1, 0.5]
    );
    let pool = read("").unwrap().uwb.unwrap();
    assert_eq!(
        [pool.cols[0][k], pool.cols[1][k], pool.cols[2][k]],
        [1.1, 2.0, -0.5]
    );
    let e = read(", frame: flu").unwrap_err().to_string();
    assert!(e.contains("world frame") && e.contains("frame: enu"), "{e}");
}

/// A command log whose clock jumps by a day after 1 s (a computer that set its clock
/// mid-log), with the navigation log's clock jumping with it: the run is cut to the longer
/// stretch after the jump, the navigation rows before it are left out with it, and both cuts
/// are said.
#[test]
fn a_clock_set_mid_log_cuts_the_run_to_its_longest_stretch() {
    let day = 86_400.0;
    let at = |k: usize| match k < 20 {
        true => k as f64 * 0.05,
        false => day + k as f64 * 0.05,
    };
    let mut t = String::from("t,X_N,Y_N,Z_N,N_Nm\n");
    let mut nav = String::from("t,u_m_s,v_m_s,w_m_s,yaw_deg\n");
    for k in 0..60 {
        t += &format!("{},{},0,0,0\n", at(k), k);
        nav += &format!("{},0.1,0,0,90\n", at(k));
    }
    let (d, files) = folder(&[
        ("run.yaml", "role: train\n"),
        ("thrust.csv", &t),
        ("nav.csv", &nav),
    ]);
    let run = load(d.path(), "cases/pool/r1", &files, None).unwrap();
    assert_eq!(run.thrust.len(), 40);
    assert_eq!(run.thrust.t[0], day + 1.0);
    assert!(run.nav.as_ref().unwrap().t.iter().all(|&x| x >= day));
    let said = run.repairs.join("\n");
    assert!(
        said.contains("the command log stops for 86400.1 s at 0.95 s"),
        "{said}"
    );
    assert!(
        said.contains("the nav rows more than 2 s outside"),
        "{said}"
    );
}

/// A command log at neutral for most of the run (a dive log that starts disarmed) is said with
/// its share; one driven throughout says nothing; one at neutral throughout says so.
#[test]
fn a_run_mostly_at_neutral_is_said() {
    let log = |x: &dyn Fn(usize) -> f64| csvlog::Log {
        t: (0..100).map(|k| k as f64 * 0.1).collect(),
        cols: vec![(0..100).map(x).collect(), vec![0.0; 100]],
        notes: vec![],
        present: vec![true, true],
    };
    let idle = idle_note(&log(&|k| if k >= 70 { 5.0 } else { 0.0 })).unwrap();
    assert!(idle.contains("for 71 % of the run (7.0 of 9.9 s"), "{idle}");
    assert_eq!(idle_note(&log(&|k| 1.0 + k as f64)), None);
    assert_eq!(idle_note(&log(&|k| if k >= 40 { 5.0 } else { 0.0 })), None);
    let never = idle_note(&log(&|_| 0.0)).unwrap();
    assert!(never.contains("anywhere in the run"), "{never}");
}
