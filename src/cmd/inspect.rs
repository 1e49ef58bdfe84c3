//! `hydrofit inspect LOG`: what a vehicle's log holds, as `rosbag info` prints it: its
//! format and span, and per topic its type, count, rate, whether its messages carry header
//! stamps, and its fields by path (the paths `run.yaml`'s `log:` section names); then what a
//! run folder reading it with nothing mapped would read (the stack's defaults found).

use crate::pool::import::log_spec::Stack;
use hydrofit_logs::{Log, Options};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

pub fn run(path: &Path, fields: bool, msg_folders: &[PathBuf]) -> anyhow::Result<ExitCode> {
    let options = Options {
        msg_folders: msg_folders.to_vec(),
        ..Options::default()
    };
    let log = Log::open_with(path, &options)?;
    let start = log
        .topics
        .iter()
        .filter(|t| t.count > 0)
        .map(|t| t.first_s)
        .fold(f64::INFINITY, f64::min);
    let end = log
        .topics
        .iter()
        .map(|t| t.last_s)
        .fold(f64::NEG_INFINITY, f64::max);
    let total: u64 = log.topics.iter().map(|t| t.count).sum();
    // A rosbag2 folder is read through its storage file: show that file.
    crate::outln!("path:      {}", log.path.display());
    crate::outln!("format:    {}", log.format.name());
    if start.is_finite() {
        crate::outln!("start:     {start:.3} s (the log's clock)");
        crate::outln!("duration:  {:.3} s", end - start);
    }
    crate::outln!("messages:  {total}");
    crate::outln!("topics:");
    let width = log.topics.iter().map(|t| t.name.len()).max().unwrap_or(0);
    let twidth = log
        .topics
        .iter()
        .map(|t| t.type_name.len())
        .max()
        .unwrap_or(0);
    for t in &log.topics {
        let stamps = if t.schema.has_header() {
            "  header stamps"
        } else {
            ""
        };
        crate::outln!(
            "  {:width$}  {:twidth$}  {:>8} msgs  {:>8.2} Hz{stamps}",
            t.name,
            t.type_name,
            t.count,
            t.rate_hz()
        );
        if fields {
            for (p, ty) in t.schema.leaves() {
                crate::outln!("      {p}: {ty}");
            }
        }
    }
    let all: Vec<usize> = (0..log.topics.len()).collect();
    for f in log
        .files(&all)
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "msg"))
    {
        crate::outln!("definition: {}", f.display());
    }
    for n in log.notes() {
        crate::outln!("note: {n}");
    }
    unmapped(&log);
    Ok(ExitCode::SUCCESS)
}

/// What a run folder reading the log with nothing mapped would read: the stack's defaults
/// found, those missing, and whether the autopilot's velocity was aided.
fn unmapped(log: &Log) {
    let (stack, signals, notes) = crate::pool::import::from_log::unmapped(log);
    if stack == Stack::None {
        crate::outln!(
            "with nothing mapped: no stack's topics (name each signal in run.yaml's `log:`, docs/logs.md)"
        );
        return;
    }
    crate::outln!(
        "with nothing mapped (stack: {}; 8 thrusters until vehicle.thrusters says):",
        stack.name()
    );
    let width = signals.iter().map(|(k, _)| k.len()).max().unwrap_or(0);
    let twidth = signals
        .iter()
        .map(|(_, s)| s.topic.len())
        .max()
        .unwrap_or(0);
    for (signal, s) in &signals {
        let fields = match &s.quaternion {
            Some(q) => format!("quaternion {q}"),
            None => s.fields.join(", "),
        };
        crate::outln!("  {signal:width$}  {:twidth$}  {fields}", s.topic);
    }
    for n in notes {
        crate::outln!("  note: {n}");
    }
}
