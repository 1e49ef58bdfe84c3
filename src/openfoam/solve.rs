//! Running a case: where its results come from in a build (left in the case, or a fresh run
//! in a scratch copy), and the run itself (blockMesh, then the solver) through duct.

use super::results::{self, LogEnd};
use super::{CaseSetup, INSTALL_HINT, RunError, STAMP, Stamp, read_track};
use crate::diag::InputError;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::process::ExitStatus;

/// The OpenFOAM binaries need WM_PROJECT_DIR (Debian's package: /usr/share/openfoam).
fn project_dir() -> Option<String> {
    std::env::var("WM_PROJECT_DIR")
        .ok()
        .filter(|d| Path::new(d).join("etc/controlDict").exists())
        .or_else(|| {
            Path::new("/usr/share/openfoam/etc/controlDict")
                .exists()
                .then(|| "/usr/share/openfoam".to_string())
        })
}

/// The executable `exe` in one of the folders of PATH.
fn on_path(exe: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|p| p.join(exe))
            .find(|p| p.is_file())
    })
}

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
    pub slurm: Option<&'a super::slurm::SlurmOptions>,
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
            let p = slurm_scratch(exec.state_dir, identity);
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
        Some(opts) => run_on_slurm(
            case_dir, files, &path, setup, &progress, identity, opts, &name,
        ),
    }
    .map_err(|e| anyhow::anyhow!("case {case_rel}: {e}"))?;
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
    let wm = project_dir().ok_or_else(|| {
        anyhow::anyhow!("OpenFOAM's etc folder was not found (set WM_PROJECT_DIR); {INSTALL_HINT}")
    })?;
    let mut build_line = String::new();
    for tool in tools(inputs, setup) {
        let (status, text) = run_tool(tool, scratch, &wm, progress, &mut build_line)?;
        check_outcome(tool, tool == setup.application, status, &text)?;
    }
    stamp_of(scratch, setup, stamp_inputs, build_line, None)
}

/// The tools a case runs, in order: blockMesh when it has a blockMeshDict, then its solver.
fn tools<'a>(inputs: &[String], setup: &'a CaseSetup) -> Vec<&'a str> {
    let mut tools: Vec<&str> = Vec::new();
    if inputs.iter().any(|i| i == "system/blockMeshDict") {
        tools.push("blockMesh");
    }
    tools.push(&setup.application);
    tools
}

/// The stamp of a finished run in `dir`: its inputs, the solver's log, the Slurm job (id and
/// node) when one ran it.
fn stamp_of(
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

/// The job record a Slurm run leaves in its scratch folder while it runs.
const JOB_FILE: &str = "hydrofit.job";
const JOB_SCRIPT: &str = "hydrofit-job.sh";

/// As [`run`], as a Slurm batch job: the tools run by a job script in `scratch` (which the
/// compute node must see), the job polled until it ends. A job left running by a build that
/// was killed is found again through the record in `scratch` and waited for, not resubmitted.
#[allow(clippy::too_many_arguments)]
fn run_on_slurm(
    case: &Path,
    inputs: &[String],
    scratch: &Path,
    setup: &CaseSetup,
    progress: &dyn Fn(f64),
    stamp_inputs: &str,
    opts: &super::slurm::SlurmOptions,
    name: &str,
) -> anyhow::Result<Stamp> {
    use super::slurm;
    let wm = project_dir().ok_or_else(|| {
        anyhow::anyhow!("OpenFOAM's etc folder was not found (set WM_PROJECT_DIR); {INSTALL_HINT}")
    })?;
    let tools = tools(inputs, setup);
    let id = match live_job(scratch) {
        Some(id) => id,
        None => {
            stage_job(case, inputs, scratch, &tools, &wm)?;
            let id = slurm::submit(scratch, JOB_SCRIPT, name, opts, &[], "slurm-%j.out")?;
            crate::fsutil::write_atomic(&scratch.join(JOB_FILE), id.as_bytes())?;
            id
        }
    };
    let log_path = scratch.join(format!("log.{}", setup.application));
    let state = slurm::wait(&id, &|_| {
        if let Some(t) = last_time(&log_path) {
            progress(t);
        }
    })?;
    let mut build_line = String::new();
    for (i, tool) in tools.iter().enumerate() {
        let text = std::fs::read_to_string(scratch.join(format!("log.{tool}"))).unwrap_or_default();
        if let Some(b) = text.lines().find_map(|l| l.strip_prefix("Build  :")) {
            build_line = b.trim().to_string();
        }
        let failed_here = state.exit_code.split(':').next() == Some(&(10 + i).to_string());
        if state.state == "COMPLETED" || failed_here {
            use std::os::unix::process::ExitStatusExt;
            let code = if failed_here { 1 } else { 0 };
            check_outcome(
                tool,
                *tool == setup.application,
                Some(ExitStatus::from_raw(code << 8)),
                &text,
            )
            .map_err(|e| anyhow::anyhow!("Slurm job {id} {}: {e}", state.describe()))?;
        }
    }
    if state.state != "COMPLETED" {
        let out =
            std::fs::read_to_string(scratch.join(format!("slurm-{id}.out"))).unwrap_or_default();
        let solver_log = std::fs::read_to_string(&log_path).unwrap_or_default();
        let tail = if solver_log.is_empty() {
            results::tail(&out, 15)
        } else {
            results::tail(&solver_log, 15)
        };
        anyhow::bail!(
            "Slurm job {id} ended {}; last lines:\n{tail}",
            state.describe()
        );
    }
    let _ = std::fs::remove_file(scratch.join(JOB_FILE));
    stamp_of(
        scratch,
        setup,
        stamp_inputs,
        build_line,
        Some((id, state.node)),
    )
}

/// The job (or array task) recorded in `scratch` when Slurm still runs it or finished it
/// well: a build killed while it ran waits for it instead of submitting it again.
fn live_job(scratch: &Path) -> Option<String> {
    std::fs::read_to_string(scratch.join(JOB_FILE))
        .ok()
        .map(|t| t.trim().to_string())
        .filter(|id| {
            super::slurm::query(id)
                .ok()
                .flatten()
                .is_some_and(|s| !s.finished() || s.state == "COMPLETED")
        })
}

/// A fresh copy of the case's inputs in `scratch` and the job script that runs its tools
/// there as a local run does (exit status 10 + i when tool i fails).
fn stage_job(
    case: &Path,
    inputs: &[String],
    scratch: &Path,
    tools: &[&str],
    wm: &str,
) -> anyhow::Result<()> {
    for e in std::fs::read_dir(scratch)? {
        let p = e?.path();
        if p.is_dir() {
            std::fs::remove_dir_all(&p)?;
        } else {
            std::fs::remove_file(&p)?;
        }
    }
    copy_inputs(case, inputs, scratch)?;
    let mut script = format!(
        "#!/bin/sh\n# Written by hydrofit: the case's tools, as a local run runs them.\nexport WM_PROJECT_DIR='{wm}'\n"
    );
    for (i, tool) in tools.iter().enumerate() {
        script.push_str(&format!("{tool} > log.{tool} 2>&1 || exit {}\n", 10 + i));
    }
    std::fs::write(scratch.join(JOB_SCRIPT), script)?;
    Ok(())
}

/// The scratch folder of the case whose inputs hash to `identity`, for Slurm runs: one per
/// identity, so a build killed while its job ran finds the job again.
fn slurm_scratch(state_dir: &Path, identity: &str) -> PathBuf {
    state_dir
        .join("slurm")
        .join(&identity[..16.min(identity.len())])
}

/// A case of a series that has to run, for [`submit_array`].
pub struct ArrayCase<'a> {
    pub dir: &'a Path,
    pub files: &'a [String],
    pub setup: &'a CaseSetup,
    pub identity: &'a str,
}

/// Cases submitted together as Slurm array jobs, dropped when the build ends: a task no
/// case waited for (Ctrl-C stopped the build first) is cancelled, and each array's script,
/// list and outputs are removed.
pub struct ArrayJob {
    /// Each array's job id, its number of tasks and its files.
    arrays: Vec<(String, usize, Vec<PathBuf>)>,
}

impl ArrayJob {
    /// The arrays' job ids.
    pub fn ids(&self) -> Vec<&str> {
        self.arrays.iter().map(|(id, _, _)| id.as_str()).collect()
    }

    /// How many cases the arrays run.
    pub fn tasks(&self) -> usize {
        self.arrays.iter().map(|(_, n, _)| n).sum()
    }
}

impl Drop for ArrayJob {
    fn drop(&mut self) {
        for (id, tasks, files) in &self.arrays {
            let unfinished = (0..*tasks).any(|i| {
                super::slurm::query(&format!("{id}_{i}"))
                    .ok()
                    .flatten()
                    .is_some_and(|s| !s.finished())
            });
            if unfinished {
                super::slurm::cancel(id);
            }
            for f in files {
                let _ = std::fs::remove_file(f);
            }
            if let Some(dir) = files.first().and_then(|f| f.parent()) {
                for i in 0..*tasks {
                    let _ = std::fs::remove_file(dir.join(format!("slurm-{id}_{i}.out")));
                }
                // Only when empty: another build's array may be there.
                let _ = std::fs::remove_dir(dir);
            }
        }
    }
}

/// Tasks per array job: Slurm's default `MaxArraySize` (1001) allows indices 0-1000.
const ARRAY_TASKS: usize = 1000;

/// Submits `cases` as array jobs (of at most [`ARRAY_TASKS`] tasks), task i running case
/// i's job script in its scratch folder, and records `<array>_<i>` there, where the case's
/// own run finds and waits for it. Cases whose job is still known to Slurm (a build killed
/// while they ran) are left to it. Fewer than two cases to submit: nothing is submitted,
/// each case goes on its own.
pub fn submit_array(
    state_dir: &Path,
    cases: &[ArrayCase],
    opts: &super::slurm::SlurmOptions,
    name: &str,
) -> anyhow::Result<Option<ArrayJob>> {
    let wm = project_dir().ok_or_else(|| {
        anyhow::anyhow!("OpenFOAM's etc folder was not found (set WM_PROJECT_DIR); {INSTALL_HINT}")
    })?;
    let mut dirs: Vec<PathBuf> = Vec::new();
    for c in cases {
        let scratch = slurm_scratch(state_dir, c.identity);
        std::fs::create_dir_all(&scratch)?;
        if live_job(&scratch).is_some() || dirs.contains(&scratch) {
            continue;
        }
        stage_job(c.dir, c.files, &scratch, &tools(c.files, c.setup), &wm)?;
        dirs.push(scratch.canonicalize()?);
    }
    if dirs.len() < 2 {
        return Ok(None);
    }
    let folder = state_dir.join("slurm").join("arrays");
    std::fs::create_dir_all(&folder)?;
    let folder = folder.canonicalize()?;
    let mut job = ArrayJob { arrays: Vec::new() };
    for chunk in dirs.chunks(ARRAY_TASKS) {
        // Kept in `job` at once: a failed submission of a later chunk cancels this one.
        let (id, files) = submit_chunk(&folder, chunk, opts, name)?;
        job.arrays.push((id, chunk.len(), files));
    }
    Ok(Some(job))
}

/// One array job over the scratch folders `dirs`; its id and the files written for it.
fn submit_chunk(
    folder: &Path,
    dirs: &[PathBuf],
    opts: &super::slurm::SlurmOptions,
    name: &str,
) -> anyhow::Result<(String, Vec<PathBuf>)> {
    let listing: String = dirs.iter().map(|d| format!("{}\n", d.display())).collect();
    let tag = &blake3::hash(listing.as_bytes()).to_hex()[..16];
    let list = folder.join(format!("{tag}.cases"));
    std::fs::write(&list, &listing)?;
    let script = format!(
        "#!/bin/sh\n# Written by hydrofit: task i runs the case in line i + 1 of the list.\ndir=$(sed -n \"$((SLURM_ARRAY_TASK_ID + 1))p\" '{}')\ncd \"$dir\" || exit 2\nexec sh {JOB_SCRIPT} > \"slurm-${{SLURM_ARRAY_JOB_ID}}_${{SLURM_ARRAY_TASK_ID}}.out\" 2>&1\n",
        list.display()
    );
    let script_name = format!("{tag}.sh");
    std::fs::write(folder.join(&script_name), script)?;
    let limit = opts.max_running.map_or(String::new(), |n| format!("%{n}"));
    let array = format!("--array=0-{}{limit}", dirs.len() - 1);
    let files = vec![list, folder.join(&script_name)];
    let id = super::slurm::submit(
        folder,
        &script_name,
        name,
        opts,
        &[array],
        "slurm-%A_%a.out",
    )
    .inspect_err(|_| {
        for f in &files {
            let _ = std::fs::remove_file(f);
        }
    })?;
    for (i, d) in dirs.iter().enumerate() {
        crate::fsutil::write_atomic(&d.join(JOB_FILE), format!("{id}_{i}").as_bytes())?;
    }
    Ok((id, files))
}

/// The last simulated time a solver log reports (its last 4 kB read).
fn last_time(path: &Path) -> Option<f64> {
    use std::io::{Read, Seek, SeekFrom};
    let mut f = std::fs::File::open(path).ok()?;
    let len = f.metadata().ok()?.len();
    f.seek(SeekFrom::Start(len.saturating_sub(4096))).ok()?;
    let mut buf = String::new();
    f.take(4096).read_to_string(&mut buf).ok()?;
    buf.lines().rev().find_map(|l| {
        l.strip_prefix("Time = ")
            .and_then(|t| t.trim().parse().ok())
    })
}

/// Copies the case's input files (paths relative to `case`) into `scratch`.
fn copy_inputs(case: &Path, inputs: &[String], scratch: &Path) -> anyhow::Result<()> {
    for rel in inputs {
        let to = scratch.join(rel);
        std::fs::create_dir_all(to.parent().expect("has a parent"))?;
        std::fs::copy(case.join(rel), &to)?;
    }
    Ok(())
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

/// Whether `tool` succeeded. For the solver the log decides first: a crash is reported with
/// the log's tail, as is a failed exit status of any tool.
fn check_outcome(
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
