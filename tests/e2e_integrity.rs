//! A damaged cache is never served: every cached result carries the blake3 of its files, a
//! build moves a result whose files changed aside and rebuilds it (or, with
//! `--strict-cache`, stops), and `hydrofit verify` checks the cache and the published reports.

mod common;
use common::*;
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
