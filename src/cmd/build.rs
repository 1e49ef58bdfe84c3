//! `hydrofit build`: take the lock, recover from any killed build, run what is stale.

use crate::core::progress::Progress;
use crate::pipeline::executor::{self, Options, Summary};
use crate::pipeline::{Plan, STATE_DIR, lock};
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

/// How `build` was asked to run.
pub struct Flags {
    pub jobs: Option<usize>,
    /// Say why each instance runs.
    pub explain: bool,
    /// Stop at a damaged cache object instead of rebuilding it.
    pub strict_cache: bool,
}

/// Builds `targets` (all when empty) in the project at `root`, `jobs` at once (default: the
/// number of cores).
pub fn run(root: &Path, targets: Vec<String>, flags: Flags) -> anyhow::Result<ExitCode> {
    let Flags {
        jobs,
        explain,
        strict_cache,
    } = flags;
    let start = Instant::now();
    let _lock = lock::acquire(&root.join(STATE_DIR), |holder| {
        eprintln!("hydrofit: waiting for another build of this project to finish ({holder})");
    })?;
    // Plan after taking the lock: the other build may have changed the cache.
    let plan = Plan::load(root, crate::kinds::KINDS)?;
    plan.cache().recover()?;
    let jobs = jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let progress = Progress::new();
    crate::core::interrupt::install();
    let s = executor::build(
        &plan,
        &Options {
            targets,
            jobs,
            explain,
            strict_cache,
        },
        &progress,
    )?;
    let secs = start.elapsed().as_secs_f64();
    for p in &s.published {
        progress.println(format!("wrote {p}"));
    }
    Ok(report(&s, secs))
}

/// Says how the build went, on stderr, and returns the exit code that says it to scripts:
/// 130 interrupted, 1 something failed, 0 done.
fn report(s: &Summary, secs: f64) -> ExitCode {
    if s.interrupted {
        eprintln!(
            "hydrofit: interrupted: {} ran and are cached, the rest will run next time ({secs:.2} s)",
            s.ran.len()
        );
        return ExitCode::from(130);
    }
    if !s.failed.is_empty() {
        eprintln!("{}", failure_line(s, secs));
        return ExitCode::from(1);
    }
    if s.ran.is_empty() {
        eprintln!(
            "hydrofit: up to date ({} stage instances, {secs:.3} s)",
            s.up_to_date
        );
    } else {
        eprintln!(
            "hydrofit: ran {}, {} up to date ({secs:.2} s)",
            s.ran.len(),
            s.up_to_date
        );
    }
    ExitCode::SUCCESS
}

/// `hydrofit: 1 failed: a; not run because they depend on it: b, c (2 ran, ...)`.
fn failure_line(s: &Summary, secs: f64) -> String {
    let names: Vec<&str> = s.failed.iter().map(|(id, _)| id.as_str()).collect();
    let mut line = format!("hydrofit: {} failed: {}", names.len(), names.join(", "));
    if !s.skipped.is_empty() {
        line += &format!(
            "; not run because they depend on it: {}",
            s.skipped.join(", ")
        );
    }
    format!(
        "{line} ({} ran, {} up to date, {secs:.2} s)",
        s.ran.len(),
        s.up_to_date
    )
}
