//! Damaged logs, as a CSV importer is fuzzed: every log cut at many offsets and with bytes
//! flipped in a few hundred deterministic pseudo-random places. Nothing may panic or hang;
//! a log that opens reads back exactly the messages it counted; an error names the path and
//! a byte offset.

mod common;

use common::{Rng, TempFile};
use hydrofit_logs::dataflash::{self, Writer};
use hydrofit_logs::{Log, LogError, Topic, Value, tlog, ulog};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::time::{Duration, Instant};

type Reader = fn(&Path, Vec<u8>) -> Result<(usize, u64), LogError>;

/// Opens and reads every topic; returns (messages read, messages counted).
fn read_counted(
    topics: &[Topic],
    read: impl FnOnce(
        &[usize],
        &mut dyn FnMut(&hydrofit_logs::Message) -> Result<(), LogError>,
    ) -> Result<(), LogError>,
) -> Result<(usize, u64), LogError> {
    let all: Vec<usize> = (0..topics.len()).collect();
    let mut n = 0;
    read(&all, &mut |m| {
        let Value::Struct(fields) = &m.value else {
            panic!("a message is not a struct");
        };
        assert_eq!(
            fields.len(),
            topics[m.topic].schema.fields.len(),
            "value and schema differ"
        );
        n += 1;
        Ok(())
    })?;
    Ok((n, topics.iter().map(|t| t.count).sum()))
}

fn dataflash_reader(path: &Path, data: Vec<u8>) -> Result<(usize, u64), LogError> {
    let (bin, topics) = dataflash::Bin::open(path, data)?;
    read_counted(&topics, |w, each| bin.read(path, &topics, w, each))
}

fn tlog_reader(path: &Path, data: Vec<u8>) -> Result<(usize, u64), LogError> {
    let (t, topics) = tlog::Tlog::open(path, data)?;
    read_counted(&topics, |w, each| t.read(path, &topics, w, each))
}

fn ulog_reader(path: &Path, data: Vec<u8>) -> Result<(usize, u64), LogError> {
    let (u, topics) = ulog::Ulog::open(path, data)?;
    read_counted(&topics, |w, each| u.read(path, &topics, w, each))
}

/// Runs one damaged case: no panic, bounded time, errors with path and offset.
fn case(reader: Reader, path: &Path, data: Vec<u8>, what: &str) -> bool {
    let start = Instant::now();
    let r = catch_unwind(AssertUnwindSafe(|| reader(path, data)));
    let took = start.elapsed();
    assert!(took < Duration::from_secs(5), "{what}: took {took:?}");
    match r {
        Err(_) => panic!("{what}: panicked"),
        Ok(Ok((read, counted))) => {
            assert_eq!(read as u64, counted, "{what}: read differs from counted");
            true
        }
        Ok(Err(e)) => {
            assert_eq!(e.path, path, "{what}: {e}");
            assert!(e.offset.is_some(), "{what}: no offset in {e}");
            false
        }
    }
}

/// Cuts `data` at `cuts` offsets spread over it, and flips bytes in `flips` cases.
fn fuzz(reader: Reader, name: &str, data: &[u8], cuts: usize, flips: usize, seed: u64) {
    let path = Path::new(name);
    let mut opened = 0;
    for k in 0..=cuts {
        let at = data.len() * k / cuts;
        opened += case(
            reader,
            path,
            data[..at].to_vec(),
            &format!("{name} cut at {at}"),
        ) as usize;
    }
    let mut rng = Rng(seed);
    // HYDROFIT_FUZZ=N runs N times the flip cases (different ones) for a deeper search.
    let deeper = std::env::var("HYDROFIT_FUZZ")
        .ok()
        .and_then(|v| v.parse().ok());
    let flips = flips * deeper.unwrap_or(1usize);
    for k in 0..flips {
        let mut d = data.to_vec();
        // Half the cases hit the start, where the definitions are.
        let span = if k % 2 == 0 {
            data.len().min(4096)
        } else {
            data.len()
        };
        let places = 1 + rng.below(8);
        for _ in 0..places {
            let i = rng.below(span);
            d[i] ^= 1 + rng.below(255) as u8;
        }
        opened += case(
            reader,
            path,
            d,
            &format!("{name} flip case {k} (seed {seed})"),
        ) as usize;
    }
    println!(
        "{name}: {opened} of {} damaged copies still opened",
        cuts + 1 + flips
    );
    assert!(
        opened > (cuts + flips) / 2,
        "most damaged copies should still open"
    );
}

fn written_dataflash() -> Vec<u8> {
    let mut w = Writer::new();
    w.define("ATT", "QccCf", "TimeUS,Roll,Pitch,Yaw,Err")
        .unwrap();
    w.define("IMU", "QBffa", "TimeUS,I,GyrX,AccZ,Raw").unwrap();
    w.units("IMU", "s#Eo-", "F-00-").unwrap();
    w.define("MSG", "QZ", "TimeUS,Message").unwrap();
    let raw = Value::Array((0..32).map(Value::Int).collect());
    for k in 0..200u32 {
        let t = Value::UInt(k as u64 * 10_000);
        let x = Value::Float(k as f64 * 0.01);
        w.write(
            "ATT",
            &[t.clone(), x.clone(), x.clone(), x.clone(), x.clone()],
        )
        .unwrap();
        let inst = Value::UInt(k as u64 % 3);
        w.write("IMU", &[t.clone(), inst, x.clone(), x.clone(), raw.clone()])
            .unwrap();
        if k % 50 == 0 {
            w.write("MSG", &[t, Value::Text(format!("message {k}"))])
                .unwrap();
        }
    }
    w.into_bytes()
}

#[test]
fn fuzz_written_dataflash() {
    let data = written_dataflash();
    fuzz(dataflash_reader, "written.BIN", &data, 400, 300, 1);
}

#[test]
fn fuzz_small_bin() {
    let p = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/ardusub/small.BIN"
    ));
    let Ok(data) = std::fs::read(p) else {
        println!("note: {} is not here; skipping", p.display());
        return;
    };
    fuzz(dataflash_reader, "small.BIN", &data, 300, 300, 2);
}

#[test]
fn fuzz_written_tlog() {
    let data = common::written_tlog();
    fuzz(tlog_reader, "written.tlog", &data, 400, 300, 3);
}

#[test]
fn fuzz_small_tlog() {
    let p = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/ardusub/small.tlog"
    ));
    let Ok(data) = std::fs::read(p) else {
        println!("note: {} is not here; skipping", p.display());
        return;
    };
    fuzz(tlog_reader, "small.tlog", &data, 200, 200, 4);
}

#[test]
fn fuzz_px4_ulog() {
    let p = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/px4/sample_appended_multiple.ulg"
    ));
    let data = std::fs::read(p).unwrap();
    fuzz(ulog_reader, "appended.ulg", &data, 200, 300, 5);
}

/// Through `Log::open` and real files, including cuts shorter than any magic.
#[test]
fn fuzz_through_files() {
    let data = written_dataflash();
    for at in [0, 1, 2, 3, 50, 88, 89, 90, 500, data.len() - 1] {
        let f = TempFile::new(&format!("cut{at}.BIN"), &data[..at]);
        match catch_unwind(|| Log::open(&f.0).map(|log| log.notes())) {
            Err(_) => panic!("cut at {at}: panicked"),
            Ok(Ok(_)) => {}
            Ok(Err(e)) => {
                assert_eq!(e.path, f.0);
                assert!(e.offset.is_some(), "{e}");
            }
        }
    }
}

/// Inputs built to make a resynchronising scan slow: a megabyte of header bytes, of
/// records too long for the file, of plausible tlog starts. Each must end in well under a
/// second (a scan that went back over the data would take hours).
#[test]
fn adversarial_inputs_end_quickly() {
    let mb = 1 << 20;
    let mut long_fmt = Writer::new();
    long_fmt.raw(&[0xA3, 0x95, 0x80, 1, 255, b'L', b'O', b'N', b'G']);
    long_fmt.raw(&[0; 16 + 64]);
    let fmt_len = long_fmt.len();
    let cases: Vec<(&str, Vec<u8>, Reader)> = vec![
        ("a3.BIN", vec![0xA3; mb], dataflash_reader),
        ("a395.BIN", [0xA3, 0x95].repeat(mb / 2), dataflash_reader),
        (
            "fmt.BIN",
            [0xA3, 0x95, 0x80].repeat(mb / 3),
            dataflash_reader,
        ),
        (
            "long.BIN",
            [long_fmt.bytes(), &[0xA3, 0x95, 1].repeat(mb / 3)].concat(),
            dataflash_reader,
        ),
        (
            "tail.BIN",
            [long_fmt.bytes(), &[0xA3, 0x95, 1, 0].repeat(50)].concat(),
            dataflash_reader,
        ),
        ("fe.tlog", tlog_starts(mb, 0xFE), tlog_reader),
        ("fd.tlog", tlog_starts(mb, 0xFD), tlog_reader),
    ];
    for (name, data, reader) in cases {
        let start = Instant::now();
        case(reader, Path::new(name), data, name);
        assert!(
            start.elapsed() < Duration::from_secs(2),
            "{name}: {:?}",
            start.elapsed()
        );
    }
    assert!(fmt_len > 0);
}

/// Repeated `time FE/FD ff`: every 10 bytes a plausible start whose packet runs long.
fn tlog_starts(size: usize, stx: u8) -> Vec<u8> {
    let mut rec = 1_683_220_541_000_000u64.to_be_bytes().to_vec();
    rec.extend_from_slice(&[stx, 0xFF]);
    rec.repeat(size / rec.len())
}
