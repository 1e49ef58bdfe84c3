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

pub fn pool(root: &Path, out: &Path, truth: &Path, seed: u64, effects: &[String]) -> anyhow::Result<ExitCode> {
    let abs = |p: &Path| if p.is_absolute() { p.to_path_buf() } else { root.join(p) };
    let effects = if effects.is_empty() {
        twin::pool::default_effects()
    } else if effects.iter().any(|e| e == "none") {
        Vec::new()
    } else {
        effects.iter().map(|e| crate::model::effects::Effect::from_arg(e)).collect::<Result<Vec<_>, _>>().map_err(anyhow::Error::msg)?
    };
    let runs = twin::pool::default_runs();
    let written = twin::pool::write_runs(&abs(out), &abs(truth), &runs, &effects, seed)?;
    let names: Vec<&str> = effects.iter().map(|e| e.name()).collect();
    eprintln!(
        "hydrofit: wrote {} pool runs to {} and their truth to {} (seed {seed}, concealed: {})",
        written.len(),
        abs(out).display(),
        abs(truth).display(),
        if names.is_empty() { "nothing".into() } else { names.join(", ") }
    );
    Ok(ExitCode::SUCCESS)
}
