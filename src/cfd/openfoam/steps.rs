//! What running a case does wherever it runs (here or as a Slurm job): the tools it runs, the
//! OpenFOAM installation they need, its inputs copied to a scratch folder, the outcome read
//! from the log, and the stamp of a finished run.

use super::results::{self, LogEnd};
use super::{CaseSetup, INSTALL_HINT, RunError, Stamp, read_track};
use std::path::{Path, PathBuf};
use std::process::ExitStatus;

/// The OpenFOAM binaries need WM_PROJECT_DIR (Debian's package: /usr/share/openfoam).
pub(super) fn project_dir() -> Option<String> {
    std::env::var("WM_PROJECT_DIR")
        .ok()
        .filter(|d| Path::new(d).join("etc/controlDict").exists())
        .or_else(|| {
            Path::new("/usr/share/openfoam/etc/controlDict")
                .exists()
                .then(|| "/usr/share/openfoam".to_string())
        })
}

/// [`project_dir`], or the error that says how to install OpenFOAM.
pub(super) fn required_project_dir() -> anyhow::Result<String> {
    project_dir().ok_or_else(|| {
        anyhow::anyhow!("OpenFOAM's etc folder was not found (set WM_PROJECT_DIR); {INSTALL_HINT}")
    })
}

/// The executable `exe` in one of the folders of PATH.
pub(super) fn on_path(exe: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|p| p.join(exe))
            .find(|p| p.is_file())
    })
}

/// The tools a case runs, in order: blockMesh when it has a blockMeshDict, then its solver.
pub(super) fn tools<'a>(inputs: &[String], setup: &'a CaseSetup) -> Vec<&'a str> {
    let mut tools: Vec<&str> = Vec::new();
    if inputs.iter().any(|i| i == "system/blockMeshDict") {
        tools.push("blockMesh");
    }
    tools.push(&setup.application);
    tools
}

/// The stamp of a finished run in `dir`: its inputs, the solver's log, the Slurm job (id and
/// node) when one ran it.
pub(super) fn stamp_of(
    dir: &Path,
    setup: &CaseSetup,
    stamp_inputs: &str,
    build_line: String,
    job: Option<(String, String)>,
) -> anyhow::Result<Stamp> {
    let (_, log, _) = read_track(dir, &setup.application)?;
    let (slurm_job, node) = job.map_or((None, None), |(j, n)| (Some(j), Some(n)));
    Ok(Stamp {
        inputs: stamp_inputs.into(),
        solver: setup.application.clone(),
        openfoam: build_line,
        steps: log.steps.len(),
        execution_time_s: log.execution_time_s,
        clock_time_s: log.clock_time_s,
        slurm_job,
        node,
    })
}

/// Copies the case's input files (paths relative to `case`) into `scratch`.
pub(super) fn copy_inputs(case: &Path, inputs: &[String], scratch: &Path) -> anyhow::Result<()> {
    for rel in inputs {
        let to = scratch.join(rel);
        std::fs::create_dir_all(to.parent().expect("has a parent"))?;
        std::fs::copy(case.join(rel), &to)?;
    }
    Ok(())
}

/// Whether `tool` succeeded. For the solver the log decides first: a crash is reported with
/// the log's tail, as is a failed exit status of any tool.
pub(super) fn check_outcome(
    tool: &str,
    is_solver: bool,
    status: Option<ExitStatus>,
    text: &str,
) -> Result<(), RunError> {
    let crashed = |steps: usize, why: String| RunError::Crashed {
        solver: tool.into(),
        steps,
        why,
        log: format!("log.{tool}"),
        tail: results::tail(text, 25),
    };
    let mut steps = 0;
    if is_solver {
        let parsed = results::parse_log(text);
        steps = parsed.steps.len();
        if let LogEnd::Crashed(why) = parsed.end {
            return Err(crashed(steps, why));
        }
    }
    if !status.is_some_and(|s| s.success()) {
        let code = status
            .and_then(|s| s.code())
            .map_or("killed by a signal".to_string(), |c| {
                format!("exit status {c}")
            });
        return Err(crashed(steps, code));
    }
    Ok(())
}
