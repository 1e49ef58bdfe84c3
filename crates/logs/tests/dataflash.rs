//! DataFlash logs: written and read back, damaged, and the real ArduSub log.

mod common;

use common::{TempFile, get, open, read_all};
use hydrofit_logs::dataflash::{Bin, Writer};
use hydrofit_logs::{Format, Log, Value};
use std::path::Path;

/// A small log like ArduSub's: ATT, two IMU instances, RCOU, text messages, an untimed type.
fn sample() -> Writer {
    let mut w = Writer::new();
    w.define("ATT", "QccC", "TimeUS,Roll,Pitch,Yaw").unwrap();
    w.define("IMU", "QBff", "TimeUS,I,GyrX,AccZ").unwrap();
    w.units("IMU", "s#Eo", "F-00").unwrap();
    w.define("RCOU", "QHHHHHHHH", "TimeUS,C1,C2,C3,C4,C5,C6,C7,C8")
        .unwrap();
    w.define("MSG", "QZ", "TimeUS,Message").unwrap();
    w.define("RFRN", "IB", "HLat,Flags").unwrap();
    w.write(
        "MSG",
        &[Value::UInt(500), Value::Text("ArduSub V4.1.0".into())],
    )
    .unwrap();
    for k in 0..10u32 {
        let t = 1_000_000.0 + k as f64 * 100_000.0;
        let k = k as f64;
        w.write("ATT", &[t, 1.25 + k, -0.5 * k, 359.99 - k])
            .unwrap();
        w.write("IMU", &[t + 10.0, 0.0, 0.125 * k, -9.75]).unwrap();
        w.write("IMU", &[t + 20.0, 1.0, -0.125 * k, -9.5]).unwrap();
        let mut rc = vec![t + 30.0];
        rc.extend((1..=8).map(|c| 1100.0 + 10.0 * c as f64 + k));
        w.write("RCOU", &rc).unwrap();
        w.write("RFRN", &[7.0, k]).unwrap();
    }
    w
}

#[test]
fn round_trip() {
    let f = TempFile::new("rt.BIN", sample().bytes());
    let log = open(&f.0);
    assert_eq!(log.format, Format::DataFlash);
    assert!(log.notes().is_empty(), "{:?}", log.notes());
    let count = |n: &str| log.topics[log.topic(n).unwrap_or_else(|| panic!("{n}"))].count;
    assert_eq!(count("ATT"), 10);
    assert_eq!(count("IMU[0]"), 10);
    assert_eq!(count("IMU[1]"), 10);
    assert_eq!(count("RCOU"), 10);
    assert_eq!(count("MSG"), 1);
    assert_eq!(count("FMTU"), 1);
    assert_eq!(count("FMT"), 7, "FMT, ATT, IMU, FMTU, RCOU, MSG, RFRN");
    assert!(log.topic("IMU").is_none());
    let att = &log.topics[log.topic("ATT").unwrap()];
    assert_eq!((att.first_s, att.last_s), (1.0, 1.9));
    assert_eq!(att.type_name, "ATT");
    assert!((att.rate_hz() - 10.0).abs() < 1e-9);

    let msgs = read_all(&log).unwrap();
    let of = |n: &'static str| msgs.iter().filter(move |m| m.0 == n);
    for (k, (_, t, v)) in of("ATT").enumerate() {
        let k = k as f64;
        assert_eq!(*t, (1_000_000.0 + k * 100_000.0) / 1e6, "TimeUS / 1e6");
        assert_eq!(get(&log, "ATT", v, "Roll"), 1.25 + k);
        assert_eq!(get(&log, "ATT", v, "Pitch"), -0.5 * k);
        assert_eq!(
            get(&log, "ATT", v, "Yaw"),
            ((359.99 - k) * 100.0).round() / 100.0
        );
    }
    for (k, (_, _, v)) in of("IMU[1]").enumerate() {
        assert_eq!(get(&log, "IMU[1]", v, "I"), 1.0);
        assert_eq!(get(&log, "IMU[1]", v, "GyrX"), -0.125 * k as f64);
    }
    let rc: Vec<f64> = of("RCOU").map(|m| get(&log, "RCOU", &m.2, "C8")).collect();
    assert_eq!(rc, (0..10).map(|k| 1180.0 + k as f64).collect::<Vec<_>>());
    let (_, t, msg) = of("MSG").next().unwrap();
    assert_eq!(*t, 0.0005);
    assert_eq!(
        msg,
        &Value::Struct(vec![Value::UInt(500), Value::Text("ArduSub V4.1.0".into())])
    );
}

#[test]
fn untimed_messages_take_the_last_time_and_file_order_holds() {
    let f = TempFile::new("order.BIN", sample().bytes());
    let log = open(&f.0);
    let msgs = read_all(&log).unwrap();
    let rfrn: Vec<f64> = msgs.iter().filter(|m| m.0 == "RFRN").map(|m| m.1).collect();
    // Each RFRN follows an RCOU written at TimeUS = ATT's + 30.
    assert_eq!(rfrn[0], 1.00003);
    assert!(msgs.windows(2).all(|w| w[0].1 <= w[1].1), "times go back");
    // FMT records come before any timed message: time 0.
    assert_eq!(log.topics[log.topic("FMT").unwrap()].first_s, 0.0);
}

#[test]
fn reads_only_the_wanted_topics() {
    let f = TempFile::new("wanted.BIN", sample().bytes());
    let log = open(&f.0);
    let want = [log.topic("IMU[1]").unwrap(), log.topic("ATT").unwrap()];
    let mut seen = Vec::new();
    log.read(&want, &mut |m| {
        seen.push(m.topic);
        Ok(())
    })
    .unwrap();
    assert_eq!(seen.len(), 20);
    assert!(seen.iter().all(|t| want.contains(t)));
    assert_eq!(seen[..2], [want[1], want[0]], "file order");
    let e = log.read(&[999], &mut |_| Ok(())).unwrap_err();
    assert!(e.what.contains("no topic 999"), "{e}");
}

#[test]
fn every_format_character() {
    // Two types, as FMT allows 16 fields at most.
    let mut w = Writer::new();
    w.define("ALL1", "bBhHiIfdnNZ", "b,B,h,H,i,I,f,d,n,N,Z")
        .unwrap();
    w.define("ALL2", "cCeELMqQag", "c,C,e,E,L,M,q,Q,a,g")
        .unwrap();
    let arr = Value::Array((0..32).map(|i| Value::Int(i * 100 - 1600)).collect());
    let one = vec![
        Value::Int(-5),
        Value::UInt(250),
        Value::Int(-30000),
        Value::UInt(65000),
        Value::Int(-2_000_000_000),
        Value::UInt(4_000_000_000),
        Value::Float(0.1f32 as f64),
        Value::Float(-1.0e300),
        Value::Text("abcd".into()),
        Value::Text("sixteen chars ok".into()),
        Value::Text("x".repeat(64)),
    ];
    let two = vec![
        Value::Float(-327.68),
        Value::Float(655.35),
        Value::Float(-21474836.48),
        Value::Float(42949672.95),
        Value::Float(-35.123_456_7),
        Value::UInt(19),
        Value::Int(i64::MIN),
        Value::UInt(u64::MAX),
        arr,
        Value::Float(-1.5),
    ];
    w.write("ALL1", &one).unwrap();
    w.write("ALL2", &two).unwrap();
    let (bin, topics) = Bin::open(Path::new("all.BIN"), w.into_bytes()).unwrap();
    let leaves = topics[2].schema.leaves();
    assert_eq!(leaves[8], ("a[0..32]".to_string(), "int16".to_string()));
    let mut got = Vec::new();
    bin.read(Path::new("all.BIN"), &topics, &[1, 2], &mut |m| {
        got.push(m.value.clone());
        Ok(())
    })
    .unwrap();
    assert_eq!(got, [Value::Struct(one), Value::Struct(two)]);
}

#[test]
fn writer_refuses_what_does_not_fit() {
    let mut w = Writer::new();
    assert!(w.define("TOOLONG", "Q", "TimeUS").is_err());
    assert!(
        w.define("X", "Qj", "TimeUS,A")
            .unwrap_err()
            .contains("unknown format")
    );
    assert!(
        w.define("X", "QB", "TimeUS")
            .unwrap_err()
            .contains("1 labels for 2")
    );
    w.define("X", "QBn", "TimeUS,A,N").unwrap();
    assert!(w.define("X", "Q", "TimeUS").is_err());
    assert!(w.write("X", &[1.0, 256.0, 0.0]).is_err());
    let len = w.len();
    assert!(
        w.write(
            "X",
            &[Value::UInt(1), Value::UInt(1), Value::Text("five!".into())]
        )
        .is_err()
    );
    assert_eq!(w.len(), len, "a refused message leaves nothing behind");
    assert!(w.write("Y", &[1.0]).is_err());
    assert!(w.units("Y", "s", "F").is_err());
}

#[test]
fn old_logs_time_by_timems() {
    let mut w = Writer::new();
    w.define("ATT", "IccC", "TimeMS,Roll,Pitch,Yaw").unwrap();
    w.define("GPS", "BIHI", "Status,TimeMS,Week,T").unwrap();
    w.write("ATT", &[1500.0, 1.0, 2.0, 3.0]).unwrap();
    w.write("GPS", &[3.0, 123_456_000.0, 2200.0, 1600.0])
        .unwrap();
    let f = TempFile::new("old.BIN", w.bytes());
    let log = open(&f.0);
    let msgs = read_all(&log).unwrap();
    let time = |n: &str| msgs.iter().find(|m| m.0 == n).unwrap().1;
    assert_eq!(time("ATT"), 1.5);
    assert_eq!(
        time("GPS"),
        1.6,
        "old GPS keeps boot time in T, TimeMS is GPS time"
    );
}

#[test]
fn garbage_in_the_middle_is_skipped_and_counted() {
    let mut w = sample();
    w.raw(&[0xA3, 0x95, 0x02, 1, 2, 3, 0xA3, 0x00, 9, 9]);
    for k in 0..5 {
        w.write("ATT", &[3_000_000.0 + k as f64, 0.0, 0.0, 0.0])
            .unwrap();
    }
    let f = TempFile::new("garbage.BIN", w.bytes());
    let log = open(&f.0);
    assert_eq!(log.topics[log.topic("ATT").unwrap()].count, 15);
    let notes = log.notes().join("\n");
    assert!(
        notes.contains("skipped 10 damaged bytes in 1 places"),
        "{notes}"
    );
    assert!(
        notes.contains("records of type 2 have no FMT record"),
        "{notes}"
    );
}

#[test]
fn a_record_cut_at_the_end_is_dropped_with_a_note() {
    let w = sample();
    let full = w.bytes().len();
    let cut = &w.bytes()[..full - 5];
    let f = TempFile::new("cut.BIN", cut);
    let log = open(&f.0);
    assert_eq!(log.topics[log.topic("RFRN").unwrap()].count, 9);
    let notes = log.notes();
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].contains("cut off by the end of the file"),
        "{notes:?}"
    );
    assert_eq!(
        read_all(&log).unwrap().len() as u64,
        log.topics.iter().map(|t| t.count).sum()
    );
}

#[test]
fn a_log_without_fmt_is_an_error() {
    let mut w = sample();
    let bytes = w.bytes().to_vec();
    w = Writer::new();
    let skip = w.len();
    let body = &bytes[skip..];
    // Drop every FMT record: keep only the records after the definitions.
    let first_msg = body
        .windows(3)
        .position(|h| h == [0xA3, 0x95, 0x85])
        .unwrap();
    let mut data = vec![0xA3, 0x95, 0x00, 0x00];
    data.extend_from_slice(&body[first_msg..]);
    let e = Bin::open(Path::new("nofmt.BIN"), data).unwrap_err();
    assert!(e.what.contains("no FMT record"), "{e}");
    assert_eq!(e.offset, Some(0));
    assert!(!e.fix.is_empty());
}

#[test]
fn a_log_that_is_mostly_garbage_is_an_error() {
    let mut w = Writer::new();
    w.define("ATT", "QccC", "TimeUS,Roll,Pitch,Yaw").unwrap();
    w.write("ATT", &[1.0, 0.0, 0.0, 0.0]).unwrap();
    w.raw(&vec![0x55; 1000]);
    let e = Bin::open(Path::new("junk.BIN"), w.into_bytes()).unwrap_err();
    assert!(e.what.contains("mostly damaged"), "{e}");
    assert_eq!(e.offset, Some(89 * 2 + 17));
    assert_eq!(e.path, Path::new("junk.BIN"));
}

#[test]
fn a_redefinition_with_another_layout_gets_its_own_topic() {
    let mut w = Writer::new();
    w.define("ATT", "QccC", "TimeUS,Roll,Pitch,Yaw").unwrap();
    w.write("ATT", &[1.0, 0.0, 0.0, 0.0]).unwrap();
    // The same type id (129) defined again with one more field.
    w.raw(&[0xA3, 0x95, 0x80, 129, 3 + 8 + 6 + 4]);
    for (s, n) in [("ATT", 4), ("QccCf", 16), ("TimeUS,Roll,Pitch,Yaw,Err", 64)] {
        let mut b = s.as_bytes().to_vec();
        b.resize(n, 0);
        w.raw(&b);
    }
    let mut rec = vec![0xA3, 0x95, 129];
    rec.extend_from_slice(&2u64.to_le_bytes());
    rec.extend_from_slice(&[0; 6]);
    rec.extend_from_slice(&0.5f32.to_le_bytes());
    w.raw(&rec);
    let (_, topics) = Bin::open(Path::new("redef.BIN"), w.into_bytes()).unwrap();
    let names: Vec<&str> = topics.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, ["FMT", "ATT", "ATT~2"]);
}

const SMALL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/ardusub/small.BIN");

/// The real ArduSub log (github clydemcqueen/ardusub_log_tools, MIT), where it is present.
fn small() -> Option<Log> {
    if !Path::new(SMALL).exists() {
        println!("note: {SMALL} is not here; skipping the real-log test");
        return None;
    }
    Some(open(Path::new(SMALL)))
}

/// Messages per topic as pymavlink 2.4.50 `DFReader_binary` counts them in small.BIN.
#[rustfmt::skip]
const SMALL_COUNTS: [(&str, u64); 28] = [
    ("FMT", 152), ("FMTU", 152), ("PARM", 876), ("UNIT", 34), ("MULT", 14), ("MSG", 9),
    ("ATT", 237), ("AHR2", 237), ("RCOU", 237), ("RCIN", 237), ("CTUN", 237),
    ("IMU[0]", 594), ("BARO[0]", 237), ("BARO[1]", 237), ("MAG[0]", 237), ("MAG[1]", 237),
    ("MAV[0]", 23), ("MAV[1]", 23), ("MAV[2]", 23), ("XKF1[0]", 237), ("XKV1[0]", 48),
    ("DU32", 24), ("DSF", 23), ("MAVC", 5), ("PM", 2), ("EV", 2), ("ARM", 1), ("MODE", 1),
];

#[test]
fn small_bin_counts_agree_with_pymavlink() {
    let Some(log) = small() else { return };
    assert!(log.notes().is_empty(), "{:?}", log.notes());
    for (name, n) in SMALL_COUNTS {
        let t = log.topic(name).unwrap_or_else(|| panic!("no {name}"));
        assert_eq!(log.topics[t].count, n, "{name}");
    }
    assert_eq!(log.topics.len(), 43);
    assert_eq!(read_all(&log).unwrap().len(), 7510);
}

/// Values as pymavlink 2.4.50 reads them (`DFMessage.to_dict()`).
#[test]
fn small_bin_values_agree_with_pymavlink() {
    let Some(log) = small() else { return };
    let msgs = read_all(&log).unwrap();
    let all = |n: &'static str| msgs.iter().filter(move |m| m.0 == n);
    let first = |n: &'static str| all(n).next().unwrap();
    let f = |topic: &str, v: &Value, p: &str| get(&log, topic, v, p);
    let (_, t, att) = first("ATT");
    assert_eq!(*t, 265.738465);
    let rpy = ["Roll", "Pitch", "Yaw"].map(|p| f("ATT", att, p));
    assert_eq!(rpy, [-0.08, -0.63, 213.93]);
    let rcou = &all("RCOU").nth(5).unwrap().2;
    let c: Vec<f64> = (1..=8).map(|i| f("RCOU", rcou, &format!("C{i}"))).collect();
    assert_eq!(
        c,
        [1506.0, 1492.0, 1506.0, 1508.0, 1500.0, 1500.0, 0.0, 0.0]
    );
    let (_, _, b0) = first("BARO[0]");
    let (_, _, b1) = first("BARO[1]");
    assert_eq!(f("BARO[0]", b0, "Alt"), -9.16286563873291);
    assert_eq!(f("BARO[0]", b0, "Press"), 99789.7421875);
    assert_eq!(f("BARO[0]", b0, "Temp"), 47.37);
    assert_eq!(f("BARO[1]", b1, "Press"), 97790.0);
    let Value::Struct(msg) = &first("MSG").2 else {
        panic!()
    };
    assert!(
        matches!(&msg[1], Value::Text(s) if s.contains("ArduSub")),
        "{msg:?}"
    );
}
