//! `kind: fit` — identifies the hydrodynamic parameters from every CFD response it reads.

use super::{starccm, Artifact, InputFile, Kind, RunCtx, StageImpl};
use crate::dof::Dof;
use crate::estimate::{self, Fit, Regression};
use crate::model::Structure;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::Arc;

pub static KIND: Kind = Kind {
    name: "fit",
    version: 1,
    fan_out: false,
    reads_files: false,
    produces: Artifact::Model,
    consumes: &[Artifact::Responses],
    requires: &[Artifact::Responses],
    uses_vehicle: super::VehicleUse::All,
    publishes_to: None,
    parse: parse_settings,
};

fn parse_settings(v: serde_yaml_ng::Value) -> Result<Arc<dyn StageImpl>, serde_yaml_ng::Error> {
    let s: Settings = serde_yaml_ng::from_value(v)?;
    if estimate::by_name(&s.method).is_none() {
        let names: &'static [&'static str] = Box::leak(estimate::names().into_boxed_slice());
        return Err(serde::de::Error::unknown_variant(&s.method, names));
    }
    Ok(Arc::new(s))
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Objective {
    /// Force reconstructed from measured velocity and acceleration vs applied force (seed 001 eq. 14).
    #[default]
    EquationError,
    /// Velocity simulated under the applied force vs measured velocity (seed 001 eq. 9).
    OutputError,
}

impl Objective {
    pub fn label(self) -> &'static str {
        match self {
            Objective::EquationError => "equation error (seed 001 eq. 14)",
            Objective::OutputError => "output error (seed 001 eq. 9, simulator in the loop)",
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {
    pub method: String,
    pub objective: Objective,
    /// Samples before this time in each case are left out: the start-up transient of the
    /// fluid-body coupling (impulsive start, pressure waves) is not vehicle dynamics.
    pub skip_start_s: f64,
    /// Seed of the stochastic methods (qpso, pso, ga); part of the cache key and provenance.
    pub seed: u64,
    /// Population and iterations of qpso, pso and ga (seed 001 does not state its own).
    pub population: usize,
    pub iterations: usize,
    /// Independent seeded runs of qpso, pso and ga: their spread is the reported interval.
    pub restarts: usize,
    /// Norm of the equation error for qpso, pso and ga: l1 (seed 001 eq. 14) or l2.
    pub norm: crate::estimate::swarm::Norm,
    /// Forgetting factor of rls (seed 000 eq. 19); 1 keeps every row equally.
    pub forgetting: f64,
    /// Wall-clock limit for qpso, pso and ga, s; the best so far is kept and the report says
    /// the search was cut short. Not part of the numbers' identity: leave it unset for
    /// reproducible results.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_seconds: Option<f64>,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            method: "ols".into(),
            objective: Objective::EquationError,
            skip_start_s: 0.0,
            seed: 1,
            population: 40,
            iterations: 2000,
            restarts: 5,
            norm: crate::estimate::swarm::Norm::L2,
            forgetting: 1.0,
            max_seconds: None,
        }
    }
}

/// A CFD case the fit used.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CaseRef {
    pub id: String,
    pub case: String,
    pub source: InputFile,
}

/// The fit stage's artifact: parameters with their provenance.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FitResult {
    pub stage: String,
    pub method: String,
    pub objective: Objective,
    pub settings: serde_json::Value,
    pub structure: Structure,
    pub dofs: Vec<Dof>,
    pub fit: Fit,
    pub cases: Vec<CaseRef>,
    pub elapsed_s: f64,
}

pub const RESULT: &str = "fit.json";

pub fn load(dir: &Path) -> anyhow::Result<FitResult> {
    super::read_json(&dir.join(RESULT))
}

impl StageImpl for Settings {
    /// Only the settings the chosen method reads, so tuning the swarm does not rerun a
    /// least-squares fit (and a deterministic method shows no seed).
    fn settings(&self) -> serde_json::Value {
        let mut v = serde_json::to_value(self).expect("settings serialise");
        let obj = v.as_object_mut().expect("settings are a map");
        let stochastic = estimate::by_name(&self.method).is_some_and(|e| e.stochastic());
        if !stochastic {
            for k in ["seed", "population", "iterations", "restarts", "norm", "max_seconds"] {
                obj.remove(k);
            }
        }
        if self.method != "rls" {
            obj.remove("forgetting");
        }
        v
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let start = std::time::Instant::now();
        let mut cases = Vec::new();
        let mut responses = Vec::new();
        for up in ctx.upstream_of(Artifact::Responses) {
            let (meta, r) = starccm::load(&up.dir)?;
            cases.push(CaseRef { id: up.id.clone(), case: meta.case, source: meta.source });
            responses.push(r);
        }
        let refs: Vec<_> = responses.iter().collect();
        let problem = Regression::build(ctx.vehicle, &refs, self.skip_start_s);
        let estimator = estimate::by_name(&self.method).expect("checked when parsed");
        ctx.progress.set_message(format!("{} on {} samples", self.method, problem.rows()));
        let bar = ctx.progress;
        let report = move |f: f64| bar.set_message(format!("{:.0} %", 100.0 * f));
        let opts = estimate::Options {
            rigid_mass: ctx.vehicle.rigid_mass(),
            seed: self.seed,
            population: self.population.max(2),
            iterations: self.iterations.max(1),
            restarts: self.restarts.max(1),
            norm: self.norm,
            forgetting: self.forgetting,
            progress: Some(&report),
            output_error: (self.objective == Objective::OutputError).then_some((ctx.vehicle, &refs[..])),
            max_seconds: self.max_seconds,
        };
        let fit = estimator.fit(&problem, &opts)?;
        let result = FitResult {
            stage: ctx.stage.to_string(),
            method: self.method.clone(),
            objective: self.objective,
            settings: self.settings(),
            structure: ctx.vehicle.structure,
            dofs: ctx.vehicle.dofs.clone(),
            fit,
            cases,
            elapsed_s: start.elapsed().as_secs_f64(),
        };
        super::write_json(&ctx.out.join(RESULT), &result)
    }
}
