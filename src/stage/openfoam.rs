//! `kind: openfoam` — one instance per OpenFOAM case folder: runs the case (blockMesh, then
//! its solver) when its inputs have no results yet, or reuses the results a run of exactly
//! these inputs left in the folder, and turns the body's motion into a response table.

use super::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use crate::dof::Dof;
use crate::io::Response;
use crate::io::response::{META, ResponseMeta, TABLE};
use crate::io::response::{Series, Source, differentiate};
use crate::openfoam::{self, Track};
use crate::provenance::InputFile;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

pub static KIND: Kind = Kind {
    fan_out: true,
    input_filter: Some(openfoam::is_case_input),
    uses_vehicle: super::VehicleUse::Dofs,
    ..Kind::new("openfoam", Artifact::Responses, parse_as::<Settings>)
};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {
    /// Write the results of a run back into the case folder (log, postProcessing, the run
    /// stamp), as running the case by hand would, so the project builds without OpenFOAM.
    pub keep_results_in_case: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            keep_results_in_case: true,
        }
    }
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let control = ctx
            .inputs
            .iter()
            .find_map(|i| i.path.strip_suffix("/system/controlDict"))
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "{}: not an OpenFOAM case (no system/controlDict)",
                    ctx.inputs.first().map_or("?", |i| i.path.as_str())
                )
            })?;
        let case_rel = control.to_string();
        let case_dir = ctx.root.join(&case_rel);
        let name = Path::new(&case_rel)
            .file_name()
            .map_or(case_rel.clone(), |n| n.to_string_lossy().into_owned());
        let local: Vec<(String, String)> = ctx
            .inputs
            .iter()
            .map(|i| (i.path[case_rel.len() + 1..].to_string(), i.blake3.clone()))
            .collect();
        let identity = openfoam::inputs_hash(&local);
        let setup = openfoam::read_setup(&case_dir, &case_rel)?;
        let solver = setup.application.clone();

        let bar = ctx.progress;
        let message = move |m: String| bar.set_message(m);
        let files: Vec<String> = local.iter().map(|(p, _)| p.clone()).collect();
        let results =
            openfoam::obtain_results(&case_dir, &case_rel, &files, &setup, &identity, &message)?;
        let (source_dir, stamp, ran, notes) = (
            results.dir.clone(),
            results.stamp.clone(),
            results.ran,
            results.notes.clone(),
        );

        let (track, log, _) = openfoam::read_track(&source_dir, &solver)
            .map_err(|e| anyhow::anyhow!("case {case_rel}: {e}"))?;
        for rel in openfoam::result_files(&solver) {
            if let Ok(bytes) = std::fs::read(source_dir.join(&rel)) {
                let flat = rel.replace('/', "_");
                crate::fsutil::write_atomic(&ctx.out.join(flat), &bytes)?;
                if ran && self.keep_results_in_case {
                    let to = case_dir.join(&rel);
                    std::fs::create_dir_all(to.parent().expect("has a parent"))?;
                    crate::fsutil::write_atomic(&to, &bytes)?;
                }
            }
        }
        if ran && self.keep_results_in_case {
            // Last: the stamp vouches for the files written before it.
            crate::fsutil::write_atomic(
                &case_dir.join(openfoam::STAMP),
                serde_json::to_string_pretty(&stamp)?.as_bytes(),
            )?;
        }
        let response = to_response(&track, &setup, &ctx.vehicle.dofs);
        anyhow::ensure!(
            !response.dofs.is_empty(),
            "case {case_rel}: the body neither moves nor is pushed in any of the vehicle's DOFs"
        );
        response.write_parquet(&ctx.out.join(TABLE))?;
        super::write_json(&ctx.out.join(openfoam::TRACK), &track)?;
        let info = openfoam::RunInfo {
            solver: solver.clone(),
            openfoam: stamp.openfoam.clone(),
            ran_in_this_build: ran,
            steps: log.steps.len(),
            end_time_s: setup.end_time_s,
            cpu_time_s: log.execution_time_s.or(stamp.execution_time_s),
            wall_time_s: log.clock_time_s.or(stamp.clock_time_s),
            applied_force_n: setup.applied_force(),
            mass_kg: setup.mass_kg,
            rho: setup.rho,
        };
        let meta = ResponseMeta {
            case: name,
            source: InputFile {
                path: format!("{case_rel}/constant/dynamicMeshDict"),
                blake3: ctx
                    .inputs
                    .iter()
                    .find(|i| i.path.ends_with("constant/dynamicMeshDict"))
                    .map_or(String::new(), |i| i.blake3.clone()),
            },
            dofs: response.dofs.keys().copied().collect(),
            sources: response.sources(),
            rows_read: track.t.len(),
            rows_kept: response.len(),
            notes,
            body_mass_kg: Some(setup.mass_kg),
            all_inputs: ctx.inputs.to_vec(),
            openfoam: Some(info),
        };
        super::write_json(&ctx.out.join(META), &meta)
    }
}

/// The body starts at rest at t = 0 (the state table begins at the first step).
fn to_response(track: &Track, setup: &openfoam::CaseSetup, dofs: &[Dof]) -> Response {
    let mut t = vec![0.0];
    t.extend(track.t.iter().copied().filter(|&x| x > 0.0));
    let skip = track.t.len() + 1 - t.len();
    let force = setup.applied_force();
    let mut out = Response {
        t: t.clone(),
        dofs: BTreeMap::new(),
    };
    for d in dofs {
        let (series, f): (Vec<f64>, f64) = match d {
            Dof::Surge => (track.velocity.iter().map(|v| v[0]).collect(), force[0]),
            Dof::Sway => (track.velocity.iter().map(|v| v[1]).collect(), force[1]),
            Dof::Heave => (track.velocity.iter().map(|v| v[2]).collect(), force[2]),
            Dof::Yaw => (track.omega.iter().map(|v| v[2]).collect(), 0.0),
            _ => continue,
        };
        let mut velocity = vec![0.0];
        velocity.extend(series[skip..].iter().copied());
        if f == 0.0 && velocity.iter().all(|v| v.abs() < 1e-9) {
            continue;
        }
        let accel = differentiate(&t, &velocity);
        out.dofs.insert(
            *d,
            Series {
                force: vec![f; t.len()],
                velocity,
                accel,
                force_source: Source::Case,
                accel_source: Source::Differentiated,
            },
        );
    }
    out
}
