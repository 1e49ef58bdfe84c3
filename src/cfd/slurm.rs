//! Running a case's scratch copy as a Slurm batch job: `sbatch --parsable` submits a job
//! script that runs the same tools as a local run, `scontrol show job -o` is polled with a
//! growing interval (never busy), Slurm's own state, reason and exit code decide the outcome,
//! and Ctrl-C cancels the job (`scancel`). The scratch folder must be on a filesystem the
//! compute nodes share (it is under the project's `.hydrofit/slurm/`).

use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Duration;

/// The `slurm:` settings of a CFD stage: what `sbatch` is asked for.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SlurmOptions {
    /// `--partition`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub partition: Option<String>,
    /// `--time`, as Slurm writes it (`00:30:00`, `2-00:00:00`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time: Option<String>,
    /// `--cpus-per-task`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cpus: Option<u32>,
    /// `--mem` (`2G`, `500M`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mem: Option<String>,
    /// For a series submitted as an array job: at most this many of its tasks run at once
    /// (`--array=0-N%max_running`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_running: Option<u32>,
    /// Further `sbatch` options, each one argument (`--qos=long`, `--account=cfd`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub sbatch: Vec<String>,
}

/// What Slurm says of a job.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JobState {
    pub state: String,
    pub reason: String,
    pub exit_code: String,
    pub node: String,
}

impl JobState {
    /// Whether the job will not change any more.
    pub fn finished(&self) -> bool {
        !matches!(
            self.state.as_str(),
            "PENDING"
                | "RUNNING"
                | "CONFIGURING"
                | "COMPLETING"
                | "SUSPENDED"
                | "REQUEUED"
                | "RESIZING"
                | "SIGNALING"
                | "STAGE_OUT"
                | "STOPPED"
                | ""
        )
    }

    /// The job's line for messages: `FAILED (NonZeroExitCode, exit 11:0) on node1`.
    pub fn describe(&self) -> String {
        format!(
            "{} ({}, exit {}){}",
            self.state,
            self.reason,
            self.exit_code,
            if self.node.is_empty() || self.node == "(null)" {
                String::new()
            } else {
                format!(" on {}", self.node)
            }
        )
    }
}

/// The fields of `scontrol show job -o` output.
pub fn parse_job(line: &str) -> JobState {
    let field = |k: &str| {
        line.split_whitespace()
            .find_map(|kv| kv.strip_prefix(k).and_then(|v| v.strip_prefix('=')))
            .unwrap_or("")
            .to_string()
    };
    JobState {
        state: field("JobState"),
        reason: field("Reason"),
        exit_code: field("ExitCode"),
        node: field("NodeList"),
    }
}

/// Submits `script` (a file in `scratch`, which is also the job's working folder) with the
/// stage's options and `extra` ones (`--array=0-3`), its output in `scratch/<output>`
/// (`slurm-%j.out`), and returns the job id.
pub fn submit(
    scratch: &Path,
    script: &str,
    name: &str,
    opts: &SlurmOptions,
    extra: &[String],
    output: &str,
) -> anyhow::Result<String> {
    // Absolute: the job starts in its own working directory.
    let scratch = &scratch.canonicalize()?;
    let mut args: Vec<String> = vec![
        "--parsable".into(),
        format!("--job-name=hydrofit-{name}"),
        format!("--chdir={}", scratch.display()),
        format!("--output={}", scratch.join(output).display()),
    ];
    args.extend(extra.iter().cloned());
    if let Some(p) = &opts.partition {
        args.push(format!("--partition={p}"));
    }
    if let Some(t) = &opts.time {
        args.push(format!("--time={t}"));
    }
    if let Some(c) = opts.cpus {
        args.push(format!("--cpus-per-task={c}"));
    }
    if let Some(m) = &opts.mem {
        args.push(format!("--mem={m}"));
    }
    args.extend(opts.sbatch.iter().cloned());
    args.push(scratch.join(script).display().to_string());
    let out = duct::cmd("sbatch", &args)
        .stderr_to_stdout()
        .unchecked()
        .stdout_capture()
        .run()
        .map_err(|e| anyhow::anyhow!("cannot run sbatch ({e}): is Slurm installed here?"))?;
    let text = String::from_utf8_lossy(&out.stdout).trim().to_string();
    anyhow::ensure!(
        out.status.success(),
        "sbatch refused the job: {text}\n  help: check the stage's slurm settings (partition, time, cpus, mem, sbatch)"
    );
    let id = text.split(';').next().unwrap_or("").trim().to_string();
    anyhow::ensure!(
        !id.is_empty() && id.chars().all(|c| c.is_ascii_digit() || c == '_'),
        "sbatch answered `{text}`, not a job id"
    );
    Ok(id)
}

/// What Slurm knows of job `id` now; `None` when it no longer knows it.
pub fn query(id: &str) -> anyhow::Result<Option<JobState>> {
    let out = duct::cmd!("scontrol", "show", "job", "-o", id)
        .stderr_to_stdout()
        .unchecked()
        .stdout_capture()
        .run()?;
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() || text.contains("Invalid job id") {
        return Ok(None);
    }
    Ok(text.lines().next().map(parse_job))
}

/// Cancels job `id` (best effort: it may have ended).
pub fn cancel(id: &str) {
    let _ = duct::cmd!("scancel", id)
        .stderr_null()
        .stdout_null()
        .unchecked()
        .run();
}

/// Waits for job `id` to end, polling every 0.5 s at first and at most every 10 s; `poll` is
/// called with the state after each look. Ctrl-C cancels the job.
pub fn wait(id: &str, poll: &dyn Fn(&JobState)) -> anyhow::Result<JobState> {
    let mut interval = Duration::from_millis(500);
    loop {
        if crate::core::interrupt::requested() {
            cancel(id);
            anyhow::bail!("interrupted (Ctrl-C): Slurm job {id} cancelled");
        }
        let Some(state) = query(id)? else {
            anyhow::bail!(
                "Slurm no longer knows job {id}: its record expired before hydrofit read it\n  help: raise MinJobAge in slurm.conf"
            );
        };
        poll(&state);
        if state.finished() {
            return Ok(state);
        }
        // Sleep in short slices, so Ctrl-C is heard within 0.1 s.
        let until = std::time::Instant::now() + interval;
        while std::time::Instant::now() < until && !crate::core::interrupt::requested() {
            std::thread::sleep(Duration::from_millis(100));
        }
        interval = (interval * 3 / 2).min(Duration::from_secs(10));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scontrol_lines_are_read() {
        let line = "JobId=7 JobName=hydrofit-short UserId=root(0) JobState=FAILED Reason=NonZeroExitCode Dependency=(null) ExitCode=11:0 NodeList=node1 BatchHost=node1";
        let s = parse_job(line);
        assert_eq!(s.state, "FAILED");
        assert_eq!(s.reason, "NonZeroExitCode");
        assert_eq!(s.exit_code, "11:0");
        assert!(s.finished());
        assert_eq!(s.describe(), "FAILED (NonZeroExitCode, exit 11:0) on node1");
        let running = parse_job("JobId=8 JobState=RUNNING Reason=None ExitCode=0:0 NodeList=n");
        assert!(!running.finished());
        assert!(parse_job("JobId=9 JobState=TIMEOUT Reason=TimeLimit").finished());
    }
}
