//! `kind: compare` — every listed estimator on the same CFD cases, side by side, as seed 001's
//! Table 2 does: parameters, error against a known truth (when the cases come from a twin),
//! validation error on the pool runs, run time and objective evaluations.

use super::{Artifact, Kind, RunCtx, StageImpl, fit, parse_as};
use crate::estimate::comparison::{Comparison, RESULT, Row};
use crate::estimate::identify;
use crate::io::response;
use crate::model::{ParamLayout, Plant};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub static KIND: Kind = Kind {
    consumes: &[Artifact::Responses, Artifact::PoolRuns],
    requires: &[Artifact::Responses],
    ..Kind::new("compare", Artifact::Comparison, parse_as::<Settings>)
};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {
    /// Each entry is a `fit` stage's settings.
    pub methods: Vec<fit::Settings>,
    /// Known parameter values (the twin's, for synthetic cases), to score each method against.
    pub truth: BTreeMap<String, f64>,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            methods: crate::estimate::names()
                .into_iter()
                .map(fit::Settings::of_method)
                .collect(),
            truth: BTreeMap::new(),
        }
    }
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        let methods: Vec<serde_json::Value> = self.methods.iter().map(|m| m.settings()).collect();
        serde_json::json!({"methods": methods, "truth": self.truth})
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let (mut responses, mut masses) = (Vec::new(), Vec::new());
        for up in ctx.upstream_of(Artifact::Responses) {
            let (meta, r) = response::load(&up.dir)?;
            responses.push(r);
            masses.push(meta.body_mass_kg);
        }
        let runs: Vec<crate::fusion::run::FusedRun> = ctx
            .upstream_of(Artifact::PoolRuns)
            .map(|u| crate::fusion::run::load_for(&u.dir, ctx.vehicle))
            .collect::<Result<_, _>>()?;
        let held_out: Vec<&crate::fusion::run::FusedRun> = if runs
            .iter()
            .any(|r| r.meta.role == crate::io::pool::Role::Validate)
        {
            runs.iter()
                .filter(|r| r.meta.role == crate::io::pool::Role::Validate)
                .collect()
        } else {
            runs.iter().collect()
        };
        let mut rows = Vec::new();
        let mut samples = 0;
        for (i, m) in self.methods.iter().enumerate() {
            ctx.progress
                .set_message(format!("{} ({}/{})", m.label(), i + 1, self.methods.len()));
            let data = identify::Data {
                vehicle: ctx.vehicle,
                cases: responses
                    .iter()
                    .zip(&masses)
                    .map(|(r, m)| (r, *m))
                    .collect(),
                pool: vec![],
                skip_start_s: m.common.skip_start_s,
            };
            let req = identify::Request {
                method: &m.method,
                objective: m.common.objective,
                added_mass_window_s: None,
                progress: None,
            };
            let start = std::time::Instant::now();
            let fit = identify::identify(&data, &req).map(|id| {
                samples = id.rows;
                id.fit
            });
            let seconds = start.elapsed().as_secs_f64();
            let mut row = Row {
                label: m.label(),
                settings: m.settings(),
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
                Ok(fit) => {
                    row.error_pct = relative_errors_pct(&fit.parameters, &self.truth);
                    row.max_abs_error_pct =
                        row.error_pct.values().map(|e| e.abs()).reduce(f64::max);
                    let theta: Vec<f64> = fit.parameters.iter().map(|p| p.value).collect();
                    let plant =
                        Plant::new(ctx.vehicle, ParamLayout::of(ctx.vehicle).to_hydro(&theta));
                    row.pool_nmae =
                        crate::validate::pool::mean_nmae(&plant, &held_out, &ctx.vehicle.dofs);
                    row.evaluations = fit.evaluations;
                    row.parameters = fit.parameters;
                }
            }
            rows.push(row);
        }
        let result = Comparison {
            rows,
            samples,
            cases: responses.len(),
            pool_runs: held_out.iter().map(|r| r.meta.run.clone()).collect(),
        };
        super::write_json(&ctx.out.join(RESULT), &result)
    }
}

/// Error of each estimate against the known value, % of that value's magnitude.
fn relative_errors_pct(
    params: &[crate::estimate::Estimate],
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
