//! A case run as a Slurm batch job (`executor: slurm`): its scratch copy under the project's
//! `.hydrofit/slurm/`, the job script that runs the same tools as a local run, the record that
//! lets a killed build find its job again, and a series' cases submitted as array jobs.

use super::results;
use super::steps::{check_outcome, copy_inputs, required_project_dir, stamp_of, tools};
use super::{CaseSetup, Stamp};
use crate::cfd::slurm::{self, SlurmOptions};
use std::path::{Path, PathBuf};
use std::process::ExitStatus;

/// The job record a Slurm run leaves in its scratch folder while it runs.
const JOB_FILE: &str = "hydrofit.job";
const JOB_SCRIPT: &str = "hydrofit-job.sh";

/// As [`super::run`], as a Slurm batch job: the tools run by a job script in `scratch` (which the
/// compute node must see), the job polled until it ends. A job left running by a build that
/// was killed is found again through the record in `scratch` and waited for, not resubmitted.
#[allow(clippy::too_many_arguments)]
pub(super) fn run(
    case: &Path,
    inputs: &[String],
    scratch: &Path,
    setup: &CaseSetup,
    progress: &dyn Fn(f64),
    stamp_inputs: &str,
    opts: &SlurmOptions,
    name: &str,
) -> anyhow::Result<Stamp> {
    let wm = required_project_dir()?;
    let tools = tools(inputs, setup);
    let id = match live_job(scratch) {
        Some(id) => id,
        None => {
            stage_job(case, inputs, scratch, &tools, &wm)?;
            let id = slurm::submit(scratch, JOB_SCRIPT, name, opts, &[], "slurm-%j.out")?;
            crate::core::fsutil::write_atomic(&scratch.join(JOB_FILE), id.as_bytes())?;
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
            slurm::query(id)
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
pub(super) fn scratch(state_dir: &Path, identity: &str) -> PathBuf {
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
                slurm::query(&format!("{id}_{i}"))
                    .ok()
                    .flatten()
                    .is_some_and(|s| !s.finished())
            });
            if unfinished {
                slurm::cancel(id);
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
    opts: &SlurmOptions,
    name: &str,
) -> anyhow::Result<Option<ArrayJob>> {
    let wm = required_project_dir()?;
    let mut dirs: Vec<PathBuf> = Vec::new();
    for c in cases {
        let scratch = scratch(state_dir, c.identity);
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
    opts: &SlurmOptions,
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
    let id = slurm::submit(
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
        crate::core::fsutil::write_atomic(&d.join(JOB_FILE), format!("{id}_{i}").as_bytes())?;
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
