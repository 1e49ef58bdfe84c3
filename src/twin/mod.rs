//! The digital twin: simulates the seed-001 reference vehicle and writes synthetic inputs in
//! exactly the formats real users have, so every stage can be checked against a known truth.

pub mod auv;
pub mod cfd;
pub mod dsrv;
pub mod field;
pub mod logs;
pub mod pool;
pub mod scenario;
pub mod six;
pub mod tank;
pub mod world;

/// Writes one twin run: its `files` into `cases_dir/<name>/`, its true motion and what it
/// hides into `truth_dir/<name>.csv` and `<name>.json` (outside `cases/`).
pub fn write_run(
    cases_dir: &std::path::Path,
    truth_dir: &std::path::Path,
    name: &str,
    files: &[(&str, String)],
    truth_csv: &str,
    record: &impl serde::Serialize,
) -> anyhow::Result<std::path::PathBuf> {
    let dir = cases_dir.join(name);
    std::fs::create_dir_all(&dir)?;
    std::fs::create_dir_all(truth_dir)?;
    for (file, text) in files {
        crate::core::fsutil::write_atomic(&dir.join(file), text.as_bytes())?;
    }
    crate::core::fsutil::write_atomic(
        &truth_dir.join(format!("{name}.csv")),
        truth_csv.as_bytes(),
    )?;
    crate::core::fsutil::write_atomic(
        &truth_dir.join(format!("{name}.json")),
        &crate::core::fsutil::json_bytes(record)?,
    )?;
    Ok(dir)
}
