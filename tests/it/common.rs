//! Helpers for end-to-end tests: a temporary copy of the shipped project and the real binary.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub const BIN: &str = env!("CARGO_BIN_EXE_hydrofit");

pub fn manifest_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A temporary project holding the shipped pipeline.yaml and cases/.
pub fn project() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        manifest_dir().join("pipeline.yaml"),
        dir.path().join("pipeline.yaml"),
    )
    .unwrap();
    hydrofit::core::fsutil::copy_dir(&manifest_dir().join("cases"), &dir.path().join("cases"))
        .unwrap();
    hydrofit::core::fsutil::copy_dir(&manifest_dir().join("truth"), &dir.path().join("truth"))
        .unwrap();
    dir
}

/// A temporary copy of `examples/<name>`: its pipeline.yaml, cases/ and truth/.
pub fn example(name: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let src = manifest_dir().join("examples").join(name);
    std::fs::copy(src.join("pipeline.yaml"), dir.path().join("pipeline.yaml")).unwrap();
    for sub in ["cases", "truth"] {
        if src.join(sub).exists() {
            hydrofit::core::fsutil::copy_dir(&src.join(sub), &dir.path().join(sub)).unwrap();
        }
    }
    dir
}

/// Stage instances of the shipped pipeline besides the imports: fit, cylinder, sphere_fit,
/// validate, diagnose, export, compare, report.
pub const SINGLE_STAGES: usize = 8;

pub fn count(dir: &Path, rel: &str) -> usize {
    std::fs::read_dir(dir.join(rel)).unwrap().count()
}

pub fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(BIN)
        .arg("--project")
        .arg(dir)
        .args(args)
        .output()
        .unwrap()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Runs and asserts success, returning stderr.
pub fn ok(dir: &Path, args: &[&str]) -> String {
    let o = run(dir, args);
    assert!(
        o.status.success(),
        "hydrofit {args:?} failed:\n{}\n{}",
        stdout(&o),
        stderr(&o)
    );
    stderr(&o) + &stdout(&o)
}

/// Writes the 2D cylinder case `rel` (`hydrofit openfoam new`) pushed by `force` N/m for
/// `end_time` s.
pub fn new_cylinder(dir: &Path, rel: &str, force: &str, end_time: &str) {
    ok(
        dir,
        &[
            "openfoam",
            "new",
            rel,
            "--force",
            force,
            "--end-time",
            end_time,
        ],
    );
}

/// `ran N` from the build summary (0 when up to date).
pub fn ran(summary: &str) -> usize {
    summary
        .lines()
        .find_map(|l| {
            l.strip_prefix("hydrofit: ran ")
                .and_then(|r| r.split(',').next())
                .and_then(|n| n.trim().parse().ok())
        })
        .unwrap_or(0)
}

pub fn read(dir: &Path, rel: &str) -> String {
    std::fs::read_to_string(dir.join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

pub fn json(dir: &Path, rel: &str) -> serde_json::Value {
    serde_json::from_str(&read(dir, rel)).unwrap()
}

/// A scratch copy of the shipped cylinder_1N run's log and tables, cut to its first `rows`
/// time steps (the log ending there with `End`).
pub fn openfoam_results(rows: usize) -> (tempfile::TempDir, PathBuf) {
    use hydrofit::cfd::openfoam::{FORCE, STATE};
    let d = tempfile::tempdir().unwrap();
    let src = manifest_dir().join("cases/cfd/openfoam/cylinder_1N");
    let dir = d.path().to_path_buf();
    // The time of the `rows`-th row of the state table.
    let state = std::fs::read_to_string(src.join(STATE)).unwrap();
    let last_t: f64 = state
        .lines()
        .filter_map(|l| l.split_whitespace().next()?.parse().ok())
        .nth(rows - 1)
        .unwrap();
    for rel in [STATE, FORCE] {
        let text = std::fs::read_to_string(src.join(rel)).unwrap();
        let head: String = text
            .split_inclusive('\n')
            .take_while(|l| {
                l.split_whitespace()
                    .next()
                    .and_then(|t| t.parse::<f64>().ok())
                    .is_none_or(|t| t <= last_t * (1.0 + 1e-9))
            })
            .collect();
        std::fs::create_dir_all(dir.join(rel).parent().unwrap()).unwrap();
        std::fs::write(dir.join(rel), head).unwrap();
    }
    // The log up to the same time, then its `End`.
    let log = std::fs::read_to_string(src.join("log.pimpleFoam")).unwrap();
    let mut out = String::new();
    for l in log.lines() {
        if let Some(t) = l
            .strip_prefix("Time = ")
            .and_then(|t| t.trim().parse::<f64>().ok())
            && t > last_t * (1.0 + 1e-9)
        {
            break;
        }
        out.push_str(l);
        out.push('\n');
    }
    out.push_str("\nEnd\n\n");
    std::fs::write(dir.join("log.pimpleFoam"), out).unwrap();
    (d, dir)
}

/// The field twin's diagnosis `d` names its hidden buoyancy (`h`, the truth's `hidden`) within
/// 15 %.
pub fn field_buoyancy_named(d: &serde_json::Value, h: &serde_json::Value) {
    let effects = d["effects"].as_array().unwrap();
    let names: Vec<&str> = effects
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    let buoy = effects
        .iter()
        .find(|e| e["name"] == "net_buoyancy")
        .unwrap_or_else(|| panic!("buoyancy not named: {names:?}\n{}", d["verdict"]));
    let up = -buoy["parameters"]["force_n"].as_f64().unwrap();
    let truth_up = h["buoyancy_up_n"].as_f64().unwrap();
    assert!(
        (up - truth_up).abs() < 0.15 * truth_up,
        "buoyancy {up} N up, hidden {truth_up} N"
    );
}
