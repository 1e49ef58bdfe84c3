//! Real ArduSub logs (`crates/logs/tests/data/ardusub/`, a BlueROV2's test logs from
//! clydemcqueen/ardusub_log_tools, MIT) read with no mapping, and the autopilot's velocity
//! estimate kept only where its filter says a sensor aided it.

use crate::common::ok;
use crate::e2e_logs::{heavy, load};
use hydrofit::core::model::thrusters::{Layout, Thrusters};
use std::path::{Path, PathBuf};

fn data(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("crates/logs/tests/data/ardusub")
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
