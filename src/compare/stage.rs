//! `kind: compare` — every listed estimator on the same CFD cases, side by side, as seed 001's
//! Table 2 does: parameters, error against a known truth (when the cases come from a twin),
//! validation error on the pool runs, run time and objective evaluations.

use crate::pipeline::contract::{Artifact, Kind, RunCtx, StageImpl, parse_as};

use crate::compare::artifact::RESULT;
use crate::compare::{Candidate, Data, compare};
use crate::core::response;
use crate::identify::settings as fit_stage;
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
    pub methods: Vec<fit_stage::Settings>,
    /// Known parameter values (the twin's, for synthetic cases), to score each method against.
    pub truth: BTreeMap<String, f64>,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            methods: crate::identify::names()
                .into_iter()
                .map(fit_stage::Settings::of_method)
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
            if let Some(bad) = r.non_finite(&ctx.vehicle.dofs, f64::NEG_INFINITY) {
                anyhow::bail!(
                    "{}: {bad}: no estimator can use it\n  help: fix or remove that sample in the input",
                    meta.source.path
                );
            }
            responses.push(r);
            masses.push(meta.body_mass_kg);
        }
        let runs: Vec<crate::pool::fusion::run::FusedRun> = ctx
            .upstream_of(Artifact::PoolRuns)
            .map(|u| crate::pool::fusion::run::load_for(&u.dir, ctx.vehicle))
            .collect::<Result<_, _>>()?;
        let candidates: Vec<Candidate> = self
            .methods
            .iter()
            .map(|m| Candidate {
                label: m.label(),
                settings: m.settings(),
                method: &m.method,
                objective: m.common.objective,
                skip_start_s: m.common.skip_start_s,
            })
            .collect();
        let data = Data {
            vehicle: ctx.vehicle,
            cases: responses
                .iter()
                .zip(&masses)
                .map(|(r, m)| (r, *m))
                .collect(),
            truth: &self.truth,
            runs: &runs,
        };
        let progress = |m: String| ctx.progress.set_message(m);
        crate::core::fsutil::write_json(
            &ctx.out.join(RESULT),
            &compare(&data, &candidates, &progress),
        )
    }
}
