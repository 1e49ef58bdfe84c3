//! Real ROS 1 bags of an underwater vehicle (bz2 and uncompressed chunks, std_msgs
//! multiarrays), read in place when the data folder is there. The values checked here were
//! cross-checked with the Python `rosbags` package.

use hydrofit_logs::{Log, Value};

/// The bags are not in this repository (their source has no licence): point
/// `HYDROFIT_EXJOBB_BAGS` at `ExjobbROV/simulink/Estimation/bag` of a clone of
/// github.com/MrEkelund/ExjobbROV to run these tests.
fn dir() -> Option<std::path::PathBuf> {
    std::env::var_os("HYDROFIT_EXJOBB_BAGS").map(Into::into)
}

#[test]
fn real_bags_read_whole_and_in_order() {
    let Some(Ok(entries)) = dir().map(std::fs::read_dir) else {
        eprintln!("skipped: set HYDROFIT_EXJOBB_BAGS to the ExjobbROV bag folder");
        return;
    };
    let mut bags = 0;
    for entry in entries {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "bag") {
            continue;
        }
        let log = Log::open(&path).unwrap_or_else(|e| panic!("{e}"));
        let all: Vec<usize> = (0..log.topics.len()).collect();
        let mut counts = vec![0u64; log.topics.len()];
        let mut last = f64::MIN;
        log.read(&all, &mut |m| {
            counts[m.topic] += 1;
            assert!(m.log_time_s >= last);
            last = m.log_time_s;
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
        for (t, n) in log.topics.iter().zip(counts) {
            assert_eq!(t.count, n, "{}: {}", path.display(), t.name);
        }
        bags += 1;
    }
    eprintln!("read {bags} real bags");
}

/// The n-th message of `topic`, as `rosbags` decodes it too.
fn nth(log: &Log, topic: &str, n: usize) -> (f64, Value) {
    let t = log.topic(topic).unwrap();
    let mut k = 0;
    let mut found = None;
    log.read(&[t], &mut |m| {
        if k == n {
            found = Some((m.log_time_s, m.value.clone()));
        }
        k += 1;
        Ok(())
    })
    .unwrap();
    found.unwrap()
}

#[test]
fn real_values_agree_with_rosbags() {
    let Some(path) = dir().map(|d| d.join("ExactLin_2016-05-25-09-17-38.bag")) else {
        eprintln!("skipped: set HYDROFIT_EXJOBB_BAGS to the ExjobbROV bag folder");
        return;
    };
    let log = Log::open(&path).unwrap();
    let t = &log.topics[log.topic("reference").unwrap()];
    assert_eq!(
        (t.type_name.as_str(), t.count),
        ("std_msgs/Float64MultiArray", 1552)
    );
    let data = |v: &Value| match v {
        Value::Struct(f) => f.last().unwrap().clone(),
        _ => panic!(),
    };
    let (time, v) = nth(&log, "rovio/thrusters", 100);
    assert!((time - 1_464_160_659.0 - 0.791_149_616).abs() < 1e-6);
    let want: Vec<Value> = [1718, 1304, 1396, 1592, 1389, 1500]
        .map(Value::UInt)
        .to_vec();
    assert_eq!(data(&v), Value::Array(want));
    let (_, v) = nth(&log, "rovio/imu/data", 0);
    let Value::Array(imu) = data(&v) else {
        panic!()
    };
    assert_eq!(imu[0], Value::Float(3_583_856.0));
    assert_eq!(imu[6], Value::Float(-9.665_150_642_395_02));
    let (_, v) = nth(&log, "rovio/water_pressure/data", 100);
    assert_eq!(v, Value::Struct(vec![Value::Float(9521.59375)]));
    let (_, v) = nth(&log, "sensor_fusion/states", 1);
    let Value::Array(states) = data(&v) else {
        panic!()
    };
    assert_eq!(states[9], Value::Float(0.789_923_798_230_883_9));
}
