//! Estimators side by side, as seed 001's Table 2 sets them (the `compare` stage): each
//! identified on the same CFD cases, scored against a known truth (when the cases come from a
//! twin) and simulated on the held-out pool runs.

pub mod artifact;
pub mod report;
pub mod stage;

use crate::core::model::{ParamLayout, Plant, Vehicle};
use crate::core::response::Response;
use crate::identify::fit::{self, Identified};
use crate::identify::result::Objective;
use crate::identify::{Estimate, Method};
use crate::pool::fusion::run::FusedRun;
use crate::pool::import::Role;
use crate::validate::pool::mean_nmae;
use artifact::{Comparison, Row};
use std::collections::BTreeMap;

/// One estimator configuration: how tables name it, its settings as keyed, and what it runs.
pub struct Candidate<'a> {
    pub label: String,
    pub settings: serde_json::Value,
    pub method: &'a Method,
    pub objective: Objective,
    /// Samples before this time in each case are left out.
    pub skip_start_s: f64,
}

/// What every candidate is compared on.
pub struct Data<'a> {
    pub vehicle: &'a Vehicle,
    /// CFD responses, with the body mass a case states when it does.
    pub cases: Vec<(&'a Response, Option<f64>)>,
    /// Known parameter values to score the estimates against (the twin's, for synthetic cases).
    pub truth: &'a BTreeMap<String, f64>,
    /// Pool runs; those of role `validate` score each model (all of them when none is).
    pub runs: &'a [FusedRun],
}

/// Every candidate identified on `data`'s cases and scored; `progress` hears which one runs.
pub fn compare(data: &Data, candidates: &[Candidate], progress: &dyn Fn(String)) -> Comparison {
    let held_out = held_out(data.runs);
    let mut rows = Vec::new();
    let mut samples = 0;
    for (i, c) in candidates.iter().enumerate() {
        if crate::core::interrupt::requested() {
            break;
        }
        progress(format!("{} ({}/{})", c.label, i + 1, candidates.len()));
        let start = std::time::Instant::now();
        let fit = identify(data, c).map(|id| {
            samples = id.rows;
            id.fit
        });
        let seconds = start.elapsed().as_secs_f64();
        let mut row = Row {
            label: c.label.clone(),
            settings: c.settings.clone(),
            parameters: vec![],
            error_pct: BTreeMap::new(),
            max_abs_error_pct: None,
            pool_nmae: None,
            seconds,
            evaluations: None,
            error: None,
        };
        match fit {
            Err(e) => row.error = Some(e.to_string()),
            Ok(fit) => score(&mut row, fit, data, &held_out),
        }
        rows.push(row);
    }
    Comparison {
        rows,
        samples,
        cases: data.cases.len(),
        pool_runs: held_out.iter().map(|r| r.meta.run.clone()).collect(),
    }
}

/// The runs that score the models: those of role `validate`, or all when none is.
fn held_out(runs: &[FusedRun]) -> Vec<&FusedRun> {
    if runs.iter().any(|r| r.meta.role == Role::Validate) {
        runs.iter()
            .filter(|r| r.meta.role == Role::Validate)
            .collect()
    } else {
        runs.iter().collect()
    }
}

/// One candidate identified on the cases alone (no pool runs, no added-mass window).
fn identify(data: &Data, c: &Candidate) -> anyhow::Result<Identified> {
    let d = fit::Data {
        vehicle: data.vehicle,
        cases: data.cases.clone(),
        pool: vec![],
        skip_start_s: c.skip_start_s,
    };
    let req = fit::Request {
        objective: c.objective,
        ..fit::Request::plain(c.method, &[])
    };
    fit::identify(&d, &req)
}

/// Fills a candidate's row from its fit: errors against the truth, the held-out pool NMAE of
/// its model, its evaluations and parameters.
fn score(row: &mut Row, fit: crate::identify::Fit, data: &Data, held_out: &[&FusedRun]) {
    row.error_pct = relative_errors_pct(&fit.parameters, data.truth);
    row.max_abs_error_pct = row.error_pct.values().map(|e| e.abs()).reduce(f64::max);
    let theta: Vec<f64> = fit.parameters.iter().map(|p| p.value).collect();
    let plant = Plant::new(data.vehicle, ParamLayout::of(data.vehicle).to_hydro(&theta));
    row.pool_nmae = mean_nmae(&plant, held_out, &data.vehicle.dofs);
    row.evaluations = fit.evaluations;
    row.parameters = fit.parameters;
}

/// Error of each estimate against the known value, % of that value's magnitude.
fn relative_errors_pct(
    params: &[Estimate],
    truth: &BTreeMap<String, f64>,
) -> BTreeMap<String, f64> {
    params
        .iter()
        .filter_map(|p| {
            let t = truth.get(&p.name)?;
            Some((p.name.clone(), 100.0 * (p.value - t) / t.abs()))
        })
        .collect()
}
