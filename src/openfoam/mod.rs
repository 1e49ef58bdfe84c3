//! OpenFOAM DFBI cases: which files of a case folder are its inputs, reading the applied
//! force and body mass from the case, running it (blockMesh, then the solver) through duct,
//! and reading the body's motion back from what the run leaves.

pub mod case;
pub mod case_run;
pub mod dict;
pub mod results;

use crate::diag::InputError;
use results::{LogEnd, VectorTable};
use serde::{Deserialize, Serialize};
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

/// Written into a case folder next to the results of a run by hydrofit: which inputs they
/// belong to. Results without it (or for other inputs) are not used as they are.
pub const STAMP: &str = "hydrofit.run.json";
pub const STATE: &str = "postProcessing/sixDoFRigidBodyState/0/sixDoFRigidBodyState.dat";
pub const FORCE: &str = "postProcessing/forces/0/force.dat";
pub const INSTALL_HINT: &str = "install OpenFOAM (Debian/Ubuntu: `sudo apt-get install openfoam`, v1912) and run `hydrofit build` again";

/// Whether a file of a case folder (path relative to the case) is one of the case's inputs
/// rather than something a run produced: logs, postProcessing/, time folders other than 0,
/// the mesh blockMesh writes, processor folders and the run stamp are not.
pub fn is_case_input(rel: &str) -> bool {
    let first = rel.split('/').next().unwrap_or("");
    if rel.starts_with("constant/polyMesh/")
        || rel == STAMP
        || first.starts_with("log.")
        || first.starts_with("processor")
    {
        return false;
    }
    if matches!(first, "postProcessing" | "dynamicCode" | "VTK")
        || first.ends_with(".foam")
        || first.ends_with(".OpenFOAM")
    {
        return false;
    }
    // Time folders: any number but the initial conditions.
    if rel.contains('/') && first.parse::<f64>().is_ok() && first != "0" {
        return false;
    }
    true
}

/// The run stamp.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stamp {
    /// blake3 over the case's input files (relative path and content hash of each).
    pub inputs: String,
    pub solver: String,
    /// `Build` line of the log, e.g. `OPENFOAM=1912 patch=200626`.
    pub openfoam: String,
    pub steps: usize,
    /// CPU and wall-clock seconds of the solver as it reported them.
    pub execution_time_s: Option<f64>,
    pub clock_time_s: Option<f64>,
}

/// Identity of a case's inputs: independent of where the case folder is.
pub fn inputs_hash(files: &[(String, String)]) -> String {
    let mut sorted: Vec<&(String, String)> = files.iter().collect();
    sorted.sort();
    let mut h = blake3::Hasher::new();
    for (path, hash) in sorted {
        h.update(path.as_bytes());
        h.update(b"\0");
        h.update(hash.as_bytes());
        h.update(b"\n");
    }
    h.finalize().to_hex().to_string()
}

/// What the case says about the body and the run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaseSetup {
    pub application: String,
    pub end_time_s: f64,
    pub mass_kg: f64,
    /// The constant body acceleration that stands for the applied force, m/s^2.
    pub g: [f64; 3],
    pub rho: f64,
}

impl CaseSetup {
    pub fn applied_force(&self) -> [f64; 3] {
        self.g.map(|g| g * self.mass_kg)
    }
}

fn read_dict(case: &Path, rel: &str, shown: &str) -> anyhow::Result<dict::Dict> {
    let text = std::fs::read_to_string(case.join(rel)).map_err(|e| {
        InputError::file(
            format!("{shown}/{rel}"),
            format!("cannot read: {e}"),
            "an OpenFOAM case needs system/controlDict and constant/dynamicMeshDict",
        )
    })?;
    dict::parse(&text).map_err(|e| {
        InputError::file(
            format!("{shown}/{rel}"),
            e.to_string(),
            "check the dictionary's braces and semicolons",
        )
        .into()
    })
}

/// Reads the solver, end time, body mass and applied force from `system/controlDict` and
/// `constant/dynamicMeshDict` (coefficients inside `sixDoFRigidBodyMotionCoeffs`, or at the
/// top level as some tutorials write them). `shown` is the case's path for messages.
pub fn read_setup(case: &Path, shown: &str) -> anyhow::Result<CaseSetup> {
    let control = read_dict(case, "system/controlDict", shown)?;
    let dyn_mesh = read_dict(case, "constant/dynamicMeshDict", shown)?;
    let err = |rel: &str, e: dict::DictError, fix: &str| {
        InputError::file(format!("{shown}/{rel}"), e.to_string(), fix.to_string())
    };
    let application = control
        .value("application")
        .and_then(|v| v.first())
        .cloned()
        .ok_or_else(|| {
            InputError::file(
                format!("{shown}/system/controlDict"),
                "no `application` entry",
                "name the solver, e.g. `application pimpleFoam;`",
            )
        })?;
    let end = dict::numbers(&[&control], "endTime")
        .map_err(|e| err("system/controlDict", e, "set `endTime`"))?;
    let mut scopes = vec![&dyn_mesh];
    if let Some(c) = dyn_mesh.dict("sixDoFRigidBodyMotionCoeffs") {
        scopes.push(c);
    }
    let fix = "the sixDoFRigidBodyMotion coefficients need `mass` and `g` (the applied force as a body acceleration, F/m)";
    let mass =
        dict::numbers(&scopes, "mass").map_err(|e| err("constant/dynamicMeshDict", e, fix))?;
    let g = dict::numbers(&scopes, "g").map_err(|e| err("constant/dynamicMeshDict", e, fix))?;
    let rho = dict::numbers(&scopes, "rhoInf").unwrap_or_else(|_| vec![1000.0]);
    let ([mass], [gx, gy, gz], [rho]) = (&mass[..], &g[..], &rho[..]) else {
        return Err(InputError::file(
            format!("{shown}/constant/dynamicMeshDict"),
            "`mass` must be one number and `g` a vector (x y z)",
            fix,
        )
        .into());
    };
    anyhow::ensure!(
        *mass > 0.0,
        InputError::file(
            format!("{shown}/constant/dynamicMeshDict"),
            format!("body mass {mass} is not positive"),
            fix
        )
    );
    Ok(CaseSetup {
        application,
        end_time_s: end.first().copied().unwrap_or(0.0),
        mass_kg: *mass,
        g: [*gx, *gy, *gz],
        rho: *rho,
    })
}

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

/// The body's motion and the fluid force on it over time, from a finished run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Track {
    pub t: Vec<f64>,
    pub position: Vec<[f64; 3]>,
    pub velocity: Vec<[f64; 3]>,
    pub omega: Vec<[f64; 3]>,
    /// Total (pressure + viscous) fluid force on the body's patches, N, when the case writes it.
    pub fluid_force: Option<Vec<[f64; 3]>>,
}

#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(
        "{solver} stopped with an error after {steps} steps ({why}); last lines of {log}:\n{tail}"
    )]
    Crashed {
        solver: String,
        steps: usize,
        why: String,
        log: String,
        tail: String,
    },
    #[error(
        "the body's velocity reached {speed:.3e} m/s at t = {t} s: the run diverged (lower deltaT or maxCo, or relax the body's acceleration with accelerationRelaxation); last lines of {log}:\n{tail}"
    )]
    Diverged {
        speed: f64,
        t: f64,
        log: String,
        tail: String,
    },
    #[error("{0}")]
    Results(String),
}

/// Reads a run's results in `dir` (a case folder or a scratch copy): the state table when the
/// case writes one, otherwise the motion the solver reports in its log.
pub fn read_track(dir: &Path, solver: &str) -> anyhow::Result<(Track, results::Log, String)> {
    let log_name = format!("log.{solver}");
    let log_text = std::fs::read_to_string(dir.join(&log_name))
        .map_err(|e| RunError::Results(format!("cannot read {log_name}: {e}")))?;
    let log = results::parse_log(&log_text);
    let tail = results::tail(&log_text, 25);
    if let LogEnd::Crashed(why) = &log.end {
        return Err(RunError::Crashed {
            solver: solver.into(),
            steps: log.steps.len(),
            why: why.clone(),
            log: log_name,
            tail,
        }
        .into());
    }
    let table = |rel: &str| -> anyhow::Result<Option<VectorTable>> {
        match std::fs::read_to_string(dir.join(rel)) {
            Ok(text) => Ok(Some(
                results::parse_vector_table(&text)
                    .map_err(|e| RunError::Results(format!("{rel}: {e}")))?,
            )),
            Err(_) => Ok(None),
        }
    };
    let mut track = match table(STATE)? {
        Some(st) => {
            let get = |c: &str| {
                st.column(c)
                    .ok_or_else(|| RunError::Results(format!("{STATE} has no `{c}` column")))
            };
            Track {
                t: st.t.clone(),
                position: get("centreOfMass")?,
                velocity: get("velocity")?,
                omega: get("omega")?,
                fluid_force: None,
            }
        }
        None => {
            let steps: Vec<&results::LogStep> = log
                .steps
                .iter()
                .filter(|s| s.linear_velocity.is_some())
                .collect();
            Track {
                t: steps.iter().map(|s| s.t).collect(),
                position: steps.iter().map(|s| s.centre.unwrap_or_default()).collect(),
                velocity: steps
                    .iter()
                    .map(|s| s.linear_velocity.unwrap_or_default())
                    .collect(),
                omega: steps
                    .iter()
                    .map(|s| s.angular_velocity.unwrap_or_default())
                    .collect(),
                fluid_force: None,
            }
        }
    };
    if track.t.is_empty() {
        return Err(RunError::Results(format!(
            "no time step of the body's motion in {log_name} or {STATE}"
        ))
        .into());
    }
    if let Some(ft) = table(FORCE)? {
        // Same time steps as the motion: match by time, the force table may start earlier or end later.
        let total = ft
            .column(ft.columns.first().map_or("", String::as_str))
            .unwrap_or_default();
        let mut out = Vec::with_capacity(track.t.len());
        let mut j = 0;
        for &t in &track.t {
            while j + 1 < ft.t.len() && ft.t[j] < t - 1e-9 {
                j += 1;
            }
            match ft.t.get(j) {
                Some(&tf) if (tf - t).abs() <= 1e-9 * t.abs().max(1.0) => out.push(total[j]),
                _ => break,
            }
        }
        if out.len() == track.t.len() {
            track.fluid_force = Some(out);
        }
    }
    for (k, v) in track.velocity.iter().enumerate() {
        let speed = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !speed.is_finite() || speed > 1e3 {
            return Err(RunError::Diverged {
                speed,
                t: track.t[k],
                log: log_name,
                tail,
            }
            .into());
        }
    }
    if log.end != LogEnd::Finished {
        return Err(RunError::Results(format!("{log_name} stops at t = {} s without `End`: the solver was killed or is still running; last lines:\n{tail}", log.steps.last().map_or(0.0, |s| s.t))).into());
    }
    Ok((track, log, log_text))
}

/// Files a run leaves that hydrofit keeps (in the cache and next to the case).
pub fn result_files(solver: &str) -> Vec<String> {
    vec![
        "log.blockMesh".into(),
        format!("log.{solver}"),
        STATE.into(),
        FORCE.into(),
    ]
}

/// Where a case's results come from in this build. A fresh run's scratch folder lives as
/// long as this value.
pub struct Results {
    pub dir: PathBuf,
    pub stamp: Stamp,
    /// True when this build ran the solver.
    pub ran: bool,
    pub notes: Vec<String>,
    _scratch: Option<tempfile::TempDir>,
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
) -> anyhow::Result<Results> {
    let solver = setup.application.clone();
    let stamp: Option<Stamp> = std::fs::read_to_string(case_dir.join(STAMP))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    let has_results = case_dir.join(format!("log.{solver}")).exists();
    let mut notes = Vec::new();
    let (dir, stamp, ran, scratch) = if stamp.as_ref().is_some_and(|s| s.inputs == identity)
        && has_results
    {
        (case_dir.to_path_buf(), stamp.expect("checked"), false, None)
    } else if solver_available(&solver) {
        let scratch = tempfile::Builder::new()
            .prefix("hydrofit-openfoam-")
            .tempdir()?;
        let end = setup.end_time_s;
        message(format!("{solver}: meshing"));
        let label = solver.clone();
        let progress = move |t: f64| {
            message(format!(
                "{label} t = {t:.2} / {end} s ({:.0} %)",
                100.0 * t / end.max(1e-12)
            ))
        };
        let stamp = run(case_dir, files, scratch.path(), setup, &progress, identity)
            .map_err(|e| anyhow::anyhow!("case {case_rel}: {e}"))?;
        (scratch.path().to_path_buf(), stamp, true, Some(scratch))
    } else if has_results && stamp.is_none() {
        notes.push(format!("results in {case_rel} were not produced by hydrofit (no {}): used as they are, unverified against the case's inputs", STAMP));
        (
            case_dir.to_path_buf(),
            Stamp {
                inputs: identity.to_string(),
                solver: solver.clone(),
                openfoam: String::new(),
                steps: 0,
                execution_time_s: None,
                clock_time_s: None,
            },
            false,
            None,
        )
    } else {
        let what = if has_results {
            "the case's inputs changed since its results were produced"
        } else {
            "the case has never been run"
        };
        return Err(InputError::file(
            case_rel,
            format!("{what}, and {solver} (OpenFOAM) is not installed here"),
            INSTALL_HINT,
        )
        .into());
    };
    Ok(Results {
        dir,
        stamp,
        ran,
        notes,
        _scratch: scratch,
    })
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
    for rel in inputs {
        let to = scratch.join(rel);
        std::fs::create_dir_all(to.parent().expect("has a parent"))?;
        std::fs::copy(case.join(rel), &to)?;
    }
    let wm = project_dir().ok_or_else(|| {
        anyhow::anyhow!("OpenFOAM's etc folder was not found (set WM_PROJECT_DIR); {INSTALL_HINT}")
    })?;
    let mut steps_run = Vec::new();
    let mut build_line = String::new();
    let mut tools: Vec<&str> = Vec::new();
    if inputs.iter().any(|i| i == "system/blockMeshDict") {
        tools.push("blockMesh");
    }
    tools.push(&setup.application);
    for tool in tools {
        let log_path = scratch.join(format!("log.{tool}"));
        let mut log = std::io::BufWriter::new(std::fs::File::create(&log_path)?);
        let reader = duct::cmd!(tool)
            .dir(scratch)
            .env("WM_PROJECT_DIR", &wm)
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
                build_line = b.trim().to_string();
            }
        }
        log.flush()?;
        let status = reader.try_wait()?.map(|o| o.status);
        let text = std::fs::read_to_string(&log_path).unwrap_or_default();
        if tool == setup.application {
            // The log decides: a crash, a divergence or a truncation is reported with its tail.
            let parsed = results::parse_log(&text);
            steps_run = parsed.steps;
            if let LogEnd::Crashed(why) = parsed.end {
                return Err(RunError::Crashed {
                    solver: tool.into(),
                    steps: steps_run.len(),
                    why,
                    log: format!("log.{tool}"),
                    tail: results::tail(&text, 25),
                }
                .into());
            }
        }
        if !status.is_some_and(|s| s.success()) {
            let code = status
                .and_then(|s| s.code())
                .map_or("killed by a signal".to_string(), |c| {
                    format!("exit status {c}")
                });
            return Err(RunError::Crashed {
                solver: tool.into(),
                steps: steps_run.len(),
                why: code,
                log: format!("log.{tool}"),
                tail: results::tail(&text, 25),
            }
            .into());
        }
    }
    let (_, log, _) = read_track(scratch, &setup.application)?;
    Ok(Stamp {
        inputs: stamp_inputs.into(),
        solver: setup.application.clone(),
        openfoam: build_line,
        steps: log.steps.len(),
        execution_time_s: log.execution_time_s,
        clock_time_s: log.clock_time_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_are_not_inputs() {
        for rel in [
            "system/controlDict",
            "constant/dynamicMeshDict",
            "0/U",
            "Allrun",
            "constant/triSurface/body.stl",
        ] {
            assert!(is_case_input(rel), "{rel}");
        }
        for rel in [
            "log.pimpleFoam",
            "postProcessing/forces/0/force.dat",
            "4/U",
            "0.5/uniform/time",
            "constant/polyMesh/points",
            "processor0/0/U",
            STAMP,
        ] {
            assert!(!is_case_input(rel), "{rel}");
        }
    }

    #[test]
    fn the_generated_case_says_its_force_and_mass() {
        let dir = tempfile::tempdir().unwrap();
        let c = case::CylinderCase {
            force_n: 4.0,
            mass_kg: 94.248,
            radius_m: 0.1,
            end_time_s: Some(3.0),
        };
        c.write(&dir.path().join("c")).unwrap();
        let s = read_setup(&dir.path().join("c"), "c").unwrap();
        assert_eq!(s.application, "pimpleFoam");
        assert_eq!(s.end_time_s, 3.0);
        assert_eq!(s.mass_kg, 94.248);
        assert!((s.applied_force()[0] - 4.0).abs() < 1e-12 && s.applied_force()[1] == 0.0);
        assert_eq!(s.rho, 1000.0);
    }
}

/// How the case's results came about; shown in the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunInfo {
    pub solver: String,
    pub openfoam: String,
    /// True when this build ran the solver; false when it read results left in the case.
    pub ran_in_this_build: bool,
    pub steps: usize,
    pub end_time_s: f64,
    pub cpu_time_s: Option<f64>,
    pub wall_time_s: Option<f64>,
    pub applied_force_n: [f64; 3],
    pub mass_kg: f64,
    pub rho: f64,
}

/// The body's path and the fluid force on it, for the report's drag analysis.
pub const TRACK: &str = "track.json";

pub fn load_track(dir: &Path) -> Option<Track> {
    crate::fsutil::read_json(&dir.join(TRACK)).ok()
}
