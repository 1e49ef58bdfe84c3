//! ROS 1 bags: round trips, bags without an index, torn ends, messages not matching their type.

use crate::common::*;
use hydrofit_logs::write::{BagCompression, BagWriter};
use hydrofit_logs::{Format, Log, ros_types};

const ALL: [BagCompression; 3] = [
    BagCompression::None,
    BagCompression::Bz2,
    BagCompression::Lz4,
];

#[test]
fn bags_round_trip_with_every_compression() {
    for c in ALL {
        let path = tmp(&format!("round-{c:?}.bag"));
        let sent = write_bag(&path, c, 10.0, Some(64 * 1024));
        let log = Log::open(&path).unwrap();
        assert_eq!(log.format, Format::Ros1Bag);
        assert_eq!(log.topics.len(), TOPICS.len());
        assert_same(&log, &read_all(&log), &sent);
        let imu = log.topic("/imu").unwrap();
        // The same ROS name without its leading slash, as `rostopic` takes it.
        assert_eq!(log.topic("imu"), Some(imu));
        assert_eq!(log.topic("mu"), None);
        assert_eq!(log.topics[imu].type_name, "sensor_msgs/Imu");
        assert!((log.topics[imu].rate_hz() - 200.0).abs() < 0.01);
        let mut n = 0;
        log.read(&[imu], &mut |m| {
            assert_eq!(m.topic, imu);
            n += 1;
            Ok(())
        })
        .unwrap();
        assert_eq!(n, 2000, "{c:?}");
    }
}

#[test]
fn a_bag_one_big_chunk_and_default_chunks() {
    let path = tmp("default-chunks.bag");
    let sent = write_bag(&path, BagCompression::Lz4, 3.0, None);
    let log = Log::open(&path).unwrap();
    assert_same(&log, &read_all(&log), &sent);
}

/// Field paths of the common types, in a bag (ROS 1 definitions) and an MCAP file (ROS 2).
#[test]
fn common_fields_are_where_ros_has_them() {
    let bag = tmp("fields.bag");
    write_bag(&bag, BagCompression::None, 1.0, None);
    let mcap = tmp("fields.mcap");
    write_mcap(
        &mcap,
        hydrofit_logs::write::McapCompression::Zstd,
        1.0,
        None,
    );
    for path in [bag, mcap] {
        check_fields(&Log::open(&path).unwrap());
    }
}

fn check_fields(log: &Log) {
    // The first message of each topic (i = 0): q(0, k) = 0.75 k - 8.
    let q = |k: f64| 0.75 * k - 8.0;
    let paths = [
        ("/imu", "linear_acceleration.z", -9.8125 + q(3.0) * 0.01),
        ("/imu", "orientation.w", 1.0),
        ("/odom", "twist.twist.angular.z", q(5.0)),
        ("/odom", "pose.covariance[35]", 0.25),
        ("/cmd_vel", "twist.linear.x", q(6.0)),
        ("/wrench", "wrench.torque.z", q(8.0)),
        ("/pressure", "fluid_pressure", 101_325.0 + q(9.0)),
        ("/states", "data[11]", q(11.0) * 0.1),
        ("/thrusters", "data[5]", (1500.0 + q(5.0) * 10.0).trunc()),
        ("/rc/out", "channels[7]", 1107.0),
        ("/rc/override", "channels[17]", 65535.0),
        ("/imu_raw", "data[9]", q(9.0)),
        ("/temp", "data", 4.5),
        ("/custom", "u64", 1.8e16),
        ("/custom", "when", T0 + 0.5),
        ("/custom", "took", 2.25),
        ("/custom", "header.stamp", T0 + 0.0011 - 0.002),
    ];
    for (topic, field, want) in paths {
        let t = log.topic(topic).unwrap();
        let sel = log.topics[t].schema.select(field).unwrap();
        let mut first = None;
        log.read(&[t], &mut |m| {
            first.get_or_insert(sel.get(&m.value));
            Ok(())
        })
        .unwrap();
        let got = first.flatten().unwrap();
        assert!(
            (got - want).abs() < 1e-6,
            "{topic} {field}: {got} != {want}"
        );
    }
}

#[test]
fn a_bag_never_closed_is_scanned() {
    for c in ALL {
        let path = tmp(&format!("open-{c:?}.bag"));
        let sent = write_bag_with(&path, c, 4.0, Some(32 * 1024), false);
        let log = Log::open(&path).unwrap();
        let got = read_all(&log);
        // The chunks written hold the first messages written; the last chunk never was.
        assert!(
            got.len() > sent.len() / 2 && got.len() < sent.len(),
            "{c:?}"
        );
        assert_same(&log, &got, &sent[..got.len()]);
    }
}

#[test]
fn a_damaged_index_falls_back_to_scanning() {
    for c in ALL {
        let path = tmp(&format!("badindex-{c:?}.bag"));
        let sent = write_bag(&path, c, 3.0, Some(32 * 1024));
        let good = std::fs::read(&path).unwrap();
        let at = find(&good, b"index_pos=").unwrap() + 10;
        let index_pos = u64::from_le_bytes(good[at..at + 8].try_into().unwrap()) as usize;
        for (k, bad_pos) in [good.len() as u64 + 100, 5000, index_pos as u64 + 3]
            .into_iter()
            .enumerate()
        {
            let mut bad = good.clone();
            bad[at..at + 8].copy_from_slice(&bad_pos.to_le_bytes());
            let p = tmp(&format!("badindex-{c:?}-{k}.bag"));
            std::fs::write(&p, &bad).unwrap();
            let log = Log::open(&p).unwrap();
            assert_same(&log, &read_all(&log), &sent);
        }
        // A chunk info record pointing elsewhere.
        let mut bad = good.clone();
        let ci = find(&good[index_pos..], b"chunk_pos=").unwrap() + index_pos + 10;
        bad[ci] ^= 0x40;
        std::fs::write(&path, &bad).unwrap();
        let log = Log::open(&path).unwrap();
        assert_same(&log, &read_all(&log), &sent);
    }
}

pub fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// A bag truncated anywhere in its chunks (a copy cut short) reads up to the cut.
#[test]
fn a_truncated_bag_keeps_what_is_readable() {
    for c in ALL {
        let path = tmp(&format!("cut-{c:?}.bag"));
        let sent = write_bag(&path, c, 4.0, Some(32 * 1024));
        let good = std::fs::read(&path).unwrap();
        let mut last = 0;
        for frac in [0.3, 0.6, 0.9, 0.99] {
            let n = (good.len() as f64 * frac) as usize;
            std::fs::write(&path, &good[..n]).unwrap();
            let log = Log::open(&path).unwrap();
            let got = read_all(&log);
            assert!(got.len() >= last, "{c:?} {frac}");
            last = got.len();
            // Torn chunks give their complete records, which come in writing order.
            assert_same(&log, &got, &sent[..got.len()]);
        }
    }
}

/// `rosbag record` writes a chunk's header with zero sizes and fills them in when it closes
/// the chunk: a recording killed mid-chunk leaves that header, then part of the stream.
#[test]
fn a_recording_killed_mid_chunk_is_read_up_to_the_kill() {
    for c in [BagCompression::None, BagCompression::Lz4] {
        let path = tmp(&format!("killed-{c:?}.bag"));
        let mut w = BagWriter::create(&path, c).unwrap();
        w.set_chunk_size(16 * 1024);
        let id = w.add_topic("/depth", "std_msgs/Float64").unwrap();
        for i in 0..2000 {
            w.write(id, T0 + i as f64 * 0.01, &float64(i as f64))
                .unwrap();
        }
        drop(w); // no finish: no index, and the open chunk (records past the last 16 KiB) is lost
        let mut bag = std::fs::read(&path).unwrap();
        let before = count(&path);
        let mut records = Vec::new();
        for i in before as u32..before as u32 + 10_000 {
            put_record(
                &mut records,
                &[
                    ("op", &[2]),
                    ("conn", &0u32.to_le_bytes()),
                    ("time", &ros_time(T0 + i as f64 * 0.01)),
                ],
                &(i as f64).to_le_bytes(),
            );
        }
        let (name, stream): (&str, Vec<u8>) = match c {
            BagCompression::Lz4 => ("lz4", lz4_frame(&records)),
            _ => ("none", records.clone()),
        };
        put_record(
            &mut bag,
            &[
                ("op", &[5]),
                ("compression", name.as_bytes()),
                ("size", &0u32.to_le_bytes()),
            ],
            &[],
        );
        bag.extend_from_slice(&stream[..stream.len() * 6 / 10]);
        std::fs::write(&path, &bag).unwrap();
        let log = Log::open(&path).unwrap();
        let got = read_all(&log);
        assert!(
            got.len() > before + 1000,
            "{c:?}: {} after {before}",
            got.len()
        );
        for (i, m) in got.iter().enumerate() {
            assert_eq!(m.value, float64(i as f64), "{c:?}");
        }
    }
}

fn count(path: &std::path::Path) -> usize {
    read_all(&Log::open(path).unwrap()).len()
}

fn float64(x: f64) -> hydrofit_logs::Value {
    hydrofit_logs::Value::Struct(vec![hydrofit_logs::Value::Float(x)])
}

fn ros_time(t: f64) -> Vec<u8> {
    let s = t.floor();
    let mut b = (s as u32).to_le_bytes().to_vec();
    b.extend((((t - s) * 1e9).round() as u32).to_le_bytes());
    b
}

fn put_record(out: &mut Vec<u8>, head: &[(&str, &[u8])], data: &[u8]) {
    let mut h = Vec::new();
    for (n, v) in head {
        h.extend(((n.len() + 1 + v.len()) as u32).to_le_bytes());
        h.extend(n.as_bytes());
        h.push(b'=');
        h.extend(*v);
    }
    out.extend((h.len() as u32).to_le_bytes());
    out.extend(h);
    out.extend((data.len() as u32).to_le_bytes());
    out.extend(data);
}

fn lz4_frame(data: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let info = lz4_flex::frame::FrameInfo::new().block_size(lz4_flex::frame::BlockSize::Max64KB);
    let mut e = lz4_flex::frame::FrameEncoder::with_frame_info(info, Vec::new());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

#[test]
fn a_message_of_another_type_is_an_error_naming_topic_time_and_offset() {
    for c in ALL {
        let path = tmp(&format!("wrongtype-{c:?}.bag"));
        let mut w = BagWriter::create(&path, c).unwrap();
        let id = w
            .add_topic("/pressure", "sensor_msgs/FluidPressure")
            .unwrap();
        let schema = w.schema(id).unwrap().clone();
        let good = hydrofit_logs::write::message(&schema, &[("fluid_pressure", 1e5)]).unwrap();
        w.write(id, T0, &good).unwrap();
        w.write_bytes(id, T0 + 1.0, &[0; 4]).unwrap(); // a std_msgs/Float32
        w.write(id, T0 + 2.0, &good).unwrap();
        w.finish().unwrap();
        let log = Log::open(&path).unwrap();
        let mut n = 0;
        let e = log
            .read(&[0], &mut |_| {
                n += 1;
                Ok(())
            })
            .unwrap_err();
        assert_eq!(n, 1);
        assert_eq!(e.path, path);
        assert!(e.offset.is_some());
        assert!(
            e.what.contains("/pressure") && e.what.contains("t = 1700000001.000000"),
            "{e}"
        );
        assert!(e.what.contains("field `header.stamp`"), "{e}");
    }
}

#[test]
fn a_changed_field_type_is_an_error_naming_the_topic() {
    for c in ALL {
        let path = tmp(&format!("changed-{c:?}.bag"));
        write_bag(&path, c, 1.0, None);
        let mut bytes = std::fs::read(&path).unwrap();
        let from = b"float64 fluid_pressure";
        let mut k = 0;
        while let Some(i) = find(&bytes[k..], from) {
            bytes[k + i + 5..k + i + 7].copy_from_slice(b"32");
            k += i + 1;
        }
        std::fs::write(&path, &bytes).unwrap();
        let log = Log::open(&path).unwrap();
        let t = log.topic("/pressure").unwrap();
        let e = log.read(&[t], &mut |_| Ok(())).unwrap_err();
        assert!(
            e.what.contains("/pressure") && e.what.contains("left over"),
            "{e}"
        );
        assert!(e.offset.is_some());
        // The other topics still read.
        let imu = log.topic("/imu").unwrap();
        log.read(&[imu], &mut |_| Ok(())).unwrap();
    }
}

#[test]
fn definitions_that_cannot_be_read_are_located_errors() {
    let path = tmp("baddef.bag");
    let mut w = BagWriter::create(&path, BagCompression::None).unwrap();
    let def = ros_types::ros1("std_msgs/Float64").unwrap();
    let id = w.add_connection("/x", "std_msgs/Float64", &def).unwrap();
    w.write(id, T0, &float64(1.0)).unwrap();
    w.finish().unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    let mut k = 0;
    while let Some(i) = find(&bytes[k..], b"float64 data") {
        bytes[k + i..k + i + 7].copy_from_slice(b"Unknown");
        k += i + 1;
    }
    std::fs::write(&path, &bytes).unwrap();
    let e = Log::open(&path).unwrap_err();
    assert!(
        e.what.contains("/x") && e.what.contains("unknown type `Unknown`"),
        "{e}"
    );
    assert!(e.offset.is_some());
}

/// A clock set back 2 s while recording (or a simulator restarted under sim time): the bag's
/// messages are read in time order, as `rosbag play` does, and the step is said in the notes
/// with its topic, its size and where it came; a bag whose clock only goes forward says nothing.
#[test]
fn a_clock_set_back_while_recording_is_said() {
    for (name, back) in [("set-back.bag", 2.0), ("forward.bag", 0.0)] {
        let path = tmp(name);
        let mut w = BagWriter::create(&path, BagCompression::Lz4).unwrap();
        w.set_chunk_size(4 * 1024);
        let id = w.add_topic("/depth", "std_msgs/Float64").unwrap();
        for i in 0..400 {
            let t = T0 + i as f64 * 0.01 - if i >= 200 { back } else { 0.0 };
            w.write(id, t, &float64(i as f64)).unwrap();
        }
        w.finish().unwrap();
        let log = Log::open(&path).unwrap();
        let notes = log.notes().join("\n");
        assert_eq!(read_all(&log).len(), 400);
        if back > 0.0 {
            assert!(
                notes.contains("steps back by 1.990 s on /depth at 1.990 s"),
                "{notes}"
            );
        } else {
            assert!(!notes.contains("steps back"), "{notes}");
        }
    }
}
