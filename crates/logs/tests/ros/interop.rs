//! Files written by other implementations (Python `rosbags` (ROS 1 bags and a ROS 2 SQLite bag
//! folder), `mcap` + `mcap-ros2-support`, `mcap` with `rosbags`' ROS 1 serialization (a bag
//! converted to MCAP);
//! see tests/data/make_fixtures.py), and our files' shape as they expect it.

use hydrofit_logs::Log;
use std::path::Path;

/// Message i: stamp 1700000000 + i // 100 + (i % 100) * 0.01 s; two fields linear in i.
#[test]
fn files_other_writers_wrote_read_right() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let files = [
        ("py-none.bag", "angular_velocity.x", 0.5, "header.seq", 1.0),
        ("py-bz2.bag", "angular_velocity.x", 0.5, "header.seq", 1.0),
        ("py-lz4.bag", "angular_velocity.x", 0.5, "header.seq", 1.0),
        ("py-ros1.mcap", "angular_velocity.x", 0.5, "header.seq", 1.0),
        (
            "py-none.mcap",
            "twist.linear.x",
            0.25,
            "twist.angular.z",
            -0.5,
        ),
        (
            "py-zstd.mcap",
            "twist.linear.x",
            0.25,
            "twist.angular.z",
            -0.5,
        ),
        (
            "py-rosbag2",
            "twist.linear.x",
            0.25,
            "twist.angular.z",
            -0.5,
        ),
        (
            "py-lz4.mcap",
            "twist.linear.x",
            0.25,
            "twist.angular.z",
            -0.5,
        ),
    ];
    for (name, f1, k1, f2, k2) in files {
        let log = Log::open(&dir.join(name)).unwrap();
        let t = &log.topics[0];
        assert_eq!(t.count, 300, "{name}");
        let (a, b) = (t.schema.select(f1).unwrap(), t.schema.select(f2).unwrap());
        let mut i = 0;
        log.read(&[0], &mut |m| {
            let n = i as f64;
            assert_eq!(a.get(&m.value), Some(n * k1), "{name} {i}");
            assert_eq!(b.get(&m.value), Some(n * k2), "{name} {i}");
            let stamp = 1_700_000_000.0 + (i / 100) as f64 + (i % 100) as f64 * 0.01;
            assert!((m.stamp_s.unwrap() - stamp).abs() < 1e-6, "{name} {i}");
            assert!(
                m.log_time_s >= stamp && m.log_time_s - stamp < 1e-6,
                "{name} {i}"
            );
            i += 1;
            Ok(())
        })
        .unwrap();
        assert_eq!(i, 300);
    }
}
