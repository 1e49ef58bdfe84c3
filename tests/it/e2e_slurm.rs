//! End-to-end on a real Slurm: `scripts/slurm-local.sh` installs (Debian's slurm-wlm, munge)
//! and starts a one-node cluster on this machine, and the OpenFOAM stage with
//! `executor: slurm` runs the short cylinder case as a batch job. Its cached response is the
//! same, byte for byte, as the local run's; the stamp names the job and the node; a crashing
//! case fails its stage with Slurm's state and the solver log's tail. Skipped, with a
//! message, without OpenFOAM or where the cluster cannot be started (never in CI).

use crate::common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

fn openfoam_installed() -> bool {
    let on_path = |exe: &str| {
        std::env::var_os("PATH")
            .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join(exe).is_file()))
    };
    on_path("pimpleFoam")
        && on_path("blockMesh")
        && Path::new("/usr/share/openfoam/etc/controlDict").exists()
}

/// A one-node cluster for the test's lifetime, stopped (by PID) when dropped.
struct Cluster {
    dir: tempfile::TempDir,
    conf: PathBuf,
}

impl Cluster {
    fn start() -> Option<Cluster> {
        let dir = tempfile::tempdir().unwrap();
        let script = manifest_dir().join("scripts/slurm-local.sh");
        let o = Command::new("bash")
            .arg(&script)
            .arg("up")
            .arg(dir.path())
            .output()
            .unwrap();
        if !o.status.success() {
            let why = String::from_utf8_lossy(&o.stderr).into_owned();
            assert!(
                std::env::var_os("CI").is_none(),
                "CI must be able to start the local Slurm: {why}"
            );
            eprintln!("skipped: no local Slurm here ({why})");
            return None;
        }
        let conf = dir.path().join("slurm.conf");
        Some(Cluster { dir, conf })
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash")
            .arg(manifest_dir().join("scripts/slurm-local.sh"))
            .arg("down")
            .arg(self.dir.path())
            .output();
    }
}

fn pipeline(executor: &str) -> String {
    format!(
        r#"
vehicle: {{name: test, mass_kg: 35.2, dofs: [surge]}}
stages:
  openfoam:
    kind: openfoam
    inputs: ["cases/cfd/openfoam/*/"]
    settings:
      executor: {executor}
      slurm: {{time: "00:10:00", cpus: 1, mem: 1G}}
"#
    )
}

fn hydrofit(dir: &Path, conf: &Path, args: &[&str]) -> std::process::Output {
    Command::new(BIN)
        .arg("--project")
        .arg(dir)
        .args(args)
        .env("SLURM_CONF", conf)
        .env("WM_PROJECT_DIR", "/usr/share/openfoam")
        .output()
        .unwrap()
}

/// The project with the short case, built with `executor`; returns the folder.
fn project_with_case(
    executor: &str,
    conf: &Path,
    broken: bool,
) -> (tempfile::TempDir, std::process::Output) {
    let p = tempfile::tempdir().unwrap();
    let dir = p.path();
    std::fs::write(dir.join("pipeline.yaml"), pipeline(executor)).unwrap();
    new_cylinder(dir, "cases/cfd/openfoam/short", "2", "1");
    if broken {
        std::fs::remove_file(dir.join("cases/cfd/openfoam/short/0/p")).unwrap();
    }
    let o = hydrofit(dir, conf, &["build"]);
    (p, o)
}

/// The cached response table of the project's one OpenFOAM instance.
fn response_table(dir: &Path) -> Vec<u8> {
    for e in std::fs::read_dir(dir.join(".hydrofit/objects")).unwrap() {
        let p = e.unwrap().path().join("response.parquet");
        if p.exists() {
            return std::fs::read(p).unwrap();
        }
    }
    panic!("no cached response in {}", dir.display());
}

/// One cluster for both checks (two would share this machine's ports).
#[test]
fn openfoam_cases_run_as_slurm_jobs() {
    if !openfoam_installed() {
        eprintln!("skipped: OpenFOAM is not installed here (.ci/run installs it)");
        return;
    }
    let Some(cluster) = Cluster::start() else {
        return;
    };
    the_short_case_runs_as_a_slurm_job_and_matches_the_local_run(&cluster);
    a_failing_job_fails_its_stage_with_slurms_state_and_the_log_tail(&cluster);
    ctrl_c_cancels_the_job_and_a_killed_build_picks_its_job_up_again(&cluster);
    a_series_runs_as_one_array_job_and_a_new_level_runs_alone(&cluster);
    ctrl_c_cancels_every_task_of_the_array(&cluster);
    the_shipped_sphere_series_runs_on_slurm_as_it_runs_locally(&cluster);
}

/// The shipped project's `sphere` stage as it is (executor slurm, the six-case sweep), with
/// the template's end time cut to three steps so CI can afford it, against the same stage
/// with `executor: local`.
fn the_shipped_sphere_series_runs_on_slurm_as_it_runs_locally(cluster: &Cluster) {
    let shorten = |dir: &Path| {
        let control = dir.join("cases/cfd/templates/sphere/system/controlDict");
        let text = std::fs::read_to_string(&control).unwrap();
        assert!(text.contains("endTime         2.5;"), "{text}");
        std::fs::write(
            &control,
            text.replace("endTime         2.5;", "endTime         0.06;"),
        )
        .unwrap();
    };
    let on_slurm = project();
    shorten(on_slurm.path());
    let local = project();
    shorten(local.path());
    let yaml = read(local.path(), "pipeline.yaml");
    assert_eq!(
        yaml.matches("executor: slurm").count(),
        1,
        "the sphere stage's"
    );
    std::fs::write(
        local.path().join("pipeline.yaml"),
        yaml.replace("executor: slurm", "executor: local"),
    )
    .unwrap();
    for p in [&local, &on_slurm] {
        let o = hydrofit(p.path(), &cluster.conf, &["build", "sphere"]);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{err}");
        assert_eq!(ran(&err), 6, "{err}");
    }
    let mut arrays = std::collections::BTreeSet::new();
    for force in ["0.5", "1", "2"] {
        for dir in ["x", "z"] {
            let case = format!("cases/cfd/sphere/sphere_{force}N_{dir}");
            let stamp = json(on_slurm.path(), &format!("{case}/hydrofit.run.json"));
            let job = stamp["slurm_job"].as_str().unwrap_or("").to_string();
            arrays.insert(job.split('_').next().unwrap().to_string());
            assert!(job.contains('_'), "an array task: {stamp}");
            assert_eq!(stamp["steps"].as_u64(), Some(3), "{stamp}");
            for table in [SERIES_STATE, "postProcessing/forces/0/force.dat"] {
                assert_eq!(
                    read(local.path(), &format!("{case}/{table}")),
                    read(on_slurm.path(), &format!("{case}/{table}")),
                    "{case}/{table}"
                );
            }
        }
    }
    assert_eq!(arrays.len(), 1, "{arrays:?}");
}

/// A series of the short cylinder case over three force levels, defined in pipeline.yaml.
fn series_project(executor: &str, levels: &str, end_time: &str) -> tempfile::TempDir {
    series_project_with(executor, levels, end_time, "")
}

/// As [`series_project`], with further `slurm` settings (`, max_running: 1`).
fn series_project_with(
    executor: &str,
    levels: &str,
    end_time: &str,
    slurm: &str,
) -> tempfile::TempDir {
    let p = tempfile::tempdir().unwrap();
    let yaml = format!(
        r#"
vehicle: {{name: test, mass_kg: 35.2, dofs: [surge]}}
stages:
  series:
    kind: openfoam
    inputs: ["cases/cfd/templates/cyl/"]
    settings:
      executor: {executor}
      slurm: {{time: "00:10:00", cpus: 1, mem: 1G{slurm}}}
      series:
        name: "cyl_{{appliedForce}}N"
        sweep:
          appliedForce: {levels}
"#
    );
    std::fs::write(p.path().join("pipeline.yaml"), yaml).unwrap();
    new_cylinder(p.path(), "cases/cfd/templates/cyl", "2", end_time);
    p
}

const SERIES_STATE: &str = "postProcessing/sixDoFRigidBodyState/0/sixDoFRigidBodyState.dat";

fn a_series_runs_as_one_array_job_and_a_new_level_runs_alone(cluster: &Cluster) {
    let local = series_project("local", "[1, 2, 4]", "0.5");
    let o = hydrofit(local.path(), &cluster.conf, &["build"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let slurm = series_project("slurm", "[1, 2, 4]", "0.5");
    let dir = slurm.path();
    let o = hydrofit(dir, &cluster.conf, &["build"]);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    assert_eq!(ran(&err), 3, "{err}");
    assert!(
        err.contains("series: 3 cases submitted to Slurm as array job "),
        "{err}"
    );
    let mut arrays = std::collections::BTreeSet::new();
    let mut tasks = std::collections::BTreeSet::new();
    for f in ["1", "2", "4"] {
        let case = format!("cases/cfd/series/cyl_{f}N");
        // The case is the template with its force set, and it ran as a task of one array.
        let dict = read(dir, &format!("{case}/constant/dynamicMeshDict"));
        assert!(dict.contains(&format!("appliedForce    {f};")), "{dict}");
        let stamp = json(dir, &format!("{case}/hydrofit.run.json"));
        let job = stamp["slurm_job"].as_str().unwrap_or("").to_string();
        let (array, task) = job
            .split_once('_')
            .unwrap_or_else(|| panic!("not an array task: {stamp}"));
        arrays.insert(array.to_string());
        tasks.insert(task.to_string());
        // The same motion as the local run's, to the byte.
        assert_eq!(
            read(local.path(), &format!("{case}/{SERIES_STATE}")),
            read(dir, &format!("{case}/{SERIES_STATE}")),
            "{case}"
        );
    }
    assert_eq!(arrays.len(), 1, "one array job: {arrays:?}");
    assert_eq!(tasks.len(), 3, "{tasks:?}");
    assert!(
        std::fs::read_dir(dir.join(".hydrofit/slurm")).map_or(true, |mut d| d.next().is_none()),
        "scratch or array files left behind"
    );
    // One more force level: one case runs, the others are untouched.
    let yaml = read(dir, "pipeline.yaml").replace("[1, 2, 4]", "[1, 2, 4, 3]");
    std::fs::write(dir.join("pipeline.yaml"), yaml).unwrap();
    let o = hydrofit(dir, &cluster.conf, &["build"]);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    assert_eq!(ran(&err), 1, "{err}");
    assert!(
        dir.join("cases/cfd/series/cyl_3N/hydrofit.run.json")
            .exists()
    );
    // Without the cache, the results left in the cases are read: nothing runs.
    ok(dir, &["clean"]);
    let o = hydrofit(dir, &cluster.conf, &["build"]);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("Slurm"), "{err}");
    let stamp = json(dir, "cases/cfd/series/cyl_1N/hydrofit.run.json");
    assert!(
        stamp["slurm_job"]
            .as_str()
            .unwrap()
            .starts_with(arrays.first().unwrap().as_str())
    );
}

fn ctrl_c_cancels_every_task_of_the_array(cluster: &Cluster) {
    let p = series_project_with("slurm", "[1, 2, 3]", "6", ", max_running: 1");
    let build = spawn_build(p.path(), &cluster.conf);
    let task = running_job(&cluster.conf);
    let array = task.split('_').next().unwrap().to_string();
    // `max_running: 1`: one task runs, the others wait for it.
    for _ in 0..10 {
        let text = squeue(&cluster.conf, &["-r", "-j", &array]);
        assert!(text.matches("RUNNING").count() <= 1, "{text}");
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
    ctrl_c(build);
    // The running task ends CANCELLED; the waiting ones never run (Slurm forgets a pending
    // task cancelled on its own, so those are either CANCELLED or unknown).
    await_cancelled(&cluster.conf, &task);
    let t0 = std::time::Instant::now();
    loop {
        let left = squeue(&cluster.conf, &["-r", "-j", &array])
            .trim()
            .to_string();
        if left.is_empty() {
            break;
        }
        assert!(t0.elapsed().as_secs() < 30, "still queued: {left}");
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    for i in 0..3 {
        let state = job_state(&cluster.conf, &format!("{array}_{i}"));
        assert!(
            matches!(state.as_str(), "CANCELLED" | ""),
            "task {i}: {state}"
        );
    }
}

/// Ctrl-C on a running build: it stops with a failure.
fn ctrl_c(build: std::process::Child) {
    let _ = Command::new("kill")
        .args(["-INT", &build.id().to_string()])
        .status();
    let o = build.wait_with_output().unwrap();
    assert!(!o.status.success());
}

/// Waits up to 30 s for Slurm to say job `id` was cancelled.
fn await_cancelled(conf: &Path, id: &str) {
    let t0 = std::time::Instant::now();
    while job_state(conf, id) != "CANCELLED" {
        assert!(
            t0.elapsed().as_secs() < 30,
            "job {id}: {}",
            job_state(conf, id)
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
}

/// `squeue -h -o "%i %T"` with `args`: one `id STATE` line per job (or task, with `-r`).
fn squeue(conf: &Path, args: &[&str]) -> String {
    let o = Command::new("squeue")
        .args(["-h", "-o", "%i %T"])
        .args(args)
        .env("SLURM_CONF", conf)
        .output()
        .unwrap();
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// `hydrofit build` of project `dir` on the cluster, started and left running.
fn spawn_build(dir: &Path, conf: &Path) -> std::process::Child {
    Command::new(BIN)
        .arg("--project")
        .arg(dir)
        .arg("build")
        .env("SLURM_CONF", conf)
        .env("WM_PROJECT_DIR", "/usr/share/openfoam")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap()
}

/// The id of the one job Slurm has queued or running, once it has one.
fn running_job(conf: &Path) -> String {
    let t0 = std::time::Instant::now();
    loop {
        let text = squeue(conf, &[]);
        if let Some(line) = text.lines().find(|l| l.ends_with("RUNNING")) {
            return line.split_whitespace().next().unwrap().to_string();
        }
        assert!(t0.elapsed().as_secs() < 60, "no job started: {text}");
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
}

fn job_state(conf: &Path, id: &str) -> String {
    let o = Command::new("scontrol")
        .args(["show", "job", "-o", id])
        .env("SLURM_CONF", conf)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    text.split_whitespace()
        .find_map(|kv| kv.strip_prefix("JobState="))
        .unwrap_or("")
        .to_string()
}

fn ctrl_c_cancels_the_job_and_a_killed_build_picks_its_job_up_again(cluster: &Cluster) {
    let p = tempfile::tempdir().unwrap();
    let dir = p.path();
    std::fs::write(dir.join("pipeline.yaml"), pipeline("slurm")).unwrap();
    new_cylinder(dir, "cases/cfd/openfoam/long", "2", "4");
    let spawn = || spawn_build(dir, &cluster.conf);
    // Ctrl-C: the build stops and cancels its job.
    let build = spawn();
    let id = running_job(&cluster.conf);
    ctrl_c(build);
    await_cancelled(&cluster.conf, &id);
    // kill -9: the job goes on; the next build waits for that job instead of a new one.
    let mut build = spawn();
    let id = running_job(&cluster.conf);
    build.kill().unwrap();
    let _ = build.wait();
    let o = hydrofit(dir, &cluster.conf, &["build"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stamp = json(dir, "cases/cfd/openfoam/long/hydrofit.run.json");
    assert_eq!(stamp["slurm_job"].as_str(), Some(id.as_str()), "{stamp}");
}

fn the_short_case_runs_as_a_slurm_job_and_matches_the_local_run(cluster: &Cluster) {
    let (local, o) = project_with_case("local", &cluster.conf, false);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (on_slurm, o) = project_with_case("slurm", &cluster.conf, false);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        response_table(local.path()),
        response_table(on_slurm.path()),
        "the cached response of the Slurm run is the local run's"
    );
    let state =
        "cases/cfd/openfoam/short/postProcessing/sixDoFRigidBodyState/0/sixDoFRigidBodyState.dat";
    assert_eq!(read(local.path(), state), read(on_slurm.path(), state));
    let stamp = json(
        on_slurm.path(),
        "cases/cfd/openfoam/short/hydrofit.run.json",
    );
    assert!(
        stamp["slurm_job"].as_str().is_some_and(|j| !j.is_empty()),
        "{stamp}"
    );
    assert!(
        stamp["node"].as_str().is_some_and(|n| !n.is_empty()),
        "{stamp}"
    );
    assert!(
        json(local.path(), "cases/cfd/openfoam/short/hydrofit.run.json")["slurm_job"].is_null()
    );
    // The scratch folder the job ran in is gone; nothing is stale.
    assert!(
        std::fs::read_dir(on_slurm.path().join(".hydrofit/slurm"))
            .map_or(true, |mut d| d.next().is_none()),
        "scratch left behind"
    );
    let again = hydrofit(on_slurm.path(), &cluster.conf, &["build"]);
    assert_eq!(ran(&String::from_utf8_lossy(&again.stderr)), 0);
}

fn a_failing_job_fails_its_stage_with_slurms_state_and_the_log_tail(cluster: &Cluster) {
    let (p, o) = project_with_case("slurm", &cluster.conf, true);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("Slurm job") && err.contains("FAILED") && err.contains("FOAM FATAL"),
        "{err}"
    );
    assert!(
        !p.path()
            .join("cases/cfd/openfoam/short/hydrofit.run.json")
            .exists()
    );
}

/// A Slurm configuration whose controller is not there: sbatch answers "Unable to contact
/// slurm controller" at once.
fn unreachable_conf(dir: &Path) -> PathBuf {
    let conf = dir.join("slurm.conf");
    std::fs::write(
        &conf,
        "ClusterName=nowhere\nSlurmctldHost=localhost(127.0.0.1)\nSlurmctldPort=1\nMessageTimeout=2\n",
    )
    .unwrap();
    conf
}

/// A case that must run under `executor: slurm` where no Slurm answers: the message says so,
/// why the case had to run, and that `executor: local` runs it here.
#[test]
fn a_case_that_must_run_where_no_slurm_answers_says_why_and_offers_the_local_executor() {
    let on_path = std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("sbatch").is_file()));
    if !on_path {
        assert!(std::env::var_os("CI").is_none(), "CI installs Slurm");
        eprintln!("skipped: no sbatch here (.ci/run installs Slurm)");
        return;
    }
    let c = tempfile::tempdir().unwrap();
    let conf = unreachable_conf(c.path());
    let (p, o) = project_with_case("slurm", &conf, false);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("no Slurm controller answers"), "{err}");
    assert!(err.contains("`executor: local`"), "{err}");
    assert!(err.contains("it had to run because: never built"), "{err}");
    if !openfoam_installed() {
        return;
    }
    // Built here once; then one dictionary changes and the case must run again.
    let dir = p.path();
    std::fs::write(dir.join("pipeline.yaml"), pipeline("local")).unwrap();
    let o = hydrofit(dir, &conf, &["build"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::write(dir.join("pipeline.yaml"), pipeline("slurm")).unwrap();
    let rel = "cases/cfd/openfoam/short/system/controlDict";
    let text = std::fs::read_to_string(dir.join(rel)).unwrap();
    std::fs::write(dir.join(rel), format!("{text}\n// checked\n")).unwrap();
    let o = hydrofit(dir, &conf, &["build"]);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains(&format!("it had to run because: input {rel} changed")),
        "{err}"
    );
}
