//! Prints one topic of a log as CSV (log time, then every numeric field):
//! `cargo run --release --example dump -- LOG TOPIC`.

use hydrofit_logs::{Log, LogError};
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 3 {
        eprintln!("usage: dump LOG TOPIC");
        std::process::exit(2);
    }
    if let Err(e) = dump(Path::new(&args[1]), &args[2]) {
        eprintln!("{e}");
        std::process::exit(1);
    }
}

fn dump(path: &Path, topic: &str) -> Result<(), LogError> {
    let log = Log::open(path)?;
    let Some(t) = log.topic(topic) else {
        let names: Vec<&str> = log.topics.iter().map(|t| t.name.as_str()).collect();
        return Err(LogError::new(
            path,
            format!("no topic {topic}; it has {}", names.join(", ")),
        ));
    };
    let schema = &log.topics[t].schema;
    let fields: Vec<_> = (schema.leaves().into_iter())
        .filter(|(_, ty)| ty != "string")
        .flat_map(|(p, _)| expand(&p))
        .filter_map(|p| schema.select(&p).ok())
        .collect();
    let names: Vec<&str> = fields.iter().map(|s| s.path.as_str()).collect();
    println!("time_s,{}", names.join(","));
    log.read(&[t], &mut |m| {
        let vals: Vec<String> = fields
            .iter()
            .map(|s| s.get(&m.value).map_or(String::new(), |x| x.to_string()))
            .collect();
        println!("{},{}", m.log_time_s, vals.join(","));
        Ok(())
    })
}

/// `a[0..3]` into `a[0]`, `a[1]`, `a[2]`; other paths as they are.
fn expand(path: &str) -> Vec<String> {
    let Some((head, rest)) = path.split_once("[0..") else {
        return vec![path.to_string()];
    };
    let n: usize = rest.trim_end_matches(']').parse().unwrap_or(0);
    (0..n).map(|i| format!("{head}[{i}]")).collect()
}
