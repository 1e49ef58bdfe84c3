//! The content-addressed store under `.hydrofit/`.
//!
//! `objects/<key>/` holds a finished instance's artifacts. It appears only through one rename
//! of a complete temporary folder, so its existence is the record that the stage finished: a
//! build killed at any point leaves either nothing or a whole result. `log` is an append-only
//! list of the fields each instance was last built with, used only to explain staleness; a torn
//! last line (killed mid-append) is cut off on the next build, never fatal.
//!
//! Every object carries a manifest (`.manifest.json`: the blake3 of each of its files), written
//! before the rename. An object is served only when its files still match it ([`Cache::verify`]):
//! a truncated, bit-flipped or edited artifact is never taken for a result.

use super::key::Fields;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Engine-owned file inside each object folder (dot-named: never published).
pub const FIELDS_FILE: &str = ".fields.json";
const PARTIAL_FILE: &str = ".partial";
/// The blake3 of every other file of the object, by path relative to it.
pub const MANIFEST_FILE: &str = ".manifest.json";
/// Project files a result was read from besides its keyed inputs (the results an OpenFOAM
/// run left in its case folder), with their blake3 (`null`: absent) when it was made.
pub const WATCHED_FILE: &str = ".watched.json";
const LOG: &str = "log";
/// Rewrite the log keeping the last record per instance once it has this many lines.
const COMPACT_AT: usize = 20_000;

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Record {
    pub id: String,
    pub key: String,
    pub fields: Fields,
}

pub struct Cache {
    dir: PathBuf,
}

impl Cache {
    pub fn new(dir: &Path) -> Cache {
        Cache {
            dir: dir.to_path_buf(),
        }
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    pub fn object(&self, key: &str) -> PathBuf {
        self.dir.join("objects").join(key)
    }

    /// A complete result, built with every upstream it asked for.
    pub fn has(&self, key: &str) -> bool {
        self.object(key).is_dir() && self.partial(key).is_none()
    }

    /// For a result built while some of its upstream instances had failed (the other pool
    /// runs went on without a broken one): which ones. Such a result is published but never
    /// served as up to date, so the next build redoes it.
    pub fn partial(&self, key: &str) -> Option<String> {
        std::fs::read_to_string(self.object(key).join(PARTIAL_FILE)).ok()
    }

    /// A fresh folder for a running instance's artifacts.
    pub fn begin(&self, key: &str) -> std::io::Result<PathBuf> {
        let tmp = self.dir.join("tmp");
        std::fs::create_dir_all(&tmp)?;
        let path = tmp.join(
            format!(
                "{key}.{}.{:?}",
                std::process::id(),
                std::thread::current().id()
            )
            .replace(['(', ')'], ""),
        );
        if path.exists() {
            std::fs::remove_dir_all(&path)?;
        }
        std::fs::create_dir(&path)?;
        Ok(path)
    }

    /// Makes a finished folder the result for `record.key` (one rename), then logs it.
    pub fn commit(&self, tmp: &Path, record: &Record) -> std::io::Result<()> {
        self.commit_partial(tmp, record, &[])
    }

    /// Commits a result; `missing` names the failed upstream instances it was built without.
    pub fn commit_partial(
        &self,
        tmp: &Path,
        record: &Record,
        missing: &[String],
    ) -> std::io::Result<()> {
        let text = serde_json::to_string_pretty(&record.fields).map_err(std::io::Error::other)?;
        crate::core::fsutil::write_atomic(&tmp.join(FIELDS_FILE), text.as_bytes())?;
        if !missing.is_empty() {
            crate::core::fsutil::write_atomic(
                &tmp.join(PARTIAL_FILE),
                missing.join(", ").as_bytes(),
            )?;
        }
        write_manifest(tmp)?;
        let dest = self.object(&record.key);
        std::fs::create_dir_all(dest.parent().expect("objects/<key> has a parent"))?;
        if self.partial(&record.key).is_some() {
            // The earlier result lacked an upstream; this one replaces it.
            std::fs::remove_dir_all(&dest)?;
        }
        if dest.exists() {
            // Same key, same inputs: the existing result is as good as ours.
            std::fs::remove_dir_all(tmp)?;
        } else {
            std::fs::rename(tmp, &dest)?;
        }
        self.append(record)
    }

    /// The first file of the project the result was read from that changed since (see
    /// [`WATCHED_FILE`]), said as `cases/x/log.pimpleFoam changed`; `None` when none did.
    pub fn watched_change(&self, key: &str, root: &Path) -> Option<String> {
        let text = std::fs::read_to_string(self.object(key).join(WATCHED_FILE)).ok()?;
        let watched: std::collections::BTreeMap<String, Option<String>> =
            serde_json::from_str(&text).ok()?;
        watched.into_iter().find_map(|(rel, was)| {
            let now = crate::core::fsutil::hash_file(&root.join(&rel)).ok();
            match (was, now) {
                (a, b) if a == b => None,
                (None, Some(_)) => Some(format!("{rel} appeared")),
                (Some(_), None) => Some(format!("{rel} was removed")),
                _ => Some(format!("{rel} changed")),
            }
        })
    }

    /// Removes an object whose result is out of date, so it is built again.
    pub fn discard(&self, key: &str) -> std::io::Result<()> {
        match std::fs::remove_dir_all(self.object(key)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e),
            _ => Ok(()),
        }
    }

    /// Whether object `key`'s files are exactly those its manifest lists, with the same
    /// contents; the first difference otherwise.
    pub fn verify(&self, key: &str) -> Result<(), String> {
        let dir = self.object(key);
        let text = std::fs::read_to_string(dir.join(MANIFEST_FILE))
            .map_err(|_| format!("{MANIFEST_FILE} is missing"))?;
        let listed: std::collections::BTreeMap<String, String> =
            serde_json::from_str(&text).map_err(|_| format!("{MANIFEST_FILE} is damaged"))?;
        let found = files_under(&dir).map_err(|e| format!("cannot list the object: {e}"))?;
        for rel in &found {
            if !listed.contains_key(rel) {
                return Err(format!("{rel} is not part of the result"));
            }
        }
        for (rel, hash) in &listed {
            match crate::core::fsutil::hash_file(&dir.join(rel)) {
                Ok(h) if h == *hash => {}
                Ok(_) => return Err(format!("{rel} differs from the result as written")),
                Err(_) => return Err(format!("{rel} is missing")),
            }
        }
        Ok(())
    }

    /// Moves a damaged object aside (`.hydrofit/damaged/<key>`, the last copy kept for
    /// inspection) so that its stage reruns.
    pub fn quarantine(&self, key: &str) -> std::io::Result<()> {
        let dest = self.dir.join("damaged").join(key);
        if dest.exists() {
            std::fs::remove_dir_all(&dest)?;
        }
        std::fs::create_dir_all(dest.parent().expect("damaged/<key> has a parent"))?;
        std::fs::rename(self.object(key), dest)
    }

    pub fn abandon(&self, tmp: &Path) {
        let _ = std::fs::remove_dir_all(tmp);
    }

    fn append(&self, record: &Record) -> std::io::Result<()> {
        let mut line = serde_json::to_string(record).map_err(std::io::Error::other)?;
        line.push('\n');
        let mut f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(self.dir.join(LOG))?;
        // One write per record: a kill leaves at most one torn line, at the end.
        f.write_all(line.as_bytes())
    }

    /// The last record of each instance. Unparsable lines (a torn append) are skipped.
    pub fn records(&self) -> HashMap<String, Record> {
        let text = std::fs::read_to_string(self.dir.join(LOG)).unwrap_or_default();
        text.lines()
            .filter_map(|l| serde_json::from_str::<Record>(l).ok())
            .map(|r| (r.id.clone(), r))
            .collect()
    }

    /// Start-of-build housekeeping (under the lock): drop temporary folders of killed builds,
    /// cut a torn last log line so the next append starts on a fresh line, compact the log.
    pub fn recover(&self) -> std::io::Result<()> {
        let _ = std::fs::remove_dir_all(self.dir.join("tmp"));
        std::fs::create_dir_all(&self.dir)?;
        let path = self.dir.join(LOG);
        let Ok(text) = std::fs::read_to_string(&path) else {
            return Ok(());
        };
        if !text.is_empty() && !text.ends_with('\n') {
            let keep = text.rfind('\n').map_or(0, |i| i + 1);
            std::fs::OpenOptions::new()
                .write(true)
                .open(&path)?
                .set_len(keep as u64)?;
        }
        if text.lines().count() > COMPACT_AT {
            let mut recs: Vec<Record> = self.records().into_values().collect();
            recs.sort_by(|a, b| a.id.cmp(&b.id));
            let body: String = recs
                .iter()
                .filter_map(|r| serde_json::to_string(r).ok())
                .map(|l| l + "\n")
                .collect();
            crate::core::fsutil::write_atomic(&path, body.as_bytes())?;
        }
        Ok(())
    }
}

/// Every file under `dir` but the manifest, as `/`-separated paths relative to it, sorted.
fn files_under(dir: &Path) -> std::io::Result<Vec<String>> {
    let mut out = crate::core::fsutil::files_under(dir, false)?;
    out.retain(|rel| rel != MANIFEST_FILE);
    out.sort();
    Ok(out)
}

/// Writes the manifest of a finished object folder.
fn write_manifest(dir: &Path) -> std::io::Result<()> {
    let mut m = std::collections::BTreeMap::new();
    for rel in files_under(dir)? {
        m.insert(
            rel.clone(),
            crate::core::fsutil::hash_file(&dir.join(&rel))?,
        );
    }
    let text = serde_json::to_string_pretty(&m).map_err(std::io::Error::other)?;
    crate::core::fsutil::write_atomic(&dir.join(MANIFEST_FILE), text.as_bytes())
}

/// Records in the result folder `out` the project files `paths` (relative to `root`) it was
/// read from besides its inputs, as they are now: a later change to one reruns the stage.
pub fn write_watched(out: &Path, root: &Path, paths: &[String]) -> std::io::Result<()> {
    let watched: std::collections::BTreeMap<&String, Option<String>> = paths
        .iter()
        .map(|p| (p, crate::core::fsutil::hash_file(&root.join(p)).ok()))
        .collect();
    let text = serde_json::to_string_pretty(&watched).map_err(std::io::Error::other)?;
    crate::core::fsutil::write_atomic(&out.join(WATCHED_FILE), text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(id: &str, key: &str) -> Record {
        Record {
            id: id.into(),
            key: key.into(),
            fields: Fields(vec![("kind".into(), "x".into())]),
        }
    }

    #[test]
    fn a_torn_log_line_is_ignored_and_cut() {
        let dir = tempfile::tempdir().unwrap();
        let c = Cache::new(dir.path());
        std::fs::create_dir_all(dir.path()).unwrap();
        let t = c.begin("k1").unwrap();
        c.commit(&t, &rec("a", "k1")).unwrap();
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(dir.path().join(LOG))
            .unwrap();
        f.write_all(b"{\"id\":\"b\",\"key\":\"k2\",\"fie").unwrap();
        assert_eq!(c.records().len(), 1);
        c.recover().unwrap();
        let t = c.begin("k3").unwrap();
        c.commit(&t, &rec("b", "k3")).unwrap();
        let r = c.records();
        assert_eq!(r["a"].key, "k1");
        assert_eq!(r["b"].key, "k3");
        assert!(c.has("k1") && c.has("k3") && !c.has("k2"));
    }
}
