//! Reading speed of CSV logs: writes a synthetic IMU table of about `MB` megabytes (default
//! 200; `timestamp` in seconds and ten numbers per row, as a simulator or PlotJuggler writes
//! them), then times `Log::open` and reading it whole.
//!
//! `cargo run --release -p hydrofit-logs --example bench_csv -- [MB] [folder]` (the file is
//! removed afterwards).

use hydrofit_logs::Log;
use std::io::Write;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let mb: f64 = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(200.0);
    let folder = args
        .get(2)
        .map_or_else(std::env::temp_dir, std::path::PathBuf::from);
    let path = folder.join(format!("hydrofit-bench-{}.csv", std::process::id()));
    let mut f = std::io::BufWriter::new(std::fs::File::create(&path)?);
    writeln!(f, "timestamp,qx,qy,qz,qw,wx,wy,wz,ax,ay,az")?;
    let mut rows = 0u64;
    let mut written = 0usize;
    while (written as f64) < mb * 1e6 {
        let t = 100.0 + rows as f64 * 0.005;
        let s = (t * 0.7).sin();
        let line = format!(
            "{t:.6},{:.9},{:.9},{:.9},{:.9},{:.6},{:.6},{:.6},{:.5},{:.5},{:.5}\n",
            0.01 * s,
            0.02 * s,
            0.3 * s,
            0.95,
            0.1 * s,
            -0.05 * s,
            0.2 * s,
            0.3 * s,
            -0.1 * s,
            9.81 + 0.05 * s
        );
        written += line.len();
        f.write_all(line.as_bytes())?;
        rows += 1;
    }
    f.flush()?;
    drop(f);
    let size = std::fs::metadata(&path)?.len() as f64 / 1e6;
    let t0 = Instant::now();
    let log = Log::open(&path)?;
    let open = t0.elapsed().as_secs_f64();
    let az = log.topics[0].schema.select("az")?;
    let (t0, mut n, mut sum) = (Instant::now(), 0u64, 0.0);
    log.read(&[0], &mut |m| {
        sum += az.get(&m.value).unwrap_or(0.0);
        n += 1;
        Ok(())
    })?;
    let read = t0.elapsed().as_secs_f64();
    println!(
        "CSV table {size:.0} MB, {rows} rows: open {open:.2} s, read {read:.2} s ({n} messages, mean az {:.3})",
        sum / n.max(1) as f64
    );
    std::fs::remove_file(&path)?;
    Ok(())
}
