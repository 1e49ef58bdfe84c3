//! OpenFOAM DFBI cases: which files of a case folder are its inputs, reading the applied
//! force and body mass from the case, running it (blockMesh, then the solver) through duct,
//! and reading the body's motion back from what the run leaves.

pub mod case;
pub mod case_run;
pub mod dict;
mod on_slurm;
pub mod report;
pub mod results;
pub mod series;
mod solve;
pub mod stage;
mod steps;
pub mod table;

use crate::core::diag::InputError;
pub use crate::core::response::RunInfo;
pub use on_slurm::{ArrayCase, ArrayJob, submit_array};
use results::{LogEnd, VectorTable};
use serde::{Deserialize, Serialize};
pub use solve::{Executor, Results, obtain_results, run, solver_available};
use std::path::Path;

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
    /// The Slurm job that ran it, and its node, when one did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slurm_job: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<String>,
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
    let path = case.join(rel);
    if path.is_dir() {
        return Err(InputError::file(
            format!("{shown}/{rel}"),
            "is a folder, where OpenFOAM's dictionary file is expected",
            "replace the folder by the dictionary (an OpenFOAM case needs system/controlDict and constant/dynamicMeshDict as files)",
        )
        .into());
    }
    let text = std::fs::read_to_string(&path).map_err(|e| {
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
        mass.is_finite() && *mass > 0.0,
        InputError::file(
            format!("{shown}/constant/dynamicMeshDict"),
            format!("body mass {mass} is not a positive number"),
            fix
        )
    );
    anyhow::ensure!(
        [*gx, *gy, *gz, *rho].iter().all(|x| x.is_finite()) && *rho > 0.0,
        InputError::file(
            format!("{shown}/constant/dynamicMeshDict"),
            format!("g ({gx} {gy} {gz}) and rhoInf ({rho}) must be finite, rhoInf positive"),
            fix
        )
    );
    let end_time = end.first().copied().unwrap_or(0.0);
    anyhow::ensure!(
        end_time.is_finite() && end_time > 0.0,
        InputError::file(
            format!("{shown}/system/controlDict"),
            format!("endTime {end_time} is not a positive number of seconds"),
            "set `endTime` to the simulated time, e.g. `endTime 3;`"
        )
    );
    Ok(CaseSetup {
        application,
        end_time_s: end_time,
        mass_kg: *mass,
        g: [*gx, *gy, *gz],
        rho: *rho,
    })
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
    /// The file the motion was read from (the state table, or the solver log when the case
    /// writes no table).
    #[serde(default)]
    pub source: String,
    /// What the report says of how the motion and the force were read (a source used in
    /// place of another, a force table that does not cover the run).
    #[serde(default)]
    pub notes: Vec<String>,
    /// The source's line of each row, for messages.
    #[serde(skip)]
    pub lines: Vec<usize>,
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
        "{log}: the body's velocity reached {speed:.3e} m/s at t = {t} s: the run diverged (lower deltaT or maxCo, or relax the body's acceleration with accelerationRelaxation), or the file was damaged (then rerun the case); last lines of the solver's log:\n{tail}"
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
    let mut track = match read_table(dir, STATE)? {
        Some(st) => track_from_state(&st, &log, &log_name)?,
        None => {
            let mut track = track_from_log(&log, &log_name);
            if !track.t.is_empty() {
                track.notes.push(format!(
                    "the body's motion was read from {log_name}: the case writes no {STATE} (add the sixDoFRigidBodyState function object to controlDict for the full precision)"
                ));
            }
            track
        }
    };
    if track.t.is_empty() {
        return Err(RunError::Results(format!(
            "no time step of the body's motion in {log_name} or {STATE}"
        ))
        .into());
    }
    if let Some(ft) = read_table(dir, FORCE)? {
        match force_at(&ft, &track.t) {
            Some(f) => track.fluid_force = Some(f),
            None => track.notes.push(force_gap(&ft, &track.t)),
        }
    }
    check_speed(&track, &tail)?;
    if log.end != LogEnd::Finished {
        return Err(RunError::Results(format!("{log_name} stops at t = {} s without `End`: the solver was killed or is still running; last lines:\n{tail}", log.steps.last().map_or(0.0, |s| s.t))).into());
    }
    Ok((track, log, log_text))
}

/// Why the force table gave no fluid force for the motion's times.
fn force_gap(ft: &VectorTable, times: &[f64]) -> String {
    let (t0, t1) = (times[0], times[times.len() - 1]);
    if ft.columns.is_empty() && !ft.t.is_empty() {
        return format!(
            "{FORCE} has no header line naming its columns: the fluid force is left out of the report's drag analysis (rerun the case to write the table again)"
        );
    }
    match (ft.t.first(), ft.t.last()) {
        (Some(a), Some(b)) => format!(
            "{FORCE} covers t = {a} to {b} s, not every time step of the motion (t = {t0} to {t1} s): the fluid force is left out of the report's drag analysis (the table was cut or written at other times)"
        ),
        _ => {
            format!("{FORCE} has no row: the fluid force is left out of the report's drag analysis")
        }
    }
}

/// The vector table `rel` of a run in `dir`, when the case writes it.
/// A file that is there but cannot be read (a folder, a symbolic link to nowhere or to
/// itself) is an error, never taken for a missing table.
fn read_table(dir: &Path, rel: &str) -> anyhow::Result<Option<VectorTable>> {
    let path = dir.join(rel);
    if std::fs::symlink_metadata(&path).is_err() {
        return Ok(None);
    }
    match crate::core::input::read_path(&path, rel, "the table is written by OpenFOAM as text") {
        Ok(text) => Ok(Some(
            results::parse_vector_table(&text.text)
                .map_err(|e| RunError::Results(format!("{rel}: {e}")))?,
        )),
        Err(e) => Err(e.into()),
    }
}

/// The body's motion from the sixDoFRigidBodyState table, which must run as far as the
/// solver's log when the log says the run finished.
fn track_from_state(
    st: &VectorTable,
    log: &results::Log,
    log_name: &str,
) -> Result<Track, RunError> {
    if st.t.is_empty() {
        return Err(RunError::Results(format!(
            "{STATE} has no row: the run wrote no motion to it; rerun the case, or delete the table to read the body's motion from {log_name}"
        )));
    }
    let get = |c: &str| {
        st.column(c).ok_or_else(|| {
            RunError::Results(format!(
                "{STATE} has no `{c}` column (its header names: {}); it is not a sixDoFRigidBodyState table, or its header line was damaged",
                st.columns.join(", ")
            ))
        })
    };
    let last = st.t[st.t.len() - 1];
    let log_last = log.steps.last().map(|s| s.t);
    if let (LogEnd::Finished, Some(log_last)) = (&log.end, log_last) {
        let behind = log
            .steps
            .iter()
            .filter(|s| s.t > last * (1.0 + 1e-9) + 1e-12)
            .count();
        if behind > 0 {
            return Err(RunError::Results(format!(
                "{STATE} ends at t = {last} s (line {}) but {log_name} runs {behind} more time steps to t = {log_last} s and `End`: the table was cut; rerun the case, or delete the table to read the body's motion from {log_name}",
                st.lines.last().copied().unwrap_or(0)
            )));
        }
    }
    Ok(Track {
        t: st.t.clone(),
        position: get("centreOfMass")?,
        velocity: get("velocity")?,
        omega: get("omega")?,
        fluid_force: None,
        source: STATE.into(),
        notes: Vec::new(),
        lines: st.lines.clone(),
    })
}

/// The body's motion as the solver reports it in its log, at the steps that give a velocity.
fn track_from_log(log: &results::Log, log_name: &str) -> Track {
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
        source: log_name.into(),
        notes: Vec::new(),
        lines: steps.iter().map(|s| s.line).collect(),
    }
}

/// The total fluid force of table `ft` at each of the times `times`, when it has all of them.
fn force_at(ft: &VectorTable, times: &[f64]) -> Option<Vec<[f64; 3]>> {
    // Same time steps as the motion: match by time, the force table may start earlier or end later.
    let total = ft
        .column(ft.columns.first().map_or("", String::as_str))
        .unwrap_or_default();
    if total.len() != ft.t.len() {
        return None;
    }
    let mut out = Vec::with_capacity(times.len());
    let mut j = 0;
    for &t in times {
        while j + 1 < ft.t.len() && ft.t[j] < t - 1e-9 {
            j += 1;
        }
        match ft.t.get(j) {
            Some(&tf) if (tf - t).abs() <= 1e-9 * t.abs().max(1.0) => out.push(total[j]),
            _ => break,
        }
    }
    (out.len() == times.len()).then_some(out)
}

/// A body speed that is not finite or above 1 km/s is a diverged run, or a damaged file.
fn check_speed(track: &Track, tail: &str) -> Result<(), RunError> {
    for (k, v) in track.velocity.iter().enumerate() {
        let speed = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !speed.is_finite() || speed > 1e3 {
            return Err(RunError::Diverged {
                speed,
                t: track.t[k],
                log: match track.lines.get(k) {
                    Some(l) => format!("{} line {l}", track.source),
                    None => track.source.clone(),
                },
                tail: tail.to_string(),
            });
        }
    }
    Ok(())
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

/// The body's path and the fluid force on it, for the report's drag analysis.
pub const TRACK: &str = "track.json";

pub fn load_track(dir: &Path) -> Option<Track> {
    crate::core::fsutil::read_json(&dir.join(TRACK)).ok()
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
