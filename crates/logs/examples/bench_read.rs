//! Reading speed: writes a synthetic vehicle run of about `MB` megabytes (default 200) as a
//! ROS 1 bag with bz2 chunks, one with lz4 chunks, a zstd MCAP file and a ROS 2 SQLite bag
//! (`.db3`, Humble's tables) (mostly
//! `sensor_msgs/Imu` at 200 Hz, plus odometry, pressure, thruster and RC topics), then times
//! `Log::open` and reading the IMU topic whole.
//!
//! `cargo run --release --example bench_read -- [MB] [folder]` (files are removed afterwards).

use hydrofit_logs::write::{
    self, BagCompression, BagWriter, Db3Layout, Db3Writer, McapCompression, McapWriter,
};
use hydrofit_logs::{Log, LogError, Schema, Value};
use std::path::{Path, PathBuf};
use std::time::Instant;

const TOPICS: [(&str, &str); 5] = [
    ("/mavros/imu/data", "sensor_msgs/Imu"),
    ("/odom", "nav_msgs/Odometry"),
    ("/pressure", "sensor_msgs/FluidPressure"),
    ("/thrusters", "std_msgs/UInt16MultiArray"),
    ("/mavros/rc/out", "mavros_msgs/RCOut"),
];

/// Either writer, behind one interface.
enum Out {
    Bag(BagWriter, Vec<u32>),
    Mcap(McapWriter, Vec<u16>),
    Db3(Db3Writer, Vec<i64>),
}

impl Out {
    fn create(path: &Path) -> Result<(Out, Vec<Schema>), LogError> {
        let name = path.to_string_lossy();
        let mut schemas = Vec::new();
        let out = if name.ends_with(".db3") {
            let mut w = Db3Writer::create(path, Db3Layout::Humble)?;
            let mut ids = Vec::new();
            for (topic, ty) in TOPICS {
                ids.push(w.add_topic(topic, ty)?);
                schemas.push(
                    w.schema(*ids.last().expect("pushed"))
                        .expect("added")
                        .clone(),
                );
            }
            Out::Db3(w, ids)
        } else if name.ends_with(".mcap") {
            let mut w = McapWriter::create(path, McapCompression::Zstd)?;
            let mut ids = Vec::new();
            for (topic, ty) in TOPICS {
                ids.push(w.add_topic(topic, ty)?);
                schemas.push(
                    w.schema(*ids.last().expect("pushed"))
                        .expect("added")
                        .clone(),
                );
            }
            Out::Mcap(w, ids)
        } else {
            let c = if name.contains("bz2") {
                BagCompression::Bz2
            } else {
                BagCompression::Lz4
            };
            let mut w = BagWriter::create(path, c)?;
            let mut ids = Vec::new();
            for (topic, ty) in TOPICS {
                ids.push(w.add_topic(topic, ty)?);
                schemas.push(
                    w.schema(*ids.last().expect("pushed"))
                        .expect("added")
                        .clone(),
                );
            }
            Out::Bag(w, ids)
        };
        Ok((out, schemas))
    }

    fn write(&mut self, topic: usize, t: f64, v: &Value) -> Result<(), LogError> {
        match self {
            Out::Bag(w, ids) => w.write(ids[topic], t, v),
            Out::Mcap(w, ids) => w.write(ids[topic], t, v),
            Out::Db3(w, ids) => w.write(ids[topic], t, v),
        }
    }

    fn finish(self) -> Result<(), LogError> {
        match self {
            Out::Bag(w, _) => w.finish(),
            Out::Mcap(w, _) => w.finish(),
            Out::Db3(w, _) => w.finish(),
        }
    }
}

/// Sensor noise, so that the data compresses like real data rather than like zeros.
struct Noise(u64);

impl Noise {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}

/// Writes the run until the file reaches `bytes`; returns the number of IMU messages.
fn write_run(path: &Path, bytes: u64) -> Result<u64, Box<dyn std::error::Error>> {
    let (mut out, s) = Out::create(path)?;
    let mut noise = Noise(0x9e37_79b9_7f4a_7c15);
    let mut k = 0u64;
    loop {
        step(&mut out, &s, &mut noise, k)?;
        k += 1;
        if k.is_multiple_of(20_000) && std::fs::metadata(path)?.len() >= bytes {
            break;
        }
    }
    out.finish()?;
    Ok(k)
}

/// One 5 ms step: an IMU message, and the slower topics on their multiples.
fn step(
    out: &mut Out,
    s: &[Schema],
    noise: &mut Noise,
    k: u64,
) -> Result<(), Box<dyn std::error::Error>> {
    let t = 1_700_000_000.0 + k as f64 / 200.0;
    let mut n = || noise.next();
    let imu = write::message(
        &s[0],
        &[
            ("header.stamp", t - 0.003),
            ("orientation.x", n() * 0.1),
            ("orientation.y", n() * 0.1),
            ("orientation.z", n()),
            ("orientation.w", 0.9 + n() * 0.1),
            ("angular_velocity.x", n()),
            ("angular_velocity.y", n()),
            ("angular_velocity.z", n()),
            ("linear_acceleration.x", n()),
            ("linear_acceleration.y", n()),
            ("linear_acceleration.z", -9.81 + n()),
            ("orientation_covariance[0]", 1e-4),
            ("angular_velocity_covariance[0]", 1e-3),
            ("linear_acceleration_covariance[0]", 1e-2),
        ],
    )?;
    out.write(0, t, &imu)?;
    if k.is_multiple_of(4) {
        let odom = write::message(
            &s[1],
            &[
                ("header.stamp", t),
                ("pose.pose.position.x", n() * 10.0),
                ("pose.pose.position.z", -2.0 + n()),
                ("twist.twist.linear.x", n()),
                ("twist.twist.angular.z", n()),
            ],
        )?;
        out.write(1, t + 0.001, &odom)?;
        let mut thr = write::zero(&s[3]);
        let pwm: Vec<f64> = (0..8).map(|_| 1500.0 + (n() * 400.0).round()).collect();
        write::set_array(&s[3], &mut thr, "data", &pwm)?;
        out.write(3, t + 0.002, &thr)?;
    }
    if k.is_multiple_of(10) {
        let mut rc = write::message(&s[4], &[("header.stamp", t)])?;
        let pwm: Vec<f64> = (0..8).map(|_| 1500.0 + (n() * 400.0).round()).collect();
        write::set_array(&s[4], &mut rc, "channels", &pwm)?;
        out.write(4, t + 0.003, &rc)?;
    }
    if k.is_multiple_of(20) {
        let pressure = 120_000.0 + n() * 50.0;
        let p = write::message(&s[2], &[("header.stamp", t), ("fluid_pressure", pressure)])?;
        out.write(2, t + 0.004, &p)?;
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let mb: u64 = args.get(1).map_or(Ok(200), |a| a.parse())?;
    let dir = PathBuf::from(args.get(2).map_or("/tmp", |a| a.as_str()));
    println!("file             size MB  IMU msgs   write s   open s   read IMU s   IMU msg/s");
    for name in [
        "hydrofit-bench-bz2.bag",
        "hydrofit-bench-lz4.bag",
        "hydrofit-bench-zstd.mcap",
        "hydrofit-bench.db3",
    ] {
        let path = dir.join(name);
        let start = Instant::now();
        let n = write_run(&path, mb << 20)?;
        let write_s = start.elapsed().as_secs_f64();
        let size = std::fs::metadata(&path)?.len() as f64 / (1 << 20) as f64;
        let start = Instant::now();
        let log = Log::open(&path)?;
        let open_s = start.elapsed().as_secs_f64();
        let imu = log.topic(TOPICS[0].0).ok_or("no IMU topic")?;
        let sel = log.topics[imu].schema.select("linear_acceleration.z")?;
        let (mut count, mut sum) = (0u64, 0.0);
        let start = Instant::now();
        log.read(&[imu], &mut |m| {
            count += 1;
            sum += sel.get(&m.value).unwrap_or(0.0);
            Ok(())
        })?;
        let read_s = start.elapsed().as_secs_f64();
        assert_eq!(count, n);
        assert!((sum / count as f64 + 9.81).abs() < 0.01);
        let rate = count as f64 / read_s;
        println!("{name:24} {size:6.0} {n:9} {write_s:9.1} {open_s:8.2} {read_s:12.2} {rate:11.0}");
        drop(log);
        std::fs::remove_file(&path)?;
    }
    Ok(())
}
