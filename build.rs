//! Fingerprints the source tree at compile time (FNV-1a 64 over sorted paths and contents),
//! so every stage key changes when hydrofit's code does: a rebuilt binary never reuses results
//! computed by different code. Costs nothing at run time.

use std::path::Path;

fn walk(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            walk(&p, out)
        } else {
            out.push(p)
        }
    }
}

fn main() {
    let mut files = Vec::new();
    for d in ["src", "assets", "crates/logs/src"] {
        walk(Path::new(d), &mut files);
    }
    files.push("Cargo.lock".into());
    files.sort();
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for f in &files {
        let bytes = std::fs::read(f).unwrap_or_default();
        for b in f.to_string_lossy().bytes().chain(bytes) {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    println!("cargo:rustc-env=HYDROFIT_SOURCE_HASH={h:016x}");
    println!("cargo:rerun-if-changed=src");
    println!("cargo:rerun-if-changed=assets");
    println!("cargo:rerun-if-changed=crates/logs/src");
    println!("cargo:rerun-if-changed=Cargo.lock");
}
