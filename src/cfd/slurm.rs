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
    /// `--partition` (one name, or several separated by commas).
    #[serde(
        skip_serializing_if = "Option::is_none",
        deserialize_with = "checked::partition"
    )]
    pub partition: Option<String>,
    /// `--time`, as Slurm writes it (`30`, `00:30:00`, `2-00:00:00`, `UNLIMITED`).
    #[serde(
        skip_serializing_if = "Option::is_none",
        deserialize_with = "checked::time"
    )]
    pub time: Option<String>,
    /// `--cpus-per-task`, at least 1.
    #[serde(
        skip_serializing_if = "Option::is_none",
        deserialize_with = "checked::cpus"
    )]
    pub cpus: Option<u32>,
    /// `--mem` (`2G`, `500M`, `4096`: megabytes without a unit).
    #[serde(
        skip_serializing_if = "Option::is_none",
        deserialize_with = "checked::mem"
    )]
    pub mem: Option<String>,
    /// For a series submitted as an array job: at most this many of its tasks run at once
    /// (`--array=0-N%max_running`), at least 1.
    #[serde(
        skip_serializing_if = "Option::is_none",
        deserialize_with = "checked::max_running"
    )]
    pub max_running: Option<u32>,
    /// Further `sbatch` options, each one argument (`--qos=long`, `--account=cfd`); not the
    /// ones hydrofit sets itself.
    #[serde(
        skip_serializing_if = "Vec::is_empty",
        deserialize_with = "checked::sbatch"
    )]
    pub sbatch: Vec<String>,
}

/// The `slurm:` settings checked when `pipeline.yaml` is read, so a malformed one is an
/// error located in it, not a refusal from `sbatch` once a case has to run.
mod checked {
    use serde::de::{Deserialize, Deserializer, Error};

    fn text<'de, D: Deserializer<'de>>(d: D) -> Result<String, D::Error> {
        String::deserialize(d)
    }

    pub fn partition<'de, D: Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
        let p = text(d)?;
        let ok = !p.is_empty()
            && p.split(',').all(|n| {
                !n.is_empty()
                    && n.chars()
                        .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
            });
        if !ok {
            return Err(D::Error::custom(format!(
                "`slurm.partition`: `{p}` is not a partition name (letters, digits, `-`, `_`, `.`; several separated by commas); `sinfo -s` lists them"
            )));
        }
        Ok(Some(p))
    }

    /// Slurm's time formats: `M`, `M:S`, `H:M:S`, `D-H`, `D-H:M`, `D-H:M:S`, or `UNLIMITED`.
    pub fn is_time(t: &str) -> bool {
        if matches!(t, "UNLIMITED" | "INFINITE" | "unlimited" | "infinite") {
            return true;
        }
        let num = |x: &str| !x.is_empty() && x.len() <= 6 && x.chars().all(|c| c.is_ascii_digit());
        let (days, rest) = match t.split_once('-') {
            Some((d, r)) => (Some(d), r),
            None => (None, t),
        };
        let parts: Vec<&str> = rest.split(':').collect();
        if days.is_some_and(|d| !num(d)) || !parts.iter().all(|p| num(p)) {
            return false;
        }
        let within = |i: usize, max: u64| {
            parts
                .get(i)
                .is_none_or(|p| p.parse::<u64>().is_ok_and(|v| v < max))
        };
        match (days.is_some(), parts.len()) {
            (false, 1) | (false, 2) => parts.len() == 1 || within(1, 60),
            (false, 3) => within(1, 60) && within(2, 60),
            (true, 1) => within(0, 24),
            (true, 2) => within(0, 24) && within(1, 60),
            (true, 3) => within(0, 24) && within(1, 60) && within(2, 60),
            _ => false,
        }
    }

    pub fn time<'de, D: Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
        // A bare number of minutes may be written unquoted.
        let t = match serde_yaml_ng::Value::deserialize(d)? {
            serde_yaml_ng::Value::Number(n) if n.as_u64().is_some() => n.to_string(),
            serde_yaml_ng::Value::String(s) => s,
            other => {
                return Err(D::Error::custom(format!(
                    "`slurm.time`: must be text like \"02:00:00\", found {other:?}"
                )));
            }
        };
        if !is_time(&t) {
            return Err(D::Error::custom(format!(
                "`slurm.time`: `{t}` is not a Slurm time limit: write minutes (`90`), `hours:minutes:seconds` (`02:00:00`) or `days-hours:minutes:seconds` (`1-12:00:00`), quoted"
            )));
        }
        Ok(Some(t))
    }

    /// `--mem`: a whole number, with a unit K, M, G or T (megabytes without one).
    pub fn is_mem(m: &str) -> bool {
        let digits = m.trim_end_matches(['K', 'M', 'G', 'T', 'k', 'm', 'g', 't']);
        let unit = m.len() - digits.len();
        unit <= 1
            && !digits.is_empty()
            && digits.chars().all(|c| c.is_ascii_digit())
            && digits.parse::<u64>().is_ok_and(|v| v > 0)
    }

    pub fn mem<'de, D: Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
        let m = match serde_yaml_ng::Value::deserialize(d)? {
            serde_yaml_ng::Value::Number(n) if n.as_u64().is_some() => n.to_string(),
            serde_yaml_ng::Value::String(s) => s,
            other => {
                return Err(D::Error::custom(format!(
                    "`slurm.mem`: must be text like \"2G\", found {other:?}"
                )));
            }
        };
        if !is_mem(&m) {
            return Err(D::Error::custom(format!(
                "`slurm.mem`: `{m}` is not a memory size: a whole number with one unit K, M, G or T (`2G`, `500M`; megabytes without a unit)"
            )));
        }
        Ok(Some(m))
    }

    fn at_least_one<'de, D: Deserializer<'de>>(d: D, key: &str) -> Result<Option<u32>, D::Error> {
        let n = i64::deserialize(d).map_err(|e| D::Error::custom(format!("`slurm.{key}`: {e}")))?;
        if !(1..=u32::MAX as i64).contains(&n) {
            return Err(D::Error::custom(format!(
                "`slurm.{key}`: must be a whole number of at least 1, found {n} (leave the setting out for Slurm's default)"
            )));
        }
        Ok(Some(n as u32))
    }

    pub fn cpus<'de, D: Deserializer<'de>>(d: D) -> Result<Option<u32>, D::Error> {
        at_least_one(d, "cpus")
    }

    pub fn max_running<'de, D: Deserializer<'de>>(d: D) -> Result<Option<u32>, D::Error> {
        at_least_one(d, "max_running")
    }

    /// Options hydrofit sets itself, which a further option would contradict.
    const OWN: [&str; 6] = [
        "--parsable",
        "--chdir",
        "--output",
        "--array",
        "--job-name",
        "--wrap",
    ];

    pub fn sbatch<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<String>, D::Error> {
        let opts = Vec::<String>::deserialize(d)?;
        for o in &opts {
            if !o.starts_with('-') || o.contains(char::is_whitespace) {
                return Err(D::Error::custom(format!(
                    "`slurm.sbatch`: `{o}` is not one option: write each as one argument starting with `-`, its value after `=` (`--qos=long`)"
                )));
            }
            let name = o.split('=').next().unwrap_or(o);
            if OWN.contains(&name) || matches!(name, "-D" | "-o" | "-a" | "-J") {
                return Err(D::Error::custom(format!(
                    "`slurm.sbatch`: `{o}` is set by hydrofit itself (it chooses the job's folder, output, name and array); leave it out"
                )));
            }
        }
        Ok(opts)
    }
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

/// How to go on when Slurm is not there.
const LOCAL_HINT: &str = "run the build where the cluster answers (its login node), start Slurm here, or set `executor: local` in the stage's settings to run the case on this machine";

/// Whether sbatch's answer says that no Slurm is reachable (no configuration, no controller),
/// rather than that it refused the job's settings.
fn unreachable(answer: &str) -> bool {
    let a = answer.to_ascii_lowercase();
    [
        "could not establish a configuration source",
        "unable to contact slurm controller",
        "unable to establish controller",
        "connection refused",
        "socket timed out",
        "slurm_conf",
        "no such file or directory",
    ]
    .iter()
    .any(|p| a.contains(p))
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
        .map_err(|e| {
            crate::core::diag::ExecutorUnavailable(format!(
                "cannot run sbatch ({e}): Slurm is not installed on this machine\n  help: {LOCAL_HINT}"
            ))
        })?;
    let text = String::from_utf8_lossy(&out.stdout).trim().to_string();
    if !out.status.success() && unreachable(&text) {
        return Err(crate::core::diag::ExecutorUnavailable(format!(
            "no Slurm controller answers from this machine; sbatch said: {}\n  help: {LOCAL_HINT}",
            crate::core::input::clip(&text, 400)
        ))
        .into());
    }
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
    fn slurm_settings_are_checked_when_read() {
        let parse = |y: &str| serde_yaml_ng::from_str::<SlurmOptions>(y);
        for good in [
            "{time: '00:30:00', mem: 2G, max_running: 1, cpus: 4, partition: debug}",
            "{time: 90, mem: 4096}",
            "{time: '1-12:00:00', partition: 'a,b'}",
            "{time: '2-0', mem: 500m}",
            "{time: UNLIMITED, sbatch: ['--qos=long', '--account=cfd']}",
        ] {
            assert!(parse(good).is_ok(), "{good}: {:?}", parse(good));
        }
        for (bad, says) in [
            ("{max_running: 0}", "at least 1"),
            ("{cpus: -2}", "at least 1"),
            ("{mem: 2GG}", "`slurm.mem`: `2GG`"),
            ("{mem: 0}", "`slurm.mem`: `0`"),
            ("{mem: 2.5G}", "`slurm.mem`"),
            ("{time: '1:75:00'}", "`slurm.time`: `1:75:00`"),
            ("{time: 'two hours'}", "`slurm.time`"),
            ("{time: '1-25'}", "`slurm.time`"),
            ("{time: '::'}", "`slurm.time`"),
            ("{partition: 'gpu nodes'}", "`slurm.partition`"),
            ("{partition: ''}", "`slurm.partition`"),
            ("{sbatch: ['--qos long']}", "not one option"),
            ("{sbatch: ['qos=long']}", "not one option"),
            ("{sbatch: ['--array=0-3']}", "set by hydrofit"),
            ("{sbatch: ['--output=x']}", "set by hydrofit"),
        ] {
            let e = parse(bad).unwrap_err().to_string();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

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
