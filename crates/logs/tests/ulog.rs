//! PX4 ULog files: pyulog's own test logs (BSD 3-clause, `data/px4/`) read as pyulog 1.3.0 reads
//! them, and damaged copies of them read as far as they go.

mod common;

use common::{TempFile, get, open, read_all};
use hydrofit_logs::{Format, Log, Value};
use std::path::Path;

const SMALL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/px4/sample_log_small.ulg"
);
const APPENDED: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/px4/sample_appended_multiple.ulg"
);

fn total(log: &Log) -> u64 {
    log.topics.iter().map(|t| t.count).sum()
}

/// Messages per topic as pyulog counts them (`ULog.data_list`, by name and multi_id).
#[rustfmt::skip]
const SMALL_COUNTS: [(&str, u64); 10] = [
    ("actuator_outputs", 65), ("actuator_outputs[1]", 65), ("sensor_accel[2]", 6),
    ("sensor_combined", 1298), ("vehicle_angular_velocity", 1812), ("vehicle_attitude", 1298),
    ("vehicle_local_position", 636), ("vehicle_imu_status[1]", 7), ("test_motor", 1),
    ("mission", 1),
];

#[test]
fn a_px4_log_reads_as_pyulog_reads_it() {
    let log = open(Path::new(SMALL));
    assert_eq!(log.format, Format::Ulog);
    assert_eq!((log.topics.len(), total(&log)), (70, 14604));
    for (name, n) in SMALL_COUNTS {
        let t = log.topic(name).unwrap_or_else(|| panic!("no {name}"));
        assert_eq!(log.topics[t].count, n, "{name}");
    }
    let notes = log.notes();
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].contains("dropped messages 1 times (30 ms"),
        "{notes:?}"
    );
    let msgs = read_all(&log).unwrap();
    assert_eq!(msgs.len(), 14604);
    let first = |n: &str| msgs.iter().find(|m| m.0 == n).unwrap();
    let f = |topic: &str, v: &Value, p: &str| get(&log, topic, v, p);
    let (_, t, lp) = first("vehicle_local_position");
    assert_eq!(*t, 20.321827);
    let lpf = |p: &str| f("vehicle_local_position", lp, p);
    assert_eq!(lpf("vx"), 0.0031821f32 as f64);
    assert_eq!(lpf("vz"), -0.21418922f32 as f64);
    assert_eq!(lpf("z"), -1.167656f32 as f64);
    assert_eq!((lpf("v_xy_valid"), lpf("v_z_valid")), (0.0, 1.0));
    let (_, _, att) = first("vehicle_attitude");
    let q: Vec<f64> = (0..4)
        .map(|k| f("vehicle_attitude", att, &format!("q[{k}]")))
        .collect();
    let pyulog = [0.9926282f32, 0.009468006, 0.00018696938, 0.1208285];
    assert_eq!(q, pyulog.map(|x| x as f64));
    let (_, t, out) = msgs
        .iter()
        .filter(|m| m.0 == "actuator_outputs[1]")
        .nth(5)
        .unwrap();
    assert_eq!(*t, 20.818016);
    let o = |p: &str| f("actuator_outputs[1]", out, p);
    assert_eq!(
        [o("noutputs"), o("output[0]"), o("output[3]")],
        [4.0, 1000.0, 1500.0]
    );
    // Stamped before the logging started (a latched state): taken at the start.
    let (_, t, _) = first("position_setpoint_triplet");
    assert_eq!(*t, 20.309082);
}

/// Data appended after the log was closed (three appended offsets) is read where it starts.
#[test]
fn appended_data_is_read() {
    let log = open(Path::new(APPENDED));
    assert_eq!((log.topics.len(), total(&log)), (20, 6852));
    let n = |name: &str| log.topics[log.topic(name).unwrap()].count;
    assert_eq!((n("actuator_outputs"), n("actuator_outputs[1]")), (95, 96));
    assert_eq!(n("ekf2_timestamps"), 2373);
    assert!(log.notes().is_empty(), "{:?}", log.notes());
}

#[test]
fn a_damaged_log_is_read_as_far_as_it_goes() {
    let bytes = std::fs::read(SMALL).unwrap();
    // Cut in the middle of a record.
    let cut = TempFile::new("cut.ulg", &bytes[..bytes.len() / 2 + 1]);
    let log = open(&cut.0);
    assert!(total(&log) > 5000 && total(&log) < 14604);
    assert!(
        log.notes().iter().any(|n| n.contains("cut off")),
        "{:?}",
        log.notes()
    );
    read_all(&log).unwrap();
    // Garbage in the middle: skipped to the next sync marker (or the end), never a panic.
    let mut g = bytes.clone();
    let at = g.len() * 3 / 4;
    g.splice(at..at, [0xEEu8; 37]);
    let bad = TempFile::new("garbage.ulg", &g);
    let log = open(&bad.0);
    assert!(
        log.notes().iter().any(|n| n.contains("skipped")),
        "{:?}",
        log.notes()
    );
    assert!(total(&log) > 10000, "{}", total(&log));
    read_all(&log).unwrap();
    // The header alone, and a file mostly garbage.
    let header = TempFile::new("header.ulg", &bytes[..16]);
    assert_eq!(open(&header.0).topics.len(), 0);
    let mut junk = bytes[..2000].to_vec();
    junk.extend(vec![0x55u8; 10_000]);
    let junk = TempFile::new("junk.ulg", &junk);
    let e = Log::open(&junk.0).unwrap_err();
    assert!(e.what.contains("mostly damaged"), "{e}");
}
