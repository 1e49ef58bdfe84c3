//! File-system helpers: atomic writes (temp file + rename), content hashes, and the JSON
//! artifacts every stage reads and writes (with NaN written as `null` and read back).

use std::io::Write;
use std::os::unix::fs::PermissionsExt;
use std::path::Path;

/// Writes `bytes` to `path` through a temporary file in the same directory and a rename,
/// so a reader (or a build killed half-way) never sees a partial file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    // tempfile creates 0600; results and reports are ordinary files (0666 less the umask).
    let mut tmp = tempfile::Builder::new()
        .permissions(std::fs::Permissions::from_mode(0o666))
        .tempfile_in(dir)?;
    tmp.write_all(bytes)?;
    tmp.as_file().sync_data()?;
    tmp.persist(path).map_err(|e| e.error)?;
    Ok(())
}

/// blake3 of a file's contents, as lowercase hex.
pub fn hash_file(path: &Path) -> std::io::Result<String> {
    let mut h = blake3::Hasher::new();
    h.update_reader(std::fs::File::open(path)?)?;
    Ok(h.finalize().to_hex().to_string())
}

/// The files under `dir`, as `/`-separated paths relative to it: depth first, each folder's
/// entries in name order, names starting with `.` left out when `skip_hidden`.
pub fn files_under(dir: &Path, skip_hidden: bool) -> std::io::Result<Vec<String>> {
    fn walk(
        dir: &Path,
        prefix: &str,
        skip_hidden: bool,
        out: &mut Vec<String>,
    ) -> std::io::Result<()> {
        let mut entries: Vec<_> = std::fs::read_dir(dir)?.collect::<Result<_, _>>()?;
        entries.sort_by_key(|e| e.file_name());
        for e in entries {
            let name = e.file_name().to_string_lossy().into_owned();
            if skip_hidden && name.starts_with('.') {
                continue;
            }
            let rel = if prefix.is_empty() {
                name
            } else {
                format!("{prefix}/{name}")
            };
            if e.file_type()?.is_dir() {
                walk(&e.path(), &rel, skip_hidden, out)?;
            } else {
                out.push(rel);
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, "", skip_hidden, &mut out)?;
    Ok(out)
}

/// Copies a directory tree (files and sub-directories).
pub fn copy_dir(from: &Path, to: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(to)?;
    for entry in std::fs::read_dir(from)? {
        let entry = entry?;
        let target = to.join(entry.file_name());
        if entry.file_type()?.is_dir() {
            copy_dir(&entry.path(), &target)?;
        } else {
            std::fs::copy(entry.path(), target)?;
        }
    }
    Ok(())
}

/// Reads a JSON artifact written by [`write_json`].
/// A non-finite float a stage wrote (tagged, or `null`) reads back as itself ([`super::lenient`]).
pub fn read_json<T: for<'de> serde::Deserialize<'de>>(path: &Path) -> anyhow::Result<T> {
    let text =
        std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    super::lenient::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

/// Writes a JSON artifact atomically (pretty, so a person can read a cached object).
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> anyhow::Result<()> {
    write_atomic(path, &json_bytes(value)?)?;
    Ok(())
}

/// `value` as every JSON artifact and published file is written (pretty-printed, a non-finite
/// float as `{"not_finite": ...}`: [`super::finite`]).
pub fn json_bytes<T: serde::Serialize>(value: &T) -> anyhow::Result<Vec<u8>> {
    Ok(super::finite::to_string_pretty(value)?.into_bytes())
}

/// JSON has no NaN: a non-finite float is written tagged (or, by older caches, as `null`);
/// read either back as the float, also where serde buffers the field (a flattened struct).
pub fn f64_or_nan<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    <super::finite::Loose as serde::Deserialize>::deserialize(d)?
        .value()
        .map_err(serde::de::Error::custom)
}

/// Series of numbers per DOF whose non-finite values (tagged, or `null`) read back as floats.
pub fn series_or_nan<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<std::collections::BTreeMap<crate::dof::Dof, Vec<f64>>, D::Error> {
    let raw: std::collections::BTreeMap<crate::dof::Dof, Vec<super::finite::Loose>> =
        serde::Deserialize::deserialize(d)?;
    raw.into_iter()
        .map(|(k, v)| {
            let v = v
                .into_iter()
                .map(super::finite::Loose::value)
                .collect::<Result<Vec<f64>, String>>();
            v.map(|v| (k, v))
        })
        .collect::<Result<_, String>>()
        .map_err(serde::de::Error::custom)
}
