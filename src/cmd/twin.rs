//! `hydrofit twin ...`: write synthetic inputs from the reference vehicle.

use crate::twin;
use std::path::Path;
use std::process::ExitCode;

pub fn starccm(root: &Path, out: &Path, seed: u64) -> anyhow::Result<ExitCode> {
    let dir = if out.is_absolute() { out.to_path_buf() } else { root.join(out) };
    let cases = twin::cfd::default_cases();
    let written = twin::cfd::write_cases(&dir, &cases, seed)?;
    eprintln!("hydrofit: wrote {} STAR-CCM+ exports of the reference vehicle to {} (seed {seed})", written.len(), dir.display());
    Ok(ExitCode::SUCCESS)
}
