//! A damaged cache is never served: every cached result carries the blake3 of its files, a
//! build moves a result whose files changed aside and rebuilds it (or, with
//! `--strict-cache`, stops), and `hydrofit verify` checks the cache and the published reports.

use crate::common::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Every file of every cached result, by extension (one of each kind is damaged in turn).
fn object_files(dir: &Path) -> BTreeMap<String, Vec<PathBuf>> {
    let mut out: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    for obj in std::fs::read_dir(dir.join(".hydrofit/objects")).unwrap() {
        for f in std::fs::read_dir(obj.unwrap().path()).unwrap() {
            let p = f.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            if name == ".manifest.json" || p.is_dir() {
                continue;
            }
            let ext = name.rsplit('.').next().unwrap().to_string();
            out.entry(ext).or_default().push(p);
        }
    }
    out
}

fn reports(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir.join("reports"))
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect()
}

fn flip(p: &Path) {
    let mut b = std::fs::read(p).unwrap();
    let i = b.len() / 2;
    b[i] ^= 0x04;
    std::fs::write(p, b).unwrap();
}

#[test]
fn a_damaged_cached_result_is_detected_moved_aside_and_rebuilt() {
    let p = example("tank_submarine");
    let dir = p.path();
    ok(dir, &["build"]);
    let first = reports(dir);
    assert!(ok(dir, &["verify"]).contains("all intact"));
    let kinds = object_files(dir);
    assert!(kinds.len() >= 3, "{kinds:?}");
    for (ext, files) in &kinds {
        // A bit flipped, a file cut in half, a stray file: each is damage.
        for damage in 0..3 {
            let f = &files[0];
            match damage {
                0 => flip(f),
                1 => {
                    let b = std::fs::read(f).unwrap();
                    std::fs::write(f, &b[..b.len() / 2]).unwrap();
                }
                _ => std::fs::write(f.with_file_name("stray.txt"), "x").unwrap(),
            }
            let o = run(dir, &["verify"]);
            assert!(!o.status.success(), "{ext} damage {damage} not found");
            assert!(stdout(&o).contains("is damaged"), "{}", stdout(&o));
            let strict = run(dir, &["build", "--strict-cache"]);
            assert!(!strict.status.success());
            assert!(
                stderr(&strict).contains("is damaged"),
                "{}",
                stderr(&strict)
            );
            let o = run(dir, &["build"]);
            assert!(o.status.success(), "{}", stderr(&o));
            let e = stderr(&o);
            assert!(
                e.contains("is damaged") && e.contains("rebuilt"),
                "{ext}: {e}"
            );
            assert_eq!(
                reports(dir),
                first,
                "{ext} damage {damage}: the rebuilt report differs"
            );
            assert!(ok(dir, &["verify"]).contains("all intact"));
        }
    }
    // An edited published file is found, and the next build publishes the result again.
    let html = dir.join("reports/index.html");
    std::fs::write(
        &html,
        read(dir, "reports/index.html").replacen("tf1", "tf9", 1),
    )
    .unwrap();
    let o = run(dir, &["verify"]);
    assert!(!o.status.success() && stdout(&o).contains("reports/index.html differs"));
    ok(dir, &["build"]);
    assert_eq!(reports(dir), first);
}

/// `[`, `]`, `*` in the project's own path are literal: the build reads its own cases, not a
/// sibling's that the path would match as a pattern.
#[test]
fn glob_characters_in_the_project_path_are_literal() {
    let parent = tempfile::tempdir().unwrap();
    let src = example("tank_submarine");
    let odd = parent.path().join("proj[12]*");
    let sibling = parent.path().join("proj1");
    for d in [&odd, &sibling] {
        hydrofit::core::fsutil::copy_dir(src.path(), d).unwrap();
    }
    // The sibling has a run the odd-named project does not.
    hydrofit::core::fsutil::copy_dir(
        &sibling.join("cases/pool/test2"),
        &sibling.join("cases/pool/sibling_only"),
    )
    .unwrap();
    let graph = ok(&odd, &["graph"]);
    assert!(
        graph.contains("test1") && graph.contains("test2"),
        "{graph}"
    );
    assert!(!graph.contains("sibling_only"), "{graph}");
    ok(&odd, &["build"]);
    assert!(odd.join("reports/index.html").exists());
    assert!(ok(&odd, &["verify"]).contains("all intact"));
}

/// `clean` while a build runs waits for the lock, keeps the lock file, and a build started
/// meanwhile runs after it, never beside it: the cache it leaves is whole and up to date.
#[test]
fn clean_during_a_build_waits_and_leaves_the_lock_usable() {
    use std::process::{Command, Stdio};
    let p = project();
    let dir = p.path();
    let spawn = |args: &[&str]| {
        Command::new(BIN)
            .arg("--project")
            .arg(dir)
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let first = spawn(&["build", "--jobs", "1"]);
    let lock = dir.join(".hydrofit/lock");
    let t0 = std::time::Instant::now();
    while !std::fs::read_to_string(&lock).is_ok_and(|t| t.contains("pid")) {
        assert!(t0.elapsed().as_secs() < 60, "the build never took the lock");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let clean = spawn(&["clean"]);
    std::thread::sleep(std::time::Duration::from_millis(300));
    let second = spawn(&["build"]);
    let first = first.wait_with_output().unwrap();
    let clean = clean.wait_with_output().unwrap();
    let second = second.wait_with_output().unwrap();
    assert!(first.status.success(), "{}", stderr(&first));
    assert!(clean.status.success(), "{}", stderr(&clean));
    assert!(
        stderr(&clean).contains("waiting for a build to finish"),
        "clean did not wait: {}",
        stderr(&clean)
    );
    assert!(second.status.success(), "{}", stderr(&second));
    assert!(lock.exists(), "clean removed the lock file");
    assert!(ok(dir, &["verify"]).contains("all intact"));
    // Either order is serial: the second build ran everything after the clean, or nothing
    // before it (and the clean then removed what the first build cached).
    let status = ok(dir, &["status"]);
    if ran(&(stderr(&second) + &stdout(&second))) > 0 {
        assert!(status.contains("up to date"), "{status}");
    } else {
        assert!(status.contains("never built"), "{status}");
    }
}

/// The reported hang: one `1e300` in a STAR-CCM+ velocity column. The import now refuses it at
/// its line, so neither the fit nor the estimator comparison ever sees it; a damaged OpenFOAM
/// table (a time written over with 0) fails its case at its line and reruns when restored.
#[test]
fn a_damaged_number_fails_its_import_at_its_line() {
    let p = project();
    let dir = p.path();
    let csv = dir.join("cases/cfd/starccm/surge_10N.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut fields: Vec<String> = lines[40].split(',').map(str::to_string).collect();
    fields[3] = "1e300".into();
    lines[40] = fields.join(",");
    std::fs::write(&csv, lines.join("\n") + "\n").unwrap();
    let o = run(dir, &["build"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("cases/cfd/starccm/surge_10N.csv:41:") && err.contains("1e300"),
        "{err}"
    );
    assert!(err.contains("not run because they depend on it"), "{err}");
    std::fs::write(&csv, &text).unwrap();
    ok(dir, &["build"]);

    let table = dir.join(format!(
        "cases/cfd/openfoam/cylinder_1N/{}",
        hydrofit::cfd::openfoam::STATE
    ));
    let good = std::fs::read_to_string(&table).unwrap();
    let bad: String = good
        .split_inclusive('\n')
        .enumerate()
        .map(|(i, l)| {
            if i == 30 {
                let rest = &l[l.find(char::is_whitespace).unwrap()..];
                format!("0{rest}")
            } else {
                l.to_string()
            }
        })
        .collect();
    std::fs::write(&table, bad).unwrap();
    let status = ok(dir, &["status"]);
    assert!(
        status.contains("sixDoFRigidBodyState.dat changed since its result was read")
            && status.contains("cylinder: it reads openfoam[cylinder_1N]"),
        "{status}"
    );
    let o = run(dir, &["build"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("line 31: time 0 is out of order"),
        "{}",
        stderr(&o)
    );
    std::fs::write(&table, &good).unwrap();
    let out = ok(dir, &["build"]);
    assert!(ran(&out) >= 3, "{out}");
    assert!(ok(dir, &["status"]).contains("up to date"));
}

/// A folder where a stage takes files (`surge_1N.csv/` among the exports) is said as such,
/// not read as a file with nothing in it.
#[test]
fn a_folder_named_like_an_input_file_is_refused() {
    let p = project();
    let dir = p.path();
    std::fs::create_dir(dir.join("cases/cfd/starccm/surge_1N.csv")).unwrap();
    let o = run(dir, &["build"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o)
            .contains("cases/cfd/starccm/surge_1N.csv: is a folder, where stage `cfd` takes files"),
        "{}",
        stderr(&o)
    );
}
