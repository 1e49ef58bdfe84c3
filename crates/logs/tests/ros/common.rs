//! A synthetic vehicle run on every common message type plus one type with every primitive,
//! written with the crate's writers and compared with what the readers give back.

use hydrofit_logs::write::{self, BagCompression, BagWriter, McapCompression, McapWriter};
use hydrofit_logs::{Log, Message, Schema, Value};
use std::path::{Path, PathBuf};

/// A path in Cargo's temporary folder for integration tests (in the target folder; each run
/// overwrites the last run's files).
pub fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("hydrofit-logs");
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

/// (topic, type, rate Hz).
pub const TOPICS: &[(&str, &str, f64)] = &[
    ("/imu", "sensor_msgs/Imu", 200.0),
    ("/odom", "nav_msgs/Odometry", 50.0),
    ("/cmd_vel", "geometry_msgs/TwistStamped", 20.0),
    ("/wrench", "geometry_msgs/WrenchStamped", 20.0),
    ("/pressure", "sensor_msgs/FluidPressure", 10.0),
    ("/states", "std_msgs/Float64MultiArray", 50.0),
    ("/thrusters", "std_msgs/UInt16MultiArray", 50.0),
    ("/rc/out", "mavros_msgs/RCOut", 20.0),
    ("/rc/override", "mavros_msgs/OverrideRCIn", 20.0),
    ("/imu_raw", "std_msgs/Float32MultiArray", 100.0),
    ("/temp", "std_msgs/Float32", 1.0),
    ("/custom", "test_msgs/Everything", 5.0),
];

pub const SEP: &str =
    "\n================================================================================\n";

/// A type with every primitive, arrays of all kinds and a nested type (ROS 1 flavour).
pub fn custom_ros1() -> String {
    format!(
        "Header header\nbool flag\nint8 i8\nuint8 u8\nint16 i16\nuint16 u16\nint32 i32\n\
         uint32 u32\nint64 i64\nuint64 u64\nfloat32 f32\nfloat64 f64\nstring text\ntime when\n\
         duration took\nuint8[] raw\nbyte[4] quad\nstring[2] names\nItem[] items\nfloat64[] empty\
         {SEP}MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\
         {SEP}MSG: test_msgs/Item\nstring label\nint32[] values"
    )
}

/// The same in ROS 2 flavour (stamps are `builtin_interfaces` structs; bounded types).
pub fn custom_ros2() -> String {
    format!(
        "std_msgs/Header header\nbool flag\nint8 i8\nuint8 u8\nint16 i16\nuint16 u16\n\
         int32 i32\nuint32 u32\nint64 i64\nuint64 u64\nfloat32 f32\nfloat64 f64 1.5\n\
         string<=16 text\nbuiltin_interfaces/Time when\nbuiltin_interfaces/Duration took\n\
         uint8[] raw\nbyte[4] quad\nstring[2] names\nItem[<=8] items\nfloat64[] empty\
         {SEP}MSG: std_msgs/msg/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\
         {SEP}MSG: builtin_interfaces/msg/Time\nint32 sec\nuint32 nanosec\
         {SEP}MSG: builtin_interfaces/msg/Duration\nint32 sec\nuint32 nanosec\
         {SEP}MSG: test_msgs/msg/Item\nstring label\nint32[] values"
    )
}

/// One message sent: topic index in `TOPICS`, log time, value.
#[derive(Debug, Clone)]
pub struct Sent {
    pub topic: usize,
    pub time_s: f64,
    pub value: Value,
}

pub const T0: f64 = 1_700_000_000.0;

/// The run's messages, in writing order (the custom topic's times go back now and then, so
/// the readers must sort). `schemas[i]` is the writer's schema of `TOPICS[i]`.
pub fn run(schemas: &[Schema], seconds: f64) -> Vec<Sent> {
    let mut out = Vec::new();
    for (ti, &(_, _, hz)) in TOPICS.iter().enumerate() {
        let n = (seconds * hz) as usize;
        for i in 0..n {
            // Each topic at its own phase: no two times equal within a topic.
            let nominal = T0 + (i as f64 / hz) + ti as f64 * 1e-4;
            let late = ti == TOPICS.len() - 1 && i % 3 == 2;
            let t = if late { nominal - 0.3 } else { nominal };
            let value = message(ti, &schemas[ti], i, t);
            out.push((
                nominal,
                Sent {
                    topic: ti,
                    time_s: t,
                    value,
                },
            ));
        }
    }
    // Written in nominal order, as a recorder would see them.
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out.into_iter().map(|(_, s)| s).collect()
}

/// A number exact in `f32`, varying with `i`.
fn q(i: usize, k: usize) -> f64 {
    ((i * 7 + k * 3) % 64) as f64 * 0.25 - 8.0
}

fn message(ti: usize, s: &Schema, i: usize, t: f64) -> Value {
    let stamp = t - 0.002;
    let m = |pairs: &[(&str, f64)]| write::message(s, pairs).expect("paths exist");
    let arr = |mut v: Value, path: &str, xs: Vec<f64>| {
        write::set_array(s, &mut v, path, &xs).expect("array path");
        v
    };
    match TOPICS[ti].1 {
        "sensor_msgs/Imu" => m(&[
            ("header.stamp", stamp),
            ("orientation.w", 1.0),
            ("orientation_covariance[0]", 0.01),
            ("angular_velocity.x", q(i, 1)),
            ("angular_velocity.z", q(i, 2)),
            ("linear_acceleration.z", -9.8125 + q(i, 3) * 0.01),
        ]),
        "nav_msgs/Odometry" => m(&[
            ("header.stamp", stamp),
            ("pose.pose.position.x", i as f64 * 0.5),
            ("pose.pose.orientation.w", 1.0),
            ("pose.covariance[35]", 0.25),
            ("twist.twist.linear.x", q(i, 4)),
            ("twist.twist.angular.z", q(i, 5)),
        ]),
        "geometry_msgs/TwistStamped" => m(&[("header.stamp", stamp), ("twist.linear.x", q(i, 6))]),
        "geometry_msgs/WrenchStamped" => m(&[
            ("header.stamp", stamp),
            ("wrench.force.x", q(i, 7)),
            ("wrench.torque.z", q(i, 8)),
        ]),
        "sensor_msgs/FluidPressure" => m(&[
            ("header.stamp", stamp),
            ("fluid_pressure", 101_325.0 + q(i, 9)),
            ("variance", 4.0),
        ]),
        "std_msgs/Float64MultiArray" => {
            arr(m(&[]), "data", (0..12).map(|k| q(i, k) * 0.1).collect())
        }
        "std_msgs/UInt16MultiArray" => arr(
            m(&[]),
            "data",
            (0..6).map(|k| 1500.0 + q(i, k) * 10.0).collect(),
        ),
        "mavros_msgs/RCOut" => arr(
            m(&[("header.stamp", stamp)]),
            "channels",
            (0..8).map(|k| 1100.0 + (i + k) as f64).collect(),
        ),
        "mavros_msgs/OverrideRCIn" => arr(
            m(&[]),
            "channels",
            (0..18)
                .map(|k| if k < 8 { 1500.0 } else { 65535.0 })
                .collect(),
        ),
        "std_msgs/Float32MultiArray" => arr(m(&[]), "data", (0..10).map(|k| q(i, k)).collect()),
        "std_msgs/Float32" => m(&[("data", 12.5 + q(i, 0))]),
        _ => everything(s, i, stamp),
    }
}

/// The custom type's value: every field set, built from the schema so one function serves
/// both flavours (ROS 1 `time` is a float; ROS 2 time a struct).
fn everything(s: &Schema, i: usize, stamp: f64) -> Value {
    let mut v = write::zero(s);
    write::set(s, &mut v, "header.stamp", stamp).expect("stamp");
    let nums: [(&str, f64); 12] = [
        ("flag", (i % 2) as f64),
        ("i8", -100.0 + i as f64),
        ("u8", 200.0),
        ("i16", -30_000.0),
        ("u16", 60_000.0),
        ("i32", -2_000_000_000.0),
        ("u32", 4_000_000_000.0),
        ("i64", -9.0e15),
        ("u64", 1.8e16),
        ("f32", q(i, 1)),
        ("f64", 1.0 / 3.0),
        ("when", T0 + 0.5),
    ];
    for (p, x) in nums {
        write::set(s, &mut v, p, x).expect("number");
    }
    write::set(s, &mut v, "took", 2.25).expect("duration");
    let Value::Struct(f) = &mut v else {
        unreachable!()
    };
    let idx = |name: &str| s.fields.iter().position(|x| x.name == name).expect("field");
    f[idx("text")] = Value::Text(format!("run {i} ✓"));
    f[idx("raw")] = Value::Bytes((0..(i % 5) as u8).collect());
    f[idx("quad")] = Value::Bytes(vec![1, 2, 3, i as u8]);
    f[idx("names")] = Value::Array(vec![Value::Text("a".into()), Value::Text(String::new())]);
    let item = |k: usize| {
        Value::Struct(vec![
            Value::Text(format!("item{k}")),
            Value::Array((0..k).map(|x| Value::Int(x as i64 - 1)).collect()),
        ])
    };
    f[idx("items")] = Value::Array((0..(i % 3)).map(item).collect());
    v
}

/// Writes the run as a ROS 1 bag; returns what was sent.
pub fn write_bag(path: &Path, c: BagCompression, seconds: f64, chunk: Option<usize>) -> Vec<Sent> {
    write_bag_with(path, c, seconds, chunk, true)
}

/// Writes the run as a ROS 1 bag, finished (indexed) or not (as if recording stopped).
pub fn write_bag_with(
    path: &Path,
    c: BagCompression,
    seconds: f64,
    chunk: Option<usize>,
    finish: bool,
) -> Vec<Sent> {
    let mut w = BagWriter::create(path, c).expect("create");
    if let Some(n) = chunk {
        w.set_chunk_size(n);
    }
    let mut ids = Vec::new();
    for &(topic, ty, _) in TOPICS {
        let id = match ty {
            "test_msgs/Everything" => w.add_connection(topic, ty, &custom_ros1()),
            _ => w.add_topic(topic, ty),
        };
        ids.push(id.expect("connection"));
    }
    let schemas: Vec<Schema> = ids
        .iter()
        .map(|&id| w.schema(id).expect("schema").clone())
        .collect();
    let sent = run(&schemas, seconds);
    for m in &sent {
        w.write(ids[m.topic], m.time_s, &m.value).expect("write");
    }
    if finish {
        w.finish().expect("finish");
    }
    sent
}

/// Writes the run as an MCAP file; returns what was sent.
pub fn write_mcap(
    path: &Path,
    c: McapCompression,
    seconds: f64,
    chunk: Option<usize>,
) -> Vec<Sent> {
    write_mcap_with(path, c, seconds, chunk, true)
}

/// Writes the run as an MCAP file, finished (with its summary) or not.
pub fn write_mcap_with(
    path: &Path,
    c: McapCompression,
    seconds: f64,
    chunk: Option<usize>,
    finish: bool,
) -> Vec<Sent> {
    write_mcap_of(path, c, seconds, chunk, finish, false)
}

/// [`write_mcap_with`], its messages ROS 2's or (`ros1`) ROS 1's.
fn write_mcap_of(
    path: &Path,
    c: McapCompression,
    seconds: f64,
    chunk: Option<usize>,
    finish: bool,
    ros1: bool,
) -> Vec<Sent> {
    let mut w = McapWriter::create(path, c).expect("create");
    if let Some(n) = chunk {
        w.set_chunk_size(n);
    }
    let mut ids = Vec::new();
    for &(topic, ty, _) in TOPICS {
        let id = match (ty, ros1) {
            ("test_msgs/Everything", true) => w.add_ros1_channel(topic, ty, &custom_ros1()),
            ("test_msgs/Everything", false) => {
                w.add_channel(topic, "test_msgs/msg/Everything", &custom_ros2())
            }
            (_, true) => w.add_ros1_topic(topic, ty),
            (_, false) => w.add_topic(topic, ty),
        };
        ids.push(id.expect("channel"));
    }
    let schemas: Vec<Schema> = ids
        .iter()
        .map(|&id| w.schema(id).expect("schema").clone())
        .collect();
    let sent = run(&schemas, seconds);
    for m in &sent {
        w.write(ids[m.topic], m.time_s, &m.value).expect("write");
    }
    if finish {
        w.finish().expect("finish");
    }
    sent
}

/// Writes the run as a ROS 1 bag converted to MCAP (`ros1msg` schemas, ROS 1 messages, as
/// `mcap convert` writes them); returns what was sent.
pub fn write_ros1_mcap(path: &Path, c: McapCompression, seconds: f64) -> Vec<Sent> {
    write_mcap_of(path, c, seconds, None, true, true)
}

/// Every message of every topic of `log`.
pub fn read_all(log: &Log) -> Vec<Message> {
    let all: Vec<usize> = (0..log.topics.len()).collect();
    let mut out = Vec::new();
    log.read(&all, &mut |m| {
        out.push(m.clone());
        Ok(())
    })
    .expect("read");
    out
}

/// Values equal, floats to 1e-6 relative (times of 1.7e9 s carry 2e-7 s of rounding).
pub fn close(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Float(x), Value::Float(y)) => (x - y).abs() <= 1e-6 * x.abs().max(1.0),
        (Value::Array(x), Value::Array(y)) | (Value::Struct(x), Value::Struct(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(p, q)| close(p, q))
        }
        _ => a == b,
    }
}

/// Checks that `got` (read back, in time order) holds exactly `sent`, per topic in time
/// order, with the right stamps, and that the topic list agrees.
pub fn assert_same(log: &Log, got: &[Message], sent: &[Sent]) {
    assert!(
        got.windows(2).all(|w| w[0].log_time_s <= w[1].log_time_s),
        "not in time order"
    );
    assert_eq!(got.len(), sent.len());
    for (ti, &(name, _, _)) in TOPICS.iter().enumerate() {
        let mut want: Vec<&Sent> = sent.iter().filter(|m| m.topic == ti).collect();
        want.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        let Some(t) = log.topic(name) else {
            assert!(want.is_empty(), "no topic {name}");
            continue;
        };
        let have: Vec<&Message> = got.iter().filter(|m| m.topic == t).collect();
        let topic = &log.topics[t];
        assert_eq!(topic.count as usize, want.len(), "{name}");
        assert_eq!(have.len(), want.len(), "{name}");
        if let (Some(first), Some(last)) = (want.first(), want.last()) {
            assert!((topic.first_s - first.time_s).abs() < 1e-6, "{name}");
            assert!((topic.last_s - last.time_s).abs() < 1e-6, "{name}");
        }
        for (h, w) in have.iter().zip(&want) {
            assert!(
                (h.log_time_s - w.time_s).abs() < 1e-6,
                "{name}: {} vs {}",
                h.log_time_s,
                w.time_s
            );
            assert!(
                close(&h.value, &w.value),
                "{name} at {}:\n{:?}\n{:?}",
                w.time_s,
                h.value,
                w.value
            );
            let has_header = topic.schema.has_header();
            match h.stamp_s {
                Some(s) => assert!(
                    has_header && (s - (w.time_s - 0.002)).abs() < 1e-6,
                    "{name}"
                ),
                None => assert!(!has_header, "{name}: no stamp"),
            }
        }
    }
}
