//! Writes a DataFlash log of about 200 MB (ArduSub-like rates and types), then times
//! `Log::open` and reading it: `cargo run --release --example bench_dataflash [MB] [PATH]`.

use hydrofit_logs::Log;
use hydrofit_logs::dataflash::Writer;
use std::path::Path;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let mb: usize = args.get(1).map_or(Ok(200), |a| a.parse())?;
    let default = std::env::temp_dir().join("hydrofit-bench.BIN");
    let path = args.get(2).map_or(default, |p| p.into());

    let t = Instant::now();
    let bytes = generate(mb << 20)?;
    std::fs::write(&path, &bytes)?;
    println!(
        "wrote {} ({:.0} MB) in {:.2?}",
        path.display(),
        bytes.len() as f64 / 1e6,
        t.elapsed()
    );
    drop(bytes);

    let t = Instant::now();
    let log = Log::open(&path)?;
    let opened = t.elapsed();
    let n: u64 = log.topics.iter().map(|t| t.count).sum();
    println!(
        "open: {opened:.2?} ({n} messages, {} topics)",
        log.topics.len()
    );

    let att = log.topic("ATT").ok_or("no ATT")?;
    let roll = log.topics[att].schema.select("Roll")?;
    let t = Instant::now();
    let mut sum = 0.0;
    log.read(&[att], &mut |m| {
        sum += roll.get(&m.value).unwrap_or(0.0);
        Ok(())
    })?;
    println!("read ATT only: {:.2?} (sum of Roll {sum:.1})", t.elapsed());

    let all: Vec<usize> = (0..log.topics.len()).collect();
    let t = Instant::now();
    let mut read = 0u64;
    log.read(&all, &mut |_| {
        read += 1;
        Ok(())
    })?;
    println!("read all {read} messages: {:.2?}", t.elapsed());
    remove(&path);
    Ok(())
}

fn remove(path: &Path) {
    if std::env::args().nth(2).is_none() {
        let _ = std::fs::remove_file(path);
    }
}

/// The types written, as ArduSub 4 defines them: name, format, labels, FMTU units and
/// multipliers ("" for none).
const TYPES: [(&str, &str, &str, &str, &str); 6] = [
    (
        "ATT",
        "QccccCCCCB",
        "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw,AEKF",
        "",
        "",
    ),
    (
        "IMU",
        "QBffffffIIfBBHH",
        "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz",
        "s#EEEooo--O--zz",
        "F-000000-----00",
    ),
    (
        "BARO",
        "QBffcfIffB",
        "TimeUS,I,Alt,Press,Temp,CRt,SMS,Offset,GndTemp,Health",
        "s#mPOnsmO-",
        "F-00B0C?0-",
    ),
    (
        "RCOU",
        "QHHHHHHHHHHHHHH",
        "TimeUS,C1,C2,C3,C4,C5,C6,C7,C8,C9,C10,C11,C12,C13,C14",
        "",
        "",
    ),
    (
        "CTUN",
        "Qfffffffccfhh",
        "TimeUS,ThI,ABst,ThO,ThH,DAlt,Alt,BAlt,DSAlt,SAlt,TAlt,DCRt,CRt",
        "",
        "",
    ),
    (
        "XKF1",
        "QBccCfffffffccce",
        "TimeUS,C,Roll,Pitch,Yaw,VN,VE,VD,dPD,PN,PE,PD,GX,GY,GZ,OH",
        "s#ddhnnnnmmmkkkm",
        "F-BBB0000000BBBB",
    ),
];

/// ArduSub-like: per 100 ms step ATT, CTUN, RCOU, two BARO, XKF1 and four IMU records.
fn generate(size: usize) -> Result<Vec<u8>, String> {
    let mut w = Writer::new();
    for (name, format, labels, units, mults) in TYPES {
        w.define(name, format, labels)?;
        if !units.is_empty() {
            w.units(name, units, mults)?;
        }
    }
    let mut k = 0u64;
    while w.len() < size {
        step(&mut w, k)?;
        k += 1;
    }
    Ok(w.into_bytes())
}

/// One 100 ms step of records at `TimeUS = k * 1e5`.
fn step(w: &mut Writer, k: u64) -> Result<(), String> {
    let t = (k * 100_000) as f64;
    let x = (k % 1800) as f64 * 0.1;
    w.write("ATT", &[t, x, x, -x, -x, 180.0, 180.0, 0.0, 0.02, 3.0])?;
    let ctun = [0.5, 1.0, 0.5, 0.5, -x, -x, -x, -x, -x, 0.0, 12.0, 11.0];
    w.write("CTUN", &[&[t + 5.0][..], &ctun].concat())?;
    let rc: Vec<f64> = (0..14).map(|c| 1500.0 + c as f64).collect();
    w.write("RCOU", &[&[t + 7.0][..], &rc].concat())?;
    for i in 0..2 {
        let baro = [-x, 101_325.0 + x, 18.5, 0.01, t / 1e3, 0.0, 18.0, 1.0];
        w.write("BARO", &[&[t + 9.0, i as f64][..], &baro].concat())?;
    }
    let xkf1 = [
        x, -x, 180.0, 0.1, 0.2, 0.3, 0.0, 1.0, 2.0, -x, 0.01, 0.02, 0.03, 0.0,
    ];
    w.write("XKF1", &[&[t + 11.0, 0.0][..], &xkf1].concat())?;
    let imu = [
        0.01, 0.02, 0.03, 0.1, 0.2, -9.8, 0.0, 0.0, 35.0, 1.0, 1.0, 1000.0, 1000.0,
    ];
    for j in 0..4 {
        let ti = t + 13.0 + j as f64 * 25_000.0;
        w.write("IMU", &[&[ti, (j % 2) as f64][..], &imu].concat())?;
    }
    Ok(())
}
