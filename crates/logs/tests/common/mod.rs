//! Helpers shared by the integration tests: temporary files, a deterministic random source,
//! and reading every message of a log.

#![allow(dead_code)]

use hydrofit_logs::{Log, LogError, Value};
use std::path::{Path, PathBuf};

/// A path in the temporary folder, unique to this process and `name`.
pub fn temp_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("hydrofit-logs-{}-{name}", std::process::id()))
}

/// Writes `bytes` to a temporary file named `name`, removed when the guard drops.
pub struct TempFile(pub PathBuf);

impl TempFile {
    pub fn new(name: &str, bytes: &[u8]) -> TempFile {
        let p = temp_path(name);
        std::fs::write(&p, bytes).expect("write temp file");
        TempFile(p)
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// SplitMix64: a small deterministic random source, so a fuzz failure can be replayed.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Every message of every topic, as (topic name, time, value).
pub fn read_all(log: &Log) -> Result<Vec<(String, f64, Value)>, LogError> {
    let all: Vec<usize> = (0..log.topics.len()).collect();
    let mut out = Vec::new();
    log.read(&all, &mut |m| {
        out.push((
            log.topics[m.topic].name.clone(),
            m.log_time_s,
            m.value.clone(),
        ));
        Ok(())
    })?;
    Ok(out)
}

/// Field `path` of `v` in `topic`'s schema.
pub fn get(log: &Log, topic: &str, v: &Value, path: &str) -> f64 {
    let t = log
        .topic(topic)
        .unwrap_or_else(|| panic!("no topic {topic}"));
    let sel = log.topics[t].schema.select(path).expect("field");
    sel.get(v).unwrap_or(f64::NAN)
}

/// Opens a log, or says why not.
pub fn open(path: &Path) -> Log {
    Log::open(path).unwrap_or_else(|e| panic!("{e}"))
}

/// A tlog of a few hundred packets, MAVLink 1 and 2, from two senders of HEARTBEAT.
pub fn written_tlog() -> Vec<u8> {
    use hydrofit_logs::tlog::Writer;
    let mut w = Writer::new(true);
    let t0 = 1_683_220_541_000_000u64;
    for k in 0..150u64 {
        let t = t0 + k * 50_000;
        let x = k as f64 * 0.01;
        w.mavlink2 = k % 3 != 0;
        w.write(t, (1, 1), "ATTITUDE", &[k as f64, x, -x, x, 0.0, 0.0, 0.0])
            .unwrap();
        let servo: Vec<f64> = (0..18)
            .map(|i| if i == 1 { 0.0 } else { 1500.0 + k as f64 })
            .collect();
        w.write(t + 1, (1, 1), "SERVO_OUTPUT_RAW", &servo).unwrap();
        let name = Value::Text("CamTilt".into());
        w.write(
            t + 2,
            (1, 1),
            "NAMED_VALUE_FLOAT",
            &[Value::UInt(k), name, Value::Float(x)],
        )
        .unwrap();
        if k % 10 == 0 {
            let hb = [6.0, 8.0, 0.0, 0.0, 4.0, 3.0];
            w.write(t + 3, (1, 1), "HEARTBEAT", &hb).unwrap();
            w.write(t + 4, (255, 190), "HEARTBEAT", &hb).unwrap();
        }
    }
    w.into_bytes()
}
