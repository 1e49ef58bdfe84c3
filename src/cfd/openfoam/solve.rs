//! Running a case: where its results come from in a build (left in the case, or a fresh run
//! in a scratch copy), and the run itself (blockMesh, then the solver) through duct.

use super::steps::{
    check_outcome, copy_inputs, on_path, project_dir, required_project_dir, stamp_of, tools,
};
use super::{CaseSetup, INSTALL_HINT, STAMP, Stamp};
use crate::core::diag::InputError;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::process::ExitStatus;

/// Whether `solver` (and blockMesh) can run here.
pub fn solver_available(solver: &str) -> bool {
    on_path(solver).is_some() && on_path("blockMesh").is_some() && project_dir().is_some()
}

/// Where a case's results come from in this build. A fresh run's scratch folder lives as
/// long as this value.
pub struct Results {
    pub dir: PathBuf,
    pub stamp: Stamp,
    /// True when this build ran the solver.
    pub ran: bool,
    pub notes: Vec<String>,
    _scratch: Option<Scratch>,
}

/// Where a fresh run's files live until they are kept: a temporary folder (local runs), or a
/// folder under the project's state that compute nodes share (Slurm), removed when done.
enum Scratch {
    Temp(#[allow(dead_code)] tempfile::TempDir),
    Shared(PathBuf),
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if let Scratch::Shared(p) = self {
            let _ = std::fs::remove_dir_all(p);
        }
    }
}

/// How a fresh run is executed: here, or as a Slurm job whose scratch folder is under
/// `state_dir` (the project's `.hydrofit/`, on the filesystem the cluster shares).
#[derive(Clone, Copy)]
pub struct Executor<'a> {
    pub slurm: Option<&'a crate::cfd::slurm::SlurmOptions>,
    pub state_dir: &'a Path,
}

fn read_stamp(case_dir: &Path) -> Option<Stamp> {
    std::fs::read_to_string(case_dir.join(STAMP))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
}

/// Whether a run of exactly these inputs (`identity`) left its results in the case.
pub fn results_left(case_dir: &Path, setup: &CaseSetup, identity: &str) -> bool {
    read_stamp(case_dir).is_some_and(|s| s.inputs == identity)
        && case_dir.join(format!("log.{}", setup.application)).exists()
}

/// The case's results: those left in the case when its stamp names exactly these inputs;
/// otherwise a fresh run in a scratch copy when the solver is installed; otherwise results
/// run by hand (without a stamp), with a note; otherwise an error that says how to install
/// OpenFOAM. `files` are the case's inputs relative to it, `identity` their hash.
pub fn obtain_results(
    case_dir: &Path,
    case_rel: &str,
    files: &[String],
    setup: &CaseSetup,
    identity: &str,
    message: &dyn Fn(String),
    exec: Executor,
) -> anyhow::Result<Results> {
    let solver = &setup.application;
    let stamp = read_stamp(case_dir);
    let has_results = case_dir.join(format!("log.{solver}")).exists();
    let left = |stamp: Stamp, notes: Vec<String>| Results {
        dir: case_dir.to_path_buf(),
        stamp,
        ran: false,
        notes,
        _scratch: None,
    };
    if results_left(case_dir, setup, identity) {
        Ok(left(stamp.expect("checked"), Vec::new()))
    } else if solver_available(solver) {
        run_fresh(case_dir, case_rel, files, setup, identity, message, exec)
    } else if has_results && stamp.is_none() {
        let note = format!(
            "results in {case_rel} were not produced by hydrofit (no {}): used as they are, unverified against the case's inputs",
            STAMP
        );
        Ok(left(unstamped(identity, solver), vec![note]))
    } else {
        let what = if has_results {
            "the case's inputs changed since its results were produced"
        } else {
            "the case has never been run"
        };
        Err(InputError::file(
            case_rel,
            format!("{what}, and {solver} (OpenFOAM) is not installed here"),
            INSTALL_HINT,
        )
        .into())
    }
}

/// The case run in a scratch copy, its progress reported through `message`.
fn run_fresh(
    case_dir: &Path,
    case_rel: &str,
    files: &[String],
    setup: &CaseSetup,
    identity: &str,
    message: &dyn Fn(String),
    exec: Executor,
) -> anyhow::Result<Results> {
    let solver = setup.application.clone();
    let (scratch, path) = match exec.slurm {
        None => {
            let t = tempfile::Builder::new()
                .prefix("hydrofit-openfoam-")
                .tempdir()?;
            let p = t.path().to_path_buf();
            (Scratch::Temp(t), p)
        }
        // One folder per case identity: a build killed while its job ran finds the job again.
        Some(_) => {
            let p = super::on_slurm::scratch(exec.state_dir, identity);
            std::fs::create_dir_all(&p)?;
            (Scratch::Shared(p.clone()), p)
        }
    };
    let end = setup.end_time_s;
    message(format!("{solver}: meshing"));
    let progress = move |t: f64| {
        message(format!(
            "{solver} t = {t:.2} / {end} s ({:.0} %)",
            100.0 * t / end.max(1e-12)
        ))
    };
    let name = Path::new(case_rel)
        .file_name()
        .map_or(case_rel.to_string(), |n| n.to_string_lossy().into_owned());
    let stamp = match exec.slurm {
        None => run(case_dir, files, &path, setup, &progress, identity),
        Some(opts) => super::on_slurm::run(
            case_dir, files, &path, setup, &progress, identity, opts, &name,
        ),
    }
    .map_err(|e| e.context(format!("case {case_rel}")))?;
    Ok(Results {
        dir: path,
        stamp,
        ran: true,
        notes: Vec::new(),
        _scratch: Some(scratch),
    })
}

/// The stamp standing for results run by hand: this build's inputs, nothing known of the run.
fn unstamped(identity: &str, solver: &str) -> Stamp {
    Stamp {
        inputs: identity.to_string(),
        solver: solver.to_string(),
        openfoam: String::new(),
        steps: 0,
        execution_time_s: None,
        clock_time_s: None,
        slurm_job: None,
        node: None,
    }
}

/// Runs blockMesh and the solver on a copy of the case's inputs in `scratch`, streaming the
/// simulated time to `progress`. Returns the stamp of the run.
pub fn run(
    case: &Path,
    inputs: &[String],
    scratch: &Path,
    setup: &CaseSetup,
    progress: &dyn Fn(f64),
    stamp_inputs: &str,
) -> anyhow::Result<Stamp> {
    copy_inputs(case, inputs, scratch)?;
    let wm = required_project_dir()?;
    let mut build_line = String::new();
    for tool in tools(inputs, setup) {
        let (status, text) = run_tool(tool, scratch, &wm, progress, &mut build_line)?;
        check_outcome(tool, tool == setup.application, status, &text)?;
    }
    stamp_of(scratch, setup, stamp_inputs, build_line, None)
}

/// Runs `tool` in `scratch`, its output written to `log.<tool>` as it comes: the simulated
/// time goes to `progress`, the OpenFOAM build it names to `build_line`. Returns the exit
/// status and the log's text.
fn run_tool(
    tool: &str,
    scratch: &Path,
    wm: &str,
    progress: &dyn Fn(f64),
    build_line: &mut String,
) -> anyhow::Result<(Option<ExitStatus>, String)> {
    let log_path = scratch.join(format!("log.{tool}"));
    let mut log = std::io::BufWriter::new(std::fs::File::create(&log_path)?);
    let reader = duct::cmd!(tool)
        .dir(scratch)
        .env("WM_PROJECT_DIR", wm)
        .stderr_to_stdout()
        .stdin_null()
        .unchecked()
        .reader()?;
    let mut lines = std::io::BufReader::new(&reader);
    let mut line = String::new();
    loop {
        line.clear();
        if lines.read_line(&mut line)? == 0 {
            break;
        }
        log.write_all(line.as_bytes())?;
        if let Some(t) = line
            .strip_prefix("Time = ")
            .and_then(|t| t.trim().parse::<f64>().ok())
        {
            progress(t);
        } else if let Some(b) = line.strip_prefix("Build  :") {
            *build_line = b.trim().to_string();
        }
    }
    log.flush()?;
    let status = reader.try_wait()?.map(|o| o.status);
    let text = std::fs::read_to_string(&log_path).unwrap_or_default();
    Ok((status, text))
}
