//! `kind: report` — validates every model on every CFD response it reads and writes the report.

use super::{fit, starccm, Artifact, Kind, RunCtx, StageImpl};
use crate::io::Response;
use crate::dof::Dof;
use crate::model::{ParamLayout, Plant, Vec6};
use std::collections::BTreeMap;
use crate::report::json::{self, ModelScore, RunScore, Validation};
use crate::report::{html, plots};
use crate::validate;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

pub static KIND: Kind = Kind {
    name: "report",
    version: 1,
    fan_out: false,
    produces: Artifact::Report,
    consumes: &[Artifact::Model, Artifact::Responses],
    requires: &[Artifact::Model],
    uses_vehicle: super::VehicleUse::All,
    publishes_to: Some("reports"),
    parse: |v| Ok(Arc::new(serde_yaml_ng::from_value::<Settings>(v)?)),
};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {}

pub const FILES: [&str; 3] = ["index.html", "parameters.json", "validation.json"];

struct Case {
    id: String,
    name: String,
    response: Response,
    notes: Vec<String>,
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let fits: Vec<fit::FitResult> = ctx.upstream_of(Artifact::Model).map(|u| fit::load(&u.dir)).collect::<Result<_, _>>()?;
        let mut cases = Vec::new();
        for u in ctx.upstream_of(Artifact::Responses) {
            let (meta, response) = starccm::load(&u.dir)?;
            cases.push(Case { id: u.id.clone(), name: meta.case, response, notes: meta.notes });
        }
        let mut models = Vec::new();
        let mut first_sims = Vec::new();
        for f in &fits {
            let layout = ParamLayout::new(&f.dofs);
            let theta: Vec<f64> = f.fit.parameters.iter().map(|p| p.value).collect();
            let plant = Plant::new(ctx.vehicle, layout.to_hydro(&theta));
            let mut runs = Vec::new();
            for c in &cases {
                let sim = validate::simulate_response(&plant, &c.response);
                let role = if f.cases.iter().any(|x| x.id == c.id) { "train" } else { "validate" };
                let dofs = validate::score(&c.response, &sim).into_iter().map(|(d, m)| (d.name().to_string(), m)).collect();
                runs.push(RunScore { run: c.name.clone(), role, dofs });
                if models.is_empty() {
                    first_sims.push(sim);
                }
            }
            models.push(ModelScore { model: f.stage.clone(), runs });
        }
        let svgs = velocity_plots(&cases, &first_sims)?;
        let parameters = json::parameters(&fits);
        let validation = Validation { models };
        let page = html::Page {
            vehicle: ctx.vehicle,
            fits: &fits,
            parameters: &parameters,
            validation: &validation,
            plots: svgs,
            notes: cases.iter().map(|c| (c.name.clone(), c.notes.clone())).collect(),
        };
        crate::fsutil::write_atomic(&ctx.out.join("index.html"), page.render().as_bytes())?;
        super::write_json(&ctx.out.join("parameters.json"), &parameters)?;
        super::write_json(&ctx.out.join("validation.json"), &validation)?;
        Ok(())
    }
}

/// One plot per DOF with every case that moves in it, against the first model's simulation.
fn velocity_plots(cases: &[Case], sims: &[Vec<Vec6>]) -> anyhow::Result<Vec<(String, String)>> {
    let mut by_dof: BTreeMap<Dof, Vec<(&Case, Vec<f64>)>> = BTreeMap::new();
    for (c, sim) in cases.iter().zip(sims) {
        for d in c.response.dofs.keys() {
            by_dof.entry(*d).or_default().push((c, sim.iter().map(|nu| nu[d.index()]).collect()));
        }
    }
    by_dof
        .into_iter()
        .map(|(d, list)| {
            let traces: Vec<plots::Trace> = list
                .iter()
                .map(|(c, s)| plots::Trace { label: &c.name, t: &c.response.t, measured: &c.response.dofs[&d].velocity, simulated: s })
                .collect();
            Ok((d.name().to_string(), plots::velocity(d, &traces)?))
        })
        .collect()
}
