//! MAVLink telemetry logs: written and read back, damaged, and the real ArduSub tlog.

mod common;

use common::{TempFile, get, open, read_all, written_tlog};
use hydrofit_logs::tlog::{Tlog, Writer};
use hydrofit_logs::{Format, Log, Value};
use std::path::Path;

const T0: u64 = 1_683_220_541_000_000;

#[test]
fn round_trip_v1_and_v2() {
    let f = TempFile::new("rt.tlog", &written_tlog());
    let log = open(&f.0);
    assert_eq!(log.format, Format::Tlog);
    assert!(log.notes().is_empty(), "{:?}", log.notes());
    let names: Vec<&str> = log.topics.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "ATTITUDE",
            "SERVO_OUTPUT_RAW",
            "NAMED_VALUE_FLOAT",
            "HEARTBEAT[1:1]",
            "HEARTBEAT[255:190]"
        ]
    );
    let att = &log.topics[0];
    assert_eq!((att.count, att.first_s), (150, T0 as f64 / 1e6));
    assert_eq!(att.type_name, "ATTITUDE");
    let msgs = read_all(&log).unwrap();
    assert_eq!(msgs.len(), 150 * 3 + 30);
    let of = |n: &'static str| msgs.iter().filter(move |m| m.0 == n);
    for (k, (_, t, v)) in of("ATTITUDE").enumerate() {
        let x = k as f64 * 0.01;
        assert_eq!(*t, (T0 + k as u64 * 50_000) as f64 / 1e6);
        assert_eq!(get(&log, "ATTITUDE", v, "time_boot_ms"), k as f64);
        assert_eq!(get(&log, "ATTITUDE", v, "pitch"), -x as f32 as f64);
    }
    for (k, (_, _, v)) in of("SERVO_OUTPUT_RAW").enumerate() {
        let s = |p: &str| get(&log, "SERVO_OUTPUT_RAW", v, p);
        assert_eq!(s("servo1_raw"), 1500.0 + k as f64);
        assert_eq!(s("port"), 0.0);
        // Extensions: MAVLink 1 packets (every third) do not carry them.
        let ext = if k % 3 == 0 { 0.0 } else { 1500.0 + k as f64 };
        assert_eq!(s("servo16_raw"), ext, "message {k}");
    }
    let (_, _, nvf) = of("NAMED_VALUE_FLOAT").nth(7).unwrap();
    let Value::Struct(f) = nvf else { panic!() };
    assert_eq!(f[1], Value::Text("CamTilt".into()));
    assert_eq!(f[2], Value::Float(0.07f32 as f64));
}

#[test]
fn mavlink2_truncates_trailing_zeros_and_reads_them_back() {
    let mut w = Writer::new(true);
    // 38 bytes in full; all zeros after chan1_raw (u16 at offset 0) and the targets.
    let mut v = vec![0.0; 20];
    v[2] = 1234.0;
    w.write(T0, (255, 190), "RC_CHANNELS_OVERRIDE", &v).unwrap();
    assert_eq!(w.bytes()[9], 2, "payload cut to 2 bytes");
    w.write(T0 + 1, (255, 190), "VISION_POSITION_DELTA", &vpd())
        .unwrap();
    let (t, topics) = Tlog::open(Path::new("trunc.tlog"), w.into_bytes()).unwrap();
    let mut got = Vec::new();
    t.read(Path::new("trunc.tlog"), &topics, &[0, 1], &mut |m| {
        got.push(m.value.clone());
        Ok(())
    })
    .unwrap();
    let sel = topics[0].schema.select("chan1_raw").unwrap();
    assert_eq!(sel.get(&got[0]), Some(1234.0));
    assert_eq!(
        topics[0].schema.select("chan18_raw").unwrap().get(&got[0]),
        Some(0.0)
    );
    let conf = topics[1].schema.select("confidence").unwrap();
    assert_eq!(conf.get(&got[1]), Some(0.5));
    let ad = |i: usize| {
        topics[1]
            .schema
            .select(&format!("angle_delta[{i}]"))
            .unwrap()
            .get(&got[1])
    };
    assert_eq!([ad(0), ad(1), ad(2)], [Some(0.25), Some(-0.25), Some(0.0)]);
    assert_eq!(got[1], Value::Struct(vpd()));
}

/// A VISION_POSITION_DELTA: two times, two float[3], a confidence.
fn vpd() -> Vec<Value> {
    let v3 = |a: f64| Value::Array(vec![Value::Float(a), Value::Float(-a), Value::Float(0.0)]);
    vec![
        Value::UInt(1),
        Value::UInt(2),
        v3(0.25),
        v3(1.5),
        Value::Float(0.5),
    ]
}

#[test]
fn writer_refuses_what_does_not_fit() {
    let mut w = Writer::new(false);
    assert!(
        w.write(T0, (1, 1), "NO_SUCH", &[0.0])
            .unwrap_err()
            .contains("not compiled in")
    );
    assert!(
        w.write(T0, (1, 1), "ATTITUDE", &[0.0; 3])
            .unwrap_err()
            .contains("3 values")
    );
    let e = w
        .write(T0, (1, 1), "VISION_POSITION_DELTA", &vpd())
        .unwrap_err();
    assert!(e.contains("needs MAVLink 2"), "{e}");
    assert!(
        w.write(T0, (1, 1), "HEARTBEAT", &[256.0, 0.0, 0.0, 0.0, 0.0, 0.0])
            .is_err()
    );
    assert!(w.is_empty());
}

#[test]
fn bad_checksums_unknown_ids_and_garbage_are_counted() {
    let mut w = Writer::new(true);
    w.write(T0, (1, 1), "ATTITUDE", &[1.0, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0])
        .unwrap();
    let n = w.len();
    w.write(
        T0 + 1,
        (1, 1),
        "ATTITUDE",
        &[2.0, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0],
    )
    .unwrap();
    let mut bytes = w.into_bytes();
    bytes[n + 8 + 10 + 5] ^= 0x40; // a payload byte of the second packet
    let mut w = Writer::new(true);
    w.raw(&bytes);
    // An unknown message id (9999), framed right: counted, not an error.
    w.raw(&(T0 + 2).to_be_bytes());
    w.raw(&[0xFD, 1, 0, 0, 0, 1, 1, 0x0F, 0x27, 0, 7, 0xAB, 0xCD]);
    w.raw(b"not a record at all");
    w.write(
        T0 + 3,
        (1, 1),
        "ATTITUDE",
        &[3.0, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0],
    )
    .unwrap();
    let f = TempFile::new("bad.tlog", w.bytes());
    let log = open(&f.0);
    assert_eq!(log.topics[0].count, 2);
    let notes = log.notes().join("\n");
    assert!(notes.contains("1 packets with a bad checksum"), "{notes}");
    assert!(
        notes.contains("1 packets of 1 message types not compiled in were skipped (ids 9999)"),
        "{notes}"
    );
    assert!(
        notes.contains("skipped 19 damaged bytes in 1 places"),
        "{notes}"
    );
}

#[test]
fn a_record_cut_at_the_end_is_dropped_with_a_note() {
    let data = written_tlog();
    let f = TempFile::new("cut.tlog", &data[..data.len() - 3]);
    let log = open(&f.0);
    assert_eq!(
        log.topics[log.topic("NAMED_VALUE_FLOAT").unwrap()].count,
        149
    );
    let notes = log.notes();
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].contains("cut off by the end of the file"),
        "{notes:?}"
    );
}

#[test]
fn a_file_that_is_no_tlog_is_an_error() {
    let f = TempFile::new("text.tlog", b"timestamp,roll\n1,2\n");
    let e = Log::open(&f.0).unwrap_err();
    assert!(e.what.contains("not a MAVLink telemetry log"), "{e}");
    assert_eq!((e.offset, e.path.as_path()), (Some(0), f.0.as_path()));
    assert!(!e.fix.is_empty());
    // The same bytes without the .tlog name are a CSV table with a time column; text that is
    // neither is no known format.
    let g = TempFile::new("text.log", b"timestamp,roll\n1,2\n");
    assert_eq!(Log::open(&g.0).unwrap().format, Format::Csv);
    let h = TempFile::new("notes.log", b"the dive went well\n");
    assert!(
        Log::open(&h.0)
            .unwrap_err()
            .what
            .contains("unknown first bytes")
    );
    let mut junk = written_tlog()[..200].to_vec();
    junk.extend(vec![0x55u8; 1000]);
    let e = Tlog::open(Path::new("junk.tlog"), junk).unwrap_err();
    assert!(e.what.contains("mostly damaged"), "{e}");
}

const SMALL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/ardusub/small.tlog");

/// Messages per topic as pymavlink 2.4.50 (`mavutil`, ardupilotmega dialect) counts them.
#[rustfmt::skip]
const SMALL_COUNTS: [(&str, u64); 18] = [
    ("ATTITUDE", 5245), ("SERVO_OUTPUT_RAW", 528), ("RC_CHANNELS", 528), ("RAW_IMU", 528),
    ("SCALED_IMU2", 528), ("SCALED_PRESSURE", 528), ("SCALED_PRESSURE2", 635),
    ("NAMED_VALUE_FLOAT", 4224), ("VFR_HUD", 3060), ("SYS_STATUS", 528),
    ("GLOBAL_POSITION_INT", 792), ("LOCAL_POSITION_NED", 792), ("MANUAL_CONTROL", 1450),
    ("EKF_STATUS_REPORT", 792),
    ("HEARTBEAT[1:1]", 263), ("HEARTBEAT[1:100]", 264), ("HEARTBEAT[1:194]", 264),
    ("HEARTBEAT[255:190]", 265),
];

/// The real ArduSub tlog (github clydemcqueen/ardusub_log_tools, MIT), where it is present.
fn small() -> Option<Log> {
    if !Path::new(SMALL).exists() {
        println!("note: {SMALL} is not here; skipping the real-log test");
        return None;
    }
    Some(open(Path::new(SMALL)))
}

#[test]
fn small_tlog_counts_agree_with_pymavlink() {
    let Some(log) = small() else { return };
    assert_eq!(log.topics.len(), SMALL_COUNTS.len());
    for (name, n) in SMALL_COUNTS {
        let t = log.topic(name).unwrap_or_else(|| panic!("no {name}"));
        assert_eq!(log.topics[t].count, n, "{name}");
    }
    // pymavlink's 4 BAD_DATA are camera messages (ids 259, 260, 262, 269) of another
    // version of their definitions: not compiled in here, so counted as unknown.
    let notes = log.notes();
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(notes[0].starts_with("14702 packets of 35 message types not compiled in"));
}

/// Values as pymavlink reads them (`to_dict()`, `_timestamp`).
#[test]
fn small_tlog_values_agree_with_pymavlink() {
    let Some(log) = small() else { return };
    let msgs = read_all(&log).unwrap();
    let first = |n: &str| msgs.iter().find(|m| m.0 == n).unwrap();
    let f = |topic: &str, v: &Value, p: &str| get(&log, topic, v, p);
    let (_, t, att) = first("ATTITUDE");
    assert_eq!(*t, 1683220541.493);
    assert_eq!(f("ATTITUDE", att, "roll"), -0.024300388991832733);
    assert_eq!(f("ATTITUDE", att, "pitch"), 0.02468784712255001);
    assert_eq!(f("ATTITUDE", att, "yaw"), -2.3479995727539062);
    let (_, _, so) = first("SERVO_OUTPUT_RAW");
    assert_eq!(f("SERVO_OUTPUT_RAW", so, "time_usec"), 689175102.0);
    assert_eq!(f("SERVO_OUTPUT_RAW", so, "servo12_raw"), 1100.0);
    assert_eq!(f("SERVO_OUTPUT_RAW", so, "servo16_raw"), 1500.0);
    let (_, _, sp) = first("SCALED_PRESSURE");
    assert_eq!(f("SCALED_PRESSURE", sp, "press_abs"), 1006.5374755859375);
    assert_eq!(f("SCALED_PRESSURE", sp, "temperature"), 2930.0);
    let (_, _, mc) = first("MANUAL_CONTROL");
    let xyzr = ["x", "y", "z", "r"].map(|p| f("MANUAL_CONTROL", mc, p));
    assert_eq!(xyzr, [36.0, 7.0, 511.0, -40.0]);
    let (_, t, ekf) = first("EKF_STATUS_REPORT");
    assert_eq!(*t, 1683220541.495);
    assert_eq!(f("EKF_STATUS_REPORT", ekf, "flags"), 831.0);
    let var = f("EKF_STATUS_REPORT", ekf, "velocity_variance");
    assert_eq!(var, 0.03235374763607979);
    let (_, _, nv) = first("NAMED_VALUE_FLOAT");
    assert!(matches!(nv, Value::Struct(v) if v[1] == Value::Text("CamTilt".into())));
}
