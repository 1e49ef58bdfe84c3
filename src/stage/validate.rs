//! `kind: validate` — simulates every identified model under every pool run's logged thrust,
//! from the run's fused initial state, and scores it per DOF: MAE, normalised MAE (seed 003),
//! RMSE as % of the run's peak speed (seed 001) and the residual's whiteness (seed 000).

use super::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use crate::dof::Dof;
use crate::fusion::run::POOL_DOFS;
use crate::model::Plant;
use crate::model::stability::Horizon;
use crate::validate::pool::{
    CrossFit, ModelScore, RunScore, SCORES, Scores, Simulated, score_run, sim_file, simulate_run,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub static KIND: Kind = Kind {
    consumes: &[Artifact::Model, Artifact::PoolRuns],
    requires: &[Artifact::Model, Artifact::PoolRuns],
    ..Kind::new("validate", Artifact::Validation, parse_as::<Settings>)
};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {
    /// Longest lag of the residual autocorrelation, s.
    pub max_lag_s: f64,
    /// Also re-estimate the model on each training run alone (equation error, least squares on
    /// the fused velocities) and score it on every other run: cross-validation across trials.
    pub cross_validate: bool,
    /// Simulation window (multiple shooting): `whole_run` (the default); `auto` re-anchors the
    /// simulation to the fused state where the model is locally unstable along a run and
    /// simulates stable runs whole; or a window in seconds.
    pub horizon_s: Horizon,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            max_lag_s: 5.0,
            cross_validate: true,
            horizon_s: Horizon::WholeRun,
        }
    }
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let fits: Vec<crate::estimate::result::FitResult> = ctx
            .upstream_of(Artifact::Model)
            .map(|u| crate::estimate::result::load(&u.dir))
            .collect::<Result<_, _>>()?;
        let runs: Vec<crate::fusion::run::FusedRun> = ctx
            .upstream_of(Artifact::PoolRuns)
            .map(|u| crate::fusion::run::load_for(&u.dir, ctx.vehicle))
            .collect::<Result<_, _>>()?;
        let mut models = Vec::new();
        for f in &fits {
            let plant = f.plant(ctx.vehicle);
            let mut scored = Vec::new();
            for run in &runs {
                let (sim, stability) = simulate_run(&plant, run, self.horizon_s);
                let mut score = score_run(&ctx.vehicle.dofs, run, &sim, self.max_lag_s);
                score.stability = Some(stability);
                scored.push(score);
                let nu = POOL_DOFS
                    .iter()
                    .filter(|d| ctx.vehicle.dofs.contains(d))
                    .map(|d| (*d, sim.iter().map(|x| x[d.index()]).collect()))
                    .collect();
                let s = Simulated {
                    model: f.stage.clone(),
                    run: run.meta.run.clone(),
                    t: run.fused.t.clone(),
                    nu,
                };
                super::write_json(&ctx.out.join(sim_file(&f.stage, &run.meta.run)), &s)?;
            }
            let mut mean_nmae: BTreeMap<String, BTreeMap<Dof, f64>> = BTreeMap::new();
            for role in ["train", "validate"] {
                let of_role: Vec<&RunScore> = scored
                    .iter()
                    .filter(|r| r.role == role && !r.diverged)
                    .collect();
                for d in POOL_DOFS {
                    let v: Vec<f64> = of_role
                        .iter()
                        .filter_map(|r| r.dofs.get(&d))
                        .map(|s| s.metrics.nmae)
                        .filter(|x| x.is_finite())
                        .collect();
                    if !v.is_empty() {
                        mean_nmae
                            .entry(role.into())
                            .or_default()
                            .insert(d, v.iter().sum::<f64>() / v.len() as f64);
                    }
                }
            }
            models.push(ModelScore {
                model: f.stage.clone(),
                runs: scored,
                mean_nmae,
            });
        }
        let (cross, mut notes) = if self.cross_validate {
            cross_validate(ctx.vehicle, &runs, self.max_lag_s)
        } else {
            (vec![], vec![])
        };
        notes.extend(ctx.failed_notes());
        super::write_json(
            &ctx.out.join(SCORES),
            &Scores {
                models,
                cross,
                notes,
            },
        )
    }
}

fn cross_validate(
    vehicle: &crate::model::Vehicle,
    runs: &[crate::fusion::run::FusedRun],
    max_lag_s: f64,
) -> (Vec<CrossFit>, Vec<String>) {
    use crate::estimate::Estimator as _;
    let mut out = Vec::new();
    let mut notes = Vec::new();
    for train in runs
        .iter()
        .filter(|r| r.meta.role == crate::io::pool::Role::Train)
    {
        let Some(resp) = train.as_response(vehicle) else {
            notes.push(format!(
                "{}: not every DOF was fused, so no model was re-estimated on it",
                train.meta.run
            ));
            continue;
        };
        let problem = crate::estimate::Regression::build(vehicle, &[&resp], 1.0);
        let fit = match crate::estimate::ols::Ols.fit(&problem, &Default::default()) {
            Ok(f) => f,
            Err(e) => {
                notes.push(format!("{}: re-estimation failed: {e}", train.meta.run));
                continue;
            }
        };
        let theta: Vec<f64> = fit.parameters.iter().map(|p| p.value).collect();
        let plant = Plant::new(vehicle, problem.layout.to_hydro(&theta));
        let scored = runs
            .iter()
            .filter(|r| r.meta.run != train.meta.run)
            .map(|r| {
                score_run(
                    &vehicle.dofs,
                    r,
                    &simulate_run(&plant, r, Horizon::WholeRun).0,
                    max_lag_s,
                )
            })
            .collect();
        out.push(CrossFit {
            trained_on: train.meta.run.clone(),
            parameters: fit.parameters,
            runs: scored,
        });
    }
    (out, notes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Hydro, Vehicle};
    use crate::twin::pool as twin;

    #[test]
    fn a_model_driven_by_its_own_thrust_reproduces_the_twin() {
        // The true model simulated from the true initial state under the logged (rounded)
        // thrust must follow the twin's true velocities: the simulator and the twin agree.
        let spec = &twin::default_runs()[3];
        let w = twin::world(&[]);
        let truth = twin::simulate(&w, spec, 11);
        let plant = Plant::new(&Vehicle::reference(), Hydro::reference());
        let t: Vec<f64> = (0..truth.cmd.len()).map(|k| k as f64 * 0.05).collect();
        let sim = plant.simulate(&t, &truth.cmd, truth.states[0].nu, 0.01);
        for (k, nu) in sim.iter().enumerate() {
            let s = &truth.states[k * 5];
            for i in [0, 1, 2, 5] {
                assert!(
                    (nu[i] - s.nu[i]).abs() < 1e-6,
                    "t {} dof {i}: {} vs {}",
                    t[k],
                    nu[i],
                    s.nu[i]
                );
            }
        }
    }
}
