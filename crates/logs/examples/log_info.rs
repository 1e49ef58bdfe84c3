//! Prints what a log holds, as `rosbag info` would: `cargo run --release --example log_info -- LOG`.

use hydrofit_logs::Log;
use std::path::Path;

fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: log_info LOG");
        std::process::exit(2);
    };
    let log = match Log::open(Path::new(&path)) {
        Ok(log) => log,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    println!("{}: {}", log.path.display(), log.format.name());
    for t in &log.topics {
        println!(
            "{:<28} {:>8} msgs  {:>12.6} .. {:>12.6} s  {:>7.2} Hz",
            t.name,
            t.count,
            t.first_s,
            t.last_s,
            t.rate_hz()
        );
    }
    for n in log.notes() {
        println!("note: {n}");
    }
}
