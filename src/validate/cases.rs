//! Identified models scored on CFD cases, as the `validate` stage stores them: each model
//! simulated under each case's applied force from the case's first state, the simulation kept
//! for the report's plots and OpenFOAM sections.
//!
//! Which model is scored on which case: a model of the vehicle on every case of the vehicle
//! (`train` where it was fitted on it, `validate` otherwise), a model of another body (the
//! OpenFOAM cylinder, whose fit states its own vehicle) on its own training cases only, and no
//! model of the vehicle on a case of another body (a case that states its body's mass).

use super::Metrics;
use crate::core::dof::Dof;
use crate::core::model::{Plant, Vec6, Vehicle};
use crate::core::response::{Response, ResponseMeta};
use crate::identify::result::FitResult;
use crate::pipeline::contract::{Artifact, RunCtx, Upstream};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A CFD case as validation reads it.
pub struct Case {
    /// The instance id of the import that produced it (what a fit lists as its cases).
    pub id: String,
    pub name: String,
    pub response: Response,
    /// The body mass the case states (OpenFOAM), which replaces the vehicle's.
    pub mass: Option<f64>,
}

/// One model on one CFD case.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CaseScore {
    pub model: String,
    /// The case's name and the id of its import.
    pub case: String,
    pub case_id: String,
    /// `train` when the model was fitted on the case, else `validate`.
    pub role: String,
    /// Metrics per DOF the case moves in.
    pub scores: Vec<(Dof, Metrics)>,
    /// The model's velocities (u, v, w, p, q, r) at the case's samples; not finite where it
    /// diverged.
    pub simulated: Vec<Vec6>,
}

/// The file the scores are stored in.
pub const CASES: &str = "cases.json";

/// Every model of `fits` on every case of `cases` it may be scored on (see the module's
/// notes), cases in their order.
pub fn score_cases(vehicle: &Vehicle, fits: &[FitResult], cases: &[Case]) -> Vec<CaseScore> {
    let mut out = Vec::new();
    for f in fits {
        let hydro = f.hydro();
        let own_vehicle = f.vehicle.as_ref().unwrap_or(vehicle);
        for c in cases {
            let trained = f.cases.iter().any(|x| x.id == c.id);
            let other_body_model = f.vehicle.is_some();
            if (other_body_model && !trained) || (!other_body_model && c.mass.is_some()) {
                continue;
            }
            let mut v = own_vehicle.clone();
            if let Some(m) = c.mass {
                v.mass_kg = m;
            }
            let sim = c.response.simulate(&Plant::new(&v, hydro));
            out.push(CaseScore {
                model: f.stage.clone(),
                case: c.name.clone(),
                case_id: c.id.clone(),
                role: if trained { "train" } else { "validate" }.into(),
                scores: super::score(&c.response, &sim),
                simulated: sim,
            });
        }
    }
    out
}

/// The CFD responses among a stage's upstream, each with the import it came from and its
/// metadata, in the natural order of the case names (`surge_2N` before `surge_10N`): what the
/// validate stage scores and the report shows, in the same order.
pub fn upstream_responses<'c>(
    ctx: &'c RunCtx,
) -> anyhow::Result<Vec<(&'c Upstream, ResponseMeta, Response)>> {
    let mut out = Vec::new();
    for u in ctx.upstream_of(Artifact::Responses) {
        let (meta, response) = crate::core::response::load(&u.dir)?;
        out.push((u, meta, response));
    }
    out.sort_by(|a, b| crate::core::natural::cmp(&a.1.case, &b.1.case));
    Ok(out)
}

/// The case scores a validate stage stored in `dir` (none when it read no CFD case).
pub fn load(dir: &Path) -> anyhow::Result<Vec<CaseScore>> {
    let path = dir.join(CASES);
    if !path.exists() {
        return Ok(vec![]);
    }
    crate::core::fsutil::read_json(&path)
}
