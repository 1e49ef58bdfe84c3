//! An OpenFOAM case's run as a response table: the body's velocity per DOF under the constant
//! force the case applies, its acceleration differentiated.

use crate::cfd::openfoam::case_run::CaseRun;
use crate::cfd::openfoam::{CaseSetup, Track};
use crate::core::dof::Dof;
use crate::core::provenance::InputFile;
use crate::core::response::Response;
use crate::core::response::{ResponseMeta, Series, Source, differentiate};
use std::collections::BTreeMap;

/// The case's response in the DOFs of `dofs` the body moves or is pushed in, and what the
/// table says of it; an error when that is none of them.
pub fn import(case: &CaseRun, dofs: &[Dof]) -> anyhow::Result<(Response, ResponseMeta)> {
    let response = to_response(&case.track, &case.setup, dofs);
    anyhow::ensure!(
        !response.dofs.is_empty(),
        "case {}: the body neither moves nor is pushed in any of the vehicle's DOFs",
        case.rel
    );
    let meta = ResponseMeta {
        case: case.name(),
        source: InputFile::new(
            format!("{}/constant/dynamicMeshDict", case.rel),
            case.inputs
                .iter()
                .find(|i| i.path.ends_with("constant/dynamicMeshDict"))
                .map_or(String::new(), |i| i.blake3.clone()),
        ),
        dofs: response.dofs.keys().copied().collect(),
        sources: response.sources(),
        rows_read: case.track.t.len(),
        rows_kept: response.len(),
        notes: case
            .results
            .notes
            .iter()
            .chain(&case.track.notes)
            .cloned()
            .collect(),
        body_mass_kg: Some(case.setup.mass_kg),
        per_metre_of_span: case.two_dimensional(),
        all_inputs: case.inputs.clone(),
        openfoam: Some(case.info()),
    };
    Ok((response, meta))
}

/// The body starts at rest at t = 0 (the state table begins at the first step).
fn to_response(track: &Track, setup: &CaseSetup, dofs: &[Dof]) -> Response {
    let mut t = vec![0.0];
    t.extend(track.t.iter().copied().filter(|&x| x > 0.0));
    let skip = track.t.len() + 1 - t.len();
    let force = setup.applied_force();
    let mut out = Response {
        t: t.clone(),
        dofs: BTreeMap::new(),
        attitude: Vec::new(),
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
