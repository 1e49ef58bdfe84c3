//! MCAP files: round trips chunked or not, files without a summary, damage, other encodings.

use crate::bag::find;
use crate::common::*;
use hydrofit_logs::write::{McapCompression, McapWriter};
use hydrofit_logs::{Format, Log, Value};

const ALL: [McapCompression; 4] = [
    McapCompression::Unchunked,
    McapCompression::None,
    McapCompression::Zstd,
    McapCompression::Lz4,
];

#[test]
fn mcap_files_round_trip_chunked_or_not() {
    for c in ALL {
        let path = tmp(&format!("round-{c:?}.mcap"));
        let sent = write_mcap(&path, c, 10.0, Some(64 * 1024));
        let log = Log::open(&path).unwrap();
        assert_eq!(log.format, Format::Mcap);
        assert_eq!(log.topics.len(), TOPICS.len());
        let imu = log.topic("/imu").unwrap();
        assert_eq!(log.topics[imu].type_name, "sensor_msgs/msg/Imu");
        assert_same(&log, &read_all(&log), &sent);
    }
}

/// A ROS 1 bag converted to MCAP (`mcap convert`) reads as the bag does: its messages keep
/// ROS 1's serialization and `Header` (with `seq`) under `ros1msg` schemas.
#[test]
fn ros1_messages_in_mcap_round_trip() {
    for c in [McapCompression::Unchunked, McapCompression::Zstd] {
        let path = tmp(&format!("ros1-{c:?}.mcap"));
        let sent = write_ros1_mcap(&path, c, 10.0);
        let log = Log::open(&path).unwrap();
        assert_eq!(log.format, Format::Mcap);
        let imu = log.topic("/imu").unwrap();
        assert_eq!(log.topics[imu].type_name, "sensor_msgs/Imu");
        assert!(log.topics[imu].schema.select("header.seq").is_ok());
        assert_same(&log, &read_all(&log), &sent);
    }
    // A ros1msg schema over CDR messages is refused, naming both.
    let path = tmp("ros1-cdr.mcap");
    write_ros1_mcap(&path, McapCompression::None, 1.0);
    let mut bytes = std::fs::read(&path).unwrap();
    let mut k = 0;
    // Each channel's message encoding `ros1` (4 bytes after its length) becomes `cdr ` -> the
    // length stays, so write a 4-letter encoding the reader does not take for ROS 1.
    while let Some(i) = find(&bytes[k..], b"\x04\x00\x00\x00ros1") {
        bytes[k + i + 4..k + i + 8].copy_from_slice(b"xcdr");
        k += i + 1;
    }
    std::fs::write(&path, &bytes).unwrap();
    let e = Log::open(&path).unwrap_err();
    assert!(
        e.what.contains("encoded as `xcdr`, not `ros1`") && e.what.contains("ros1msg"),
        "{e}"
    );
}

#[test]
fn an_mcap_file_never_finished_is_scanned() {
    for c in ALL {
        let path = tmp(&format!("open-{c:?}.mcap"));
        let sent = write_mcap_with(&path, c, 4.0, Some(32 * 1024), false);
        let log = Log::open(&path).unwrap();
        let got = read_all(&log);
        assert!(got.len() > sent.len() / 2, "{c:?}");
        assert_same(&log, &got, &sent[..got.len()]);
    }
}

#[test]
fn a_damaged_summary_falls_back_to_scanning() {
    for c in ALL {
        let path = tmp(&format!("badsummary-{c:?}.mcap"));
        let sent = write_mcap(&path, c, 3.0, Some(32 * 1024));
        let good = std::fs::read(&path).unwrap();
        // The footer's summary_start (8 bytes at 37 from the end) pointing elsewhere.
        for (k, start) in [0u64, 9, good.len() as u64 - 50].into_iter().enumerate() {
            let mut bad = good.clone();
            let at = good.len() - 8 - 20;
            bad[at..at + 8].copy_from_slice(&start.to_le_bytes());
            let p = tmp(&format!("badsummary-{c:?}-{k}.mcap"));
            std::fs::write(&p, &bad).unwrap();
            let log = Log::open(&p).unwrap();
            assert_same(&log, &read_all(&log), &sent);
        }
        for frac in [0.5, 0.95] {
            let n = (good.len() as f64 * frac) as usize;
            std::fs::write(&path, &good[..n]).unwrap();
            let log = Log::open(&path).unwrap();
            let got = read_all(&log);
            assert_same(&log, &got, &sent[..got.len()]);
        }
    }
}

#[test]
fn damaged_chunks_are_located_errors() {
    for c in [
        McapCompression::None,
        McapCompression::Zstd,
        McapCompression::Lz4,
    ] {
        let path = tmp(&format!("badchunk-{c:?}.mcap"));
        write_mcap(&path, c, 3.0, Some(32 * 1024));
        let mut bytes = std::fs::read(&path).unwrap();
        let mid = bytes.len() / 2;
        for b in &mut bytes[mid..mid + 8] {
            *b ^= 0xa5;
        }
        std::fs::write(&path, &bytes).unwrap();
        let e = Log::open(&path)
            .and_then(|log| log.read(&(0..log.topics.len()).collect::<Vec<_>>(), &mut |_| Ok(())));
        let e = e.unwrap_err();
        assert!(e.offset.is_some_and(|o| o <= mid as u64), "{c:?}: {e}");
    }
}

#[test]
fn other_schema_encodings_are_said_not_read() {
    let path = tmp("idl.mcap");
    write_mcap(&path, McapCompression::Zstd, 1.0, None);
    let mut bytes = std::fs::read(&path).unwrap();
    let mut k = 0;
    while let Some(i) = find(&bytes[k..], b"ros2msg") {
        bytes[k + i..k + i + 7].copy_from_slice(b"ros2idl");
        k += i + 1;
    }
    std::fs::write(&path, &bytes).unwrap();
    let e = Log::open(&path).unwrap_err();
    assert!(e.what.contains("`ros2idl`, which is not read"), "{e}");
    assert!(e.what.contains("protobuf"), "{e}");
}

#[test]
fn big_endian_cdr_and_wrong_messages() {
    let path = tmp("be.mcap");
    let mut w = McapWriter::create(&path, McapCompression::Lz4).unwrap();
    let id = w.add_topic("/depth", "std_msgs/Float64").unwrap();
    let mut be = vec![0, 0, 0, 0];
    be.extend(2.5f64.to_be_bytes());
    w.write_bytes(id, T0, &be).unwrap();
    w.write(id, T0 + 1.0, &Value::Struct(vec![Value::Float(-1.0)]))
        .unwrap();
    w.write_bytes(id, T0 + 2.0, &[0, 1, 0, 0, 1, 2]).unwrap(); // too short
    let mut xcdr2 = vec![0, 7, 0, 0];
    xcdr2.extend(1f64.to_le_bytes());
    w.write_bytes(id, T0 + 3.0, &xcdr2).unwrap();
    w.finish().unwrap();
    let log = Log::open(&path).unwrap();
    let mut got = Vec::new();
    let e = log
        .read(&[0], &mut |m| {
            got.push(m.value.clone());
            Ok(())
        })
        .unwrap_err();
    let want = [
        Value::Struct(vec![Value::Float(2.5)]),
        Value::Struct(vec![Value::Float(-1.0)]),
    ];
    assert_eq!(got, want);
    assert!(
        e.what.contains("/depth") && e.what.contains("t = 1700000002.000000"),
        "{e}"
    );
    assert!(e.offset.is_some());
    let mut n = 0;
    let e = log
        .read(&[0], &mut |_| {
            n += 1;
            if n == 2 {
                return Err(hydrofit_logs::LogError::new("caller", "stop"));
            }
            Ok(())
        })
        .unwrap_err();
    assert_eq!(e.what, "stop");
}

#[test]
fn xcdr2_is_said_not_read() {
    let path = tmp("xcdr2.mcap");
    let mut w = McapWriter::create(&path, McapCompression::None).unwrap();
    let id = w.add_topic("/depth", "std_msgs/Float64").unwrap();
    let mut xcdr2 = vec![0, 7, 0, 0];
    xcdr2.extend(1f64.to_le_bytes());
    w.write_bytes(id, T0, &xcdr2).unwrap();
    w.finish().unwrap();
    let log = Log::open(&path).unwrap();
    let e = log.read(&[0], &mut |_| Ok(())).unwrap_err();
    assert!(e.what.contains("XCDR2"), "{e}");
}

#[test]
fn a_changed_field_type_is_an_error_naming_the_topic() {
    for c in ALL {
        let path = tmp(&format!("changed-{c:?}.mcap"));
        write_mcap(&path, c, 1.0, None);
        let mut bytes = std::fs::read(&path).unwrap();
        let mut k = 0;
        // (`fluid_pressure` as a float32 would still fit: CDR pads the next float64 to 8.)
        while let Some(i) = find(&bytes[k..], b"float64 variance") {
            bytes[k + i + 5..k + i + 7].copy_from_slice(b"32");
            k += i + 1;
        }
        std::fs::write(&path, &bytes).unwrap();
        let log = Log::open(&path).unwrap();
        let t = log.topic("/pressure").unwrap();
        let e = log.read(&[t], &mut |_| Ok(())).unwrap_err();
        assert!(
            e.what.contains("/pressure") && e.what.contains("left over"),
            "{c:?}: {e}"
        );
        assert!(e.what.contains("t = 1700000000.000"), "{c:?}: {e}");
        assert!(e.offset.is_some());
        let imu = log.topic("/imu").unwrap();
        log.read(&[imu], &mut |_| Ok(())).unwrap();
    }
}

/// The clock stepping back inside an MCAP file is said as in a ROS 1 bag, chunked or not.
#[test]
fn a_clock_set_back_while_recording_is_said() {
    for c in [McapCompression::Unchunked, McapCompression::Zstd] {
        let path = tmp(&format!("set-back-{c:?}.mcap"));
        let mut w = McapWriter::create(&path, c).unwrap();
        w.set_chunk_size(4 * 1024);
        let id = w.add_topic("/depth", "std_msgs/Float64").unwrap();
        for i in 0..400 {
            let t = T0 + i as f64 * 0.01 - if i >= 200 { 2.0 } else { 0.0 };
            w.write(id, t, &Value::Struct(vec![Value::Float(i as f64)]))
                .unwrap();
        }
        w.finish().unwrap();
        let log = Log::open(&path).unwrap();
        let notes = log.notes().join("\n");
        assert!(
            notes.contains("steps back by 1.990 s on /depth at 1.990 s"),
            "{c:?}: {notes}"
        );
    }
}
