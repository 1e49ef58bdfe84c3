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

/// Stage instances of the shipped pipeline besides the imports: fit, cylinder, validate, compare, report.
pub const SINGLE_STAGES: usize = 7;

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
