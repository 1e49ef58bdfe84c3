//! A test fixture: the twin's runs written as a vehicle would log them: a ROS 1 bag, a ROS 2 bag (MCAP or
//! SQLite `.db3`) or an ArduPilot DataFlash log, holding the same numbers as the run's CSV files, with the
//! `log:` section of `run.yaml` that maps them. Optionally the command as per-thruster PWM
//! through a thruster layout and curve (the wrench split over the thrusters by the
//! allocation's pseudo-inverse, each thrust through the inverse of the curve, rounded to whole
//! microseconds as an ESC command is logged). Written apart from the readers, through the log
//! crate's writers.

use anyhow::Context;
use hydrofit::core::model::thrusters::{Allocation, Command, Thrusters};
use hydrofit::pool::import::PoolRun;
use hydrofit::pool::import::actuators::Actuators;
use hydrofit::pool::import::csvlog::Log;
use hydrofit_logs::write::{
    BagCompression, BagWriter, Db3Layout, Db3Writer, McapCompression, McapWriter,
};
use std::path::Path;

mod encode;
use encode::{Ros1Mcap, write_dataflash, write_ros};

/// The formats the twin writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogFormat {
    Ros1Bag,
    Mcap,
    /// A ROS 1 bag converted to MCAP (`mcap convert`: `ros1msg` schemas, ROS 1 messages).
    McapRos1,
    /// A ROS 2 Humble SQLite bag (no definitions inside: the reader's built-in types).
    Db3,
    DataFlash,
    /// Topics exported by `rostopic echo -p`: a CSV per topic, in a folder beside the run's.
    TopicCsv,
    /// A simulator's tables: a CSV per topic with a `timestamp` column in seconds of its own
    /// clock and flat column names (`pose_pose_orientation_x`), in a folder beside the run's.
    PlainCsv,
}

impl LogFormat {
    pub fn file_name(self) -> &'static str {
        match self {
            LogFormat::Ros1Bag => "run.bag",
            LogFormat::Mcap => "run.mcap",
            LogFormat::McapRos1 => "run_ros1.mcap",
            LogFormat::Db3 => "run.db3",
            LogFormat::DataFlash => "run.BIN",
            LogFormat::TopicCsv => "topics",
            LogFormat::PlainCsv => "tables",
        }
    }
}

/// The Unix time the twin's runs start at (header stamps and receive times).
const EPOCH_S: f64 = 1.7e9;

/// One message to write: its stream, time and numbers by field.
pub(crate) struct Row {
    pub stream: &'static str,
    pub t: f64,
    pub numbers: Vec<f64>,
}

/// A stream of messages and how `run.yaml` maps it.
pub(crate) struct Stream {
    pub name: &'static str,
    pub ros_topic: &'static str,
    pub ros_type: &'static str,
    /// The ROS field of each number.
    pub ros_fields: Vec<String>,
    /// The DataFlash labels of each number (after TimeUS).
    df_labels: Vec<String>,
}

/// Writes `run` as a log of `format` into `dir` and returns the `log:` section of its
/// `run.yaml`. With `thrusters`, the command is logged as per-thruster PWM.
pub fn write(
    run: &PoolRun,
    dir: &Path,
    format: LogFormat,
    thrusters: Option<&Thrusters>,
) -> anyhow::Result<String> {
    let alloc = thrusters.map(Thrusters::allocation);
    let (streams, rows, yaml) = plan(run, alloc.as_ref(), format)?;
    let mut path = dir.join(format.file_name());
    let mut file = format.file_name().to_string();
    if matches!(format, LogFormat::TopicCsv | LogFormat::PlainCsv) {
        // Beside the run folder: a `nav.csv` inside it would be read as the run's own CSV.
        let name = dir.file_name().context("a run folder")?.to_string_lossy();
        file = format!("../{name}_{}", format.file_name());
        path = dir.join(&file);
    }
    match format {
        LogFormat::Ros1Bag => {
            let mut w = BagWriter::create(&path, BagCompression::Lz4)?;
            write_ros(&mut w, &streams, &rows)?;
            w.finish()?;
        }
        LogFormat::Mcap => {
            let mut w = McapWriter::create(&path, McapCompression::Zstd)?;
            write_ros(&mut w, &streams, &rows)?;
            w.finish()?;
        }
        LogFormat::McapRos1 => {
            let mut w = Ros1Mcap(McapWriter::create(&path, McapCompression::Zstd)?);
            write_ros(&mut w, &streams, &rows)?;
            w.0.finish()?;
        }
        LogFormat::Db3 => {
            let mut w = Db3Writer::create(&path, Db3Layout::Humble)?;
            write_ros(&mut w, &streams, &rows)?;
            w.finish()?;
        }
        LogFormat::DataFlash => write_dataflash(&path, &streams, &rows)?,
        LogFormat::TopicCsv => crate::topic_csv_writer::write(&path, &streams, &rows, EPOCH_S)?,
        LogFormat::PlainCsv => crate::topic_csv_writer::write_plain(&path, &streams, &rows)?,
    }
    Ok(format!("log:\n  file: {file}\n  stack: none\n{yaml}"))
}

/// The streams, their rows and the mapping, from the run's logs.
fn plan(
    run: &PoolRun,
    alloc: Option<&Allocation>,
    format: LogFormat,
) -> anyhow::Result<(Vec<Stream>, Vec<Row>, String)> {
    let mut streams = Vec::new();
    let mut rows = Vec::new();
    let mut yaml = String::new();
    // A fin-steered run without thrust.csv logs its actuators alone.
    if run.force_logged || run.actuators.is_none() {
        command(run, alloc, format, &mut streams, &mut rows, &mut yaml)?;
    }
    if let Some(a) = &run.actuators {
        actuators(a, format, &mut streams, &mut rows, &mut yaml);
    }
    if let Some(l) = &run.uwb {
        let s = Stream {
            name: "position",
            ros_topic: "/uwb",
            ros_type: "nav_msgs/Odometry",
            ros_fields: ["x", "y", "z"]
                .iter()
                .map(|c| format!("pose.pose.position.{c}"))
                .collect(),
            df_labels: ["X", "Y", "Z"].map(String::from).to_vec(),
        };
        push_rows(&s, l, &[0, 1, 2], &mut rows);
        yaml += &mapping(&s, format, &[0, 1, 2], "");
        streams.push(s);
    }
    if let Some(l) = &run.sonar {
        let s = Stream {
            name: "sonar",
            ros_topic: "/sonar",
            ros_type: "std_msgs/Float64MultiArray",
            ros_fields: vec!["data[0]".into(), "data[1]".into()],
            df_labels: vec!["X".into(), "Y".into()],
        };
        push_rows(&s, l, &[0, 1], &mut rows);
        yaml += &mapping(&s, format, &[0, 1], "");
        streams.push(s);
    }
    if let Some(l) = &run.imu {
        imu(l, format, &mut streams, &mut rows, &mut yaml);
    }
    if let Some(l) = &run.depth {
        let s = Stream {
            name: "depth",
            ros_topic: "/depth",
            ros_type: "sensor_msgs/FluidPressure",
            ros_fields: vec!["fluid_pressure".into()],
            df_labels: vec!["Press".into()],
        };
        // Gauge pressure of a 1000 kg/m^3 pool, as a pressure sensor logs it.
        for (k, &t) in l.t.iter().enumerate() {
            rows.push(Row {
                stream: s.name,
                t,
                numbers: vec![l.cols[0][k] * 1000.0 * 9.80665],
            });
        }
        yaml += &mapping(&s, format, &[0], ", unit: pa");
        streams.push(s);
    }
    if let Some(l) = &run.nav {
        nav(l, format, &mut streams, &mut rows, &mut yaml);
    }
    rows.sort_by(|a, b| a.t.total_cmp(&b.t));
    Ok((streams, rows, yaml))
}

/// The command: the wrench as logged, or per-thruster PWM.
fn command(
    run: &PoolRun,
    alloc: Option<&Allocation>,
    format: LogFormat,
    streams: &mut Vec<Stream>,
    rows: &mut Vec<Row>,
    yaml: &mut String,
) -> anyhow::Result<()> {
    let l = &run.thrust;
    let Some(a) = alloc else {
        // THRUST's columns: X, Y, Z, N, K, M; the wrench message's order X, Y, Z, K, M, N.
        let s = Stream {
            name: "wrench",
            ros_topic: "/wrench",
            ros_type: "geometry_msgs/WrenchStamped",
            ros_fields: [
                "force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z",
            ]
            .iter()
            .map(|f| format!("wrench.{f}"))
            .collect(),
            df_labels: ["X", "Y", "Z", "K", "M", "N"].map(String::from).to_vec(),
        };
        push_rows(&s, l, &[0, 1, 2, 4, 5, 3], rows);
        for r in rows.iter_mut().filter(|r| r.stream == "wrench") {
            // A moment the log lacks was not commanded.
            r.numbers
                .iter_mut()
                .for_each(|x| *x = if x.is_nan() { 0.0 } else { *x });
        }
        // A vehicle commanded in surge, sway, heave and yaw logs X, Y, Z, N only.
        let idx: &[usize] = if l.has(4) || l.has(5) {
            &[0, 1, 2, 3, 4, 5]
        } else {
            &[0, 1, 2, 5]
        };
        *yaml += &mapping(&s, format, idx, "");
        streams.push(s);
        return Ok(());
    };
    let n = a.units.len();
    let s = Stream {
        name: "command",
        ros_topic: "/thrusters",
        ros_type: "std_msgs/UInt16MultiArray",
        ros_fields: (0..n).map(|k| format!("data[{k}]")).collect(),
        df_labels: (1..=n).map(|k| format!("C{k}")).collect(),
    };
    for (k, &t) in l.t.iter().enumerate() {
        let col = |c: usize| if l.has(c) { l.cols[c][k] } else { 0.0 };
        let tau = [col(0), col(1), col(2), col(4), col(5), col(3)];
        rows.push(Row {
            stream: s.name,
            t,
            numbers: pwm(a, &tau)?,
        });
    }
    *yaml += &mapping(&s, format, &(0..n).collect::<Vec<_>>(), "");
    streams.push(s);
    Ok(())
}

/// Whole-microsecond PWM commands whose thrusts give `tau` through the allocation: the
/// minimum-norm thrusts f = B^T (B B^T)^+ tau, each through the inverse of the curve (the
/// thrusts themselves for commands in newtons).
pub fn pwm(a: &Allocation, tau: &[f64; 6]) -> anyhow::Result<Vec<f64>> {
    let n = a.columns.len();
    let b = nalgebra::DMatrix::from_fn(6, n, |i, j| a.columns[j][i]);
    let pinv = b
        .clone()
        .pseudo_inverse(1e-9)
        .map_err(|e| anyhow::anyhow!("the allocation has no pseudo-inverse: {e}"))?;
    let f = pinv * nalgebra::DVector::from_column_slice(tau);
    if a.command_kind() == Command::Newtons {
        return Ok(f.iter().copied().collect());
    }
    Ok(f.iter().map(|&fi| inverse_thrust(a, fi).round()).collect())
}

/// The PWM at which the curve gives thrust `f` (bisection on the monotone curve; the dead
/// band's middle for zero).
fn inverse_thrust(a: &Allocation, f: f64) -> f64 {
    if f == 0.0 {
        return 1500.0;
    }
    let (mut lo, mut hi) = (1100.0, 1900.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if a.thrust(mid) < f {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// A fin-steered vehicle's actuator commands, each in the unit its CSV column had (degrees,
/// rpm), mapped with those columns.
fn actuators(
    a: &Actuators,
    format: LogFormat,
    streams: &mut Vec<Stream>,
    rows: &mut Vec<Row>,
    yaml: &mut String,
) {
    let n = a.names.len();
    let s = Stream {
        name: "actuators",
        ros_topic: "/actuators",
        ros_type: "std_msgs/Float64MultiArray",
        ros_fields: (0..n).map(|k| format!("data[{k}]")).collect(),
        df_labels: (0..n).map(|k| format!("A{k}")).collect(),
    };
    for (k, &t) in a.log.t.iter().enumerate() {
        rows.push(Row {
            stream: s.name,
            t,
            numbers: (0..n).map(|j| a.log.cols[j][k] / a.factors[j]).collect(),
        });
    }
    let columns: Vec<String> = (a.names.iter().zip(&a.units))
        .map(|(name, unit)| format!("{name}{unit}"))
        .collect();
    let extra = format!(", columns: [{}]", columns.join(", "));
    *yaml += &mapping(&s, format, &(0..n).collect::<Vec<_>>(), &extra);
    streams.push(s);
}

/// The IMU: attitude as a quaternion (FRD in NED), rates and specific force.
fn imu(
    l: &Log,
    format: LogFormat,
    streams: &mut Vec<Stream>,
    rows: &mut Vec<Row>,
    yaml: &mut String,
) {
    let ros = [
        "orientation.x",
        "orientation.y",
        "orientation.z",
        "orientation.w",
    ]
    .into_iter()
    .chain([
        "angular_velocity.x",
        "angular_velocity.y",
        "angular_velocity.z",
    ])
    .chain([
        "linear_acceleration.x",
        "linear_acceleration.y",
        "linear_acceleration.z",
    ]);
    let s = Stream {
        name: "imu",
        ros_topic: "/imu",
        ros_type: "sensor_msgs/Imu",
        ros_fields: ros.map(String::from).collect(),
        df_labels: [
            "Roll", "Pitch", "Yaw", "GyrX", "GyrY", "GyrZ", "AccX", "AccY", "AccZ",
        ]
        .map(String::from)
        .to_vec(),
    };
    for (k, &t) in l.t.iter().enumerate() {
        let c = |j: usize| l.cols[j][k];
        let numbers = match format {
            LogFormat::DataFlash => (0..9).map(c).collect(),
            _ => {
                let q = quaternion([c(0), c(1), c(2)]);
                q.into_iter().chain((3..9).map(c)).collect()
            }
        };
        rows.push(Row {
            stream: s.name,
            t,
            numbers,
        });
    }
    let ros = format != LogFormat::DataFlash;
    let topic = topic_of(&s, format);
    if l.has(0) {
        *yaml += &if format == LogFormat::PlainCsv {
            // A table's quaternion: four flat columns x, y, z, w.
            let q = fields_of(&s, format, &[0, 1, 2, 3]);
            field_map("attitude", &topic, &q, ", frame: ned")
        } else if ros {
            format!("  attitude: {{topic: {topic}, quaternion: orientation, frame: ned}}\n")
        } else {
            field_map("attitude", &topic, &s.df_labels[0..3], "")
        };
    }
    let (r, a) = if ros {
        ([4, 5, 6], [7, 8, 9])
    } else {
        ([3, 4, 5], [6, 7, 8])
    };
    if l.has(3) {
        *yaml += &field_map("rates", &topic, &fields_of(&s, format, &r), "");
    }
    if l.has(6) {
        *yaml += &field_map("acceleration", &topic, &fields_of(&s, format, &a), "");
    }
    streams.push(s);
}

/// The navigation log: body velocity, with the AHRS's attitude and rates where it has them.
fn nav(
    l: &Log,
    format: LogFormat,
    streams: &mut Vec<Stream>,
    rows: &mut Vec<Row>,
    yaml: &mut String,
) {
    let ros: Vec<String> = [
        "twist.twist.linear.x",
        "twist.twist.linear.y",
        "twist.twist.linear.z",
    ]
    .into_iter()
    .chain([
        "pose.pose.orientation.x",
        "pose.pose.orientation.y",
        "pose.pose.orientation.z",
        "pose.pose.orientation.w",
    ])
    .chain([
        "twist.twist.angular.x",
        "twist.twist.angular.y",
        "twist.twist.angular.z",
    ])
    .map(String::from)
    .collect();
    let s = Stream {
        name: "velocity",
        ros_topic: "/nav",
        ros_type: "nav_msgs/Odometry",
        ros_fields: ros,
        df_labels: ["U", "V", "W", "Roll", "Pitch", "Yaw", "P", "Q", "R"]
            .map(String::from)
            .to_vec(),
    };
    for (k, &t) in l.t.iter().enumerate() {
        let c = |j: usize| l.cols[j][k];
        let numbers = match format {
            LogFormat::DataFlash => (0..9).map(c).collect(),
            _ => (0..3)
                .map(c)
                .chain(quaternion([c(3), c(4), c(5)]))
                .chain((6..9).map(c))
                .collect(),
        };
        rows.push(Row {
            stream: s.name,
            t,
            numbers,
        });
    }
    let ros = format != LogFormat::DataFlash;
    let topic = topic_of(&s, format);
    let fields = |a: usize, b: usize| fields_of(&s, format, &(a..b).collect::<Vec<_>>());
    *yaml += &field_map("velocity", &topic, &fields(0, 3), "");
    if l.has(3) {
        *yaml += &if format == LogFormat::PlainCsv {
            field_map("attitude", &topic, &fields(3, 7), ", frame: ned")
        } else if ros {
            format!(
                "  attitude: {{topic: {topic}, quaternion: pose.pose.orientation, frame: ned}}\n"
            )
        } else {
            field_map("attitude", &topic, &fields(3, 6), "")
        };
    }
    if l.has(6) {
        let (a, b) = if ros { (7, 10) } else { (6, 9) };
        *yaml += &field_map("rates", &topic, &fields(a, b), "");
    }
    streams.push(s);
}

/// The quaternion (x, y, z, w) of roll, pitch, yaw (zyx; FRD in NED).
fn quaternion([phi, theta, psi]: [f64; 3]) -> [f64; 4] {
    let (sr, cr) = (phi / 2.0).sin_cos();
    let (sp, cp) = (theta / 2.0).sin_cos();
    let (sy, cy) = (psi / 2.0).sin_cos();
    [
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    ]
}

fn push_rows(s: &Stream, l: &Log, cols: &[usize], rows: &mut Vec<Row>) {
    for (k, &t) in l.t.iter().enumerate() {
        rows.push(Row {
            stream: s.name,
            t,
            numbers: cols.iter().map(|&c| l.cols[c][k]).collect(),
        });
    }
}

/// The topic (ROS) or message name (DataFlash) of a stream.
fn topic_of(s: &Stream, format: LogFormat) -> String {
    match format {
        LogFormat::DataFlash => df_name(s.name).to_string(),
        _ => s.ros_topic.to_string(),
    }
}

/// The four-letter DataFlash name of a stream.
fn df_name(stream: &str) -> &'static str {
    match stream {
        "wrench" => "WRN",
        "command" => "RCOU",
        "position" => "UWB",
        "sonar" => "SNR",
        "imu" => "IMU",
        "depth" => "DPTH",
        "actuators" => "ACT",
        _ => "NAV",
    }
}

/// The `run.yaml` line mapping signal `s` (its numbers `idx`).
fn mapping(s: &Stream, format: LogFormat, idx: &[usize], extra: &str) -> String {
    field_map(
        s.name,
        &topic_of(s, format),
        &fields_of(s, format, idx),
        extra,
    )
}

/// The names of numbers `idx` of stream `s` in a log of `format`.
fn fields_of(s: &Stream, format: LogFormat, idx: &[usize]) -> Vec<String> {
    idx.iter()
        .map(|&i| match format {
            LogFormat::DataFlash => s.df_labels[i].clone(),
            // `rostopic echo -p` writes an array's elements as `data0`, `data1`.
            LogFormat::TopicCsv => s.ros_fields[i].replace(['[', ']'], ""),
            LogFormat::PlainCsv => crate::topic_csv_writer::flat(&s.ros_fields[i]),
            _ => s.ros_fields[i].clone(),
        })
        .collect()
}

fn field_map(signal: &str, topic: &str, fields: &[String], extra: &str) -> String {
    let f: Vec<String> = fields.iter().map(|f| format!("\"{f}\"")).collect();
    format!(
        "  {signal}: {{topic: {topic}, fields: [{}]{extra}}}\n",
        f.join(", ")
    )
}
