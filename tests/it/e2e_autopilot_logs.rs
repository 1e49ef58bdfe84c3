//! Real autopilot logs read with no mapping: ArduSub's (`crates/logs/tests/data/ardusub/`, a
//! BlueROV2's test logs from clydemcqueen/ardusub_log_tools, MIT) and PX4's
//! (`crates/logs/tests/data/px4/`, pyulog's test logs, BSD); the autopilot's velocity
//! estimate kept only where its filter says a sensor aided it.

use crate::common::ok;
use crate::e2e_logs::{heavy, load};
use hydrofit::core::model::thrusters::{Layout, Thrusters};
use std::path::{Path, PathBuf};

fn data(file: &str) -> PathBuf {
    let dir = match file.ends_with(".ulg") {
        true => "px4",
        false => "ardusub",
    };
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("crates/logs/tests/data")
        .join(dir)
        .join(file)
}

/// The six-thruster BlueROV2 the logs are of.
fn bluerov2() -> Thrusters {
    let mut t = heavy();
    t.layout = Some(Layout::Bluerov2);
    t.gain = 1.0;
    t
}

/// A run folder `dir` under `root` whose run.yaml reads `log` (and `more` lines of `log:`).
fn run_folder(root: &Path, dir: &str, log: &Path, more: &str) {
    std::fs::create_dir_all(root.join(dir)).unwrap();
    std::fs::write(
        root.join(dir).join("run.yaml"),
        format!("role: train\nlog:\n  file: {}\n{more}", log.display()),
    )
    .unwrap();
}

#[test]
fn a_real_ardusub_log_is_read_without_a_mapping() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    let bin = data("small.BIN");
    let out = ok(root, &["inspect", bin.to_str().unwrap()]);
    assert!(
        out.contains("ArduPilot DataFlash log") && out.contains("RCOU"),
        "{out}"
    );
    // What a run folder would read with nothing mapped, the unaided velocity said.
    let unmapped = out
        .split("with nothing mapped")
        .nth(1)
        .expect("the defaults");
    assert!(
        unmapped.contains("(stack: ardusub;")
            && unmapped.contains("velocity      XKF1[0]")
            && unmapped.contains("no velocity")
            && unmapped.contains("for all 237 samples"),
        "{unmapped}"
    );
    run_folder(root, "cases/pool/dive", &bin, "");
    let t = bluerov2();
    let run = load(root, "cases/pool/dive", Some(&t));
    let notes = run.notes.join("\n");
    for signal in [
        "command from `RCOU`",
        "attitude from `ATT`",
        "rates from `IMU[0]`",
        "depth from `BARO[1]`",
    ] {
        assert!(notes.contains(signal), "{signal} in {notes}");
    }
    // A bench test in air at neutral PWM: no thrust, level within a degree, at the surface.
    assert!(run.thrust.cols[0].iter().all(|x| x.abs() < 1e-9));
    let imu = run.imu.as_ref().expect("attitude and rates");
    assert!(
        imu.cols[0]
            .iter()
            .filter(|r| !r.is_nan())
            .all(|r| r.abs() < 1f64.to_radians())
    );
    let depth = run.depth.as_ref().expect("depth");
    assert!(
        depth.cols[0].iter().all(|z| z.abs() < 0.05),
        "{:?}",
        &depth.cols[0][..5]
    );
}

/// The same six-thruster log read as an eight-thruster BlueROV2 Heavy: ArduSub logs the two
/// outputs it does not drive as 0 us, which the curve would read as full reverse on both
/// corner thrusters (80 N down); they are no thrust, and the notes name them.
#[test]
fn an_output_with_no_pulse_is_no_thrust_and_said() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    run_folder(root, "dive", &data("small.BIN"), "");
    let mut t = heavy();
    t.gain = 1.0;
    let run = load(root, "dive", Some(&t));
    for (j, c) in run.thrust.cols.iter().enumerate() {
        assert!(
            c.iter().all(|x| x.abs() < 1e-9),
            "column {j}: {:?}",
            &c[..3]
        );
    }
    let notes = run.notes.join("\n");
    assert!(
        notes.contains("thrusters 7, 8 on `RCOU` get no pulse (PWM 0) in the whole run")
            && notes.contains("`layout: bluerov2` for six"),
        "{notes}"
    );
    assert!(!notes.contains("thruster 1 "), "{notes}");
}

/// In air on a bench, the EKF has nothing to aid its horizontal velocity: `XKF4`'s status
/// is in constant-position mode throughout (65703), so the velocity of `XKF1`, the stack's
/// default or named in run.yaml, is not a measurement and the run has none.
#[test]
fn an_unaided_ekf_velocity_is_not_taken_for_a_measurement() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    let named = "  velocity: {topic: \"XKF1[0]\", fields: [VN, VE, VD], frame: ned}\n";
    for (dir, velocity) in [("default", ""), ("named", named)] {
        run_folder(root, dir, &data("small.BIN"), velocity);
        let run = load(root, dir, Some(&bluerov2()));
        assert!(run.nav.is_none(), "{dir}: an unaided velocity was kept");
        let notes = run.notes.join("\n");
        assert!(
            notes.contains("no velocity") && notes.contains("`XKF4[0]`"),
            "{dir}: {notes}"
        );
    }
}

/// The telemetry log's dive had its horizontal velocity aided throughout
/// (`EKF_STATUS_REPORT.flags` 831): the default `LOCAL_POSITION_NED` velocity is read whole.
#[test]
fn an_aided_ekf_velocity_is_read_whole() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    let out = ok(root, &["inspect", data("small.tlog").to_str().unwrap()]);
    assert!(
        out.contains("(stack: ardusub_tlog;")
            && out.contains("says all 792 velocity samples were aided"),
        "{out}"
    );
    run_folder(root, "cases/pool/dive", &data("small.tlog"), "");
    let run = load(root, "cases/pool/dive", Some(&bluerov2()));
    let notes = run.notes.join("\n");
    assert!(
        notes.contains("velocity from `LOCAL_POSITION_NED` (792 samples"),
        "{notes}"
    );
    assert!(!notes.contains("left out") && !notes.contains("no velocity"));
    let nav = run.nav.as_ref().expect("a navigation log");
    assert_eq!(nav.len(), 792);
    let source = run.log_source.as_ref().expect("a log source");
    assert_eq!(source.topics["ekf_status"], "EKF_STATUS_REPORT");
}

/// A PX4 ULog (an aerial vehicle's, on the ground before its position was known) through the
/// `px4` stack: every signal found with no mapping, the quaternion (w, x, y, z, NED) read as
/// pyulog gives it, and the EKF's velocity refused because `v_xy_valid` is never set.
#[test]
fn a_px4_ulog_is_read_without_a_mapping() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    let out = ok(
        root,
        &["inspect", data("sample_log_small.ulg").to_str().unwrap()],
    );
    assert!(
        out.contains("format:    PX4 ULog")
            && out.contains("(stack: px4;")
            && out.contains("actuator_outputs[1]"),
        "{out}"
    );
    run_folder(root, "log", &data("sample_log_small.ulg"), "");
    let run = load(root, "log", Some(&bluerov2()));
    let notes = run.notes.join("\n");
    for signal in [
        "command from `actuator_outputs` (65 samples",
        "attitude from `vehicle_attitude` (1298 samples",
        "rates from `vehicle_angular_velocity` (1812 samples",
        "acceleration from `sensor_combined` (1298 samples",
        "depth from `vehicle_local_position` (636 samples",
    ] {
        assert!(notes.contains(signal), "{signal} in {notes}");
    }
    assert!(
        notes.contains("no velocity") && notes.contains("for all 636 samples"),
        "{notes}"
    );
    assert!(run.nav.is_none());
    let imu = run.imu.as_ref().expect("attitude, rates, acceleration");
    // pyulog's first vehicle_attitude q (w, x, y, z), as roll and yaw.
    let [w, x, y, z] = [0.9926282f32, 0.009468006, 0.00018696938, 0.1208285].map(f64::from);
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    let k = (imu.cols[0].iter()).position(|r| !r.is_nan()).unwrap();
    assert!(
        (imu.cols[0][k] - roll).abs() < 0.02,
        "{} {roll}",
        imu.cols[0][k]
    );
    assert!(
        (imu.cols[2][k] - yaw).abs() < 0.02,
        "{} {yaw}",
        imu.cols[2][k]
    );
    // On the ground: the accelerometer reads gravity upwards, -g along body z.
    let az: Vec<f64> = imu.cols[8]
        .iter()
        .copied()
        .filter(|a| a.is_finite())
        .collect();
    let mean = az.iter().sum::<f64>() / az.len() as f64;
    assert!((mean + 9.8).abs() < 0.5, "{mean}");
    let source = run.log_source.as_ref().expect("a log source");
    assert_eq!(source.topics["velocity_valid"], "vehicle_local_position");
}
