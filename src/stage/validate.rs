//! `kind: validate` — simulates every identified model under every pool run's logged thrust,
//! from the run's fused initial state, and scores it per DOF: MAE, normalised MAE (seed 003),
//! RMSE as % of the run's peak speed (seed 001) and the residual's whiteness (seed 000).

use super::{Artifact, Kind, RunCtx, StageImpl, fit, pool};
use crate::dof::Dof;
use crate::model::stability::{Horizon, Stability};
use crate::model::{Plant, Vec6};
use crate::validate::{self, Metrics, Whiteness};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

pub static KIND: Kind = Kind {
    name: "validate",
    version: 1,
    fan_out: false,
    reads_files: false,
    input_filter: None,
    produces: Artifact::Validation,
    consumes: &[Artifact::Model, Artifact::PoolRuns],
    requires: &[Artifact::Model, Artifact::PoolRuns],
    requires_one_of: &[],
    uses_vehicle: super::VehicleUse::All,
    publishes_to: None,
    parse: |v| Ok(Arc::new(serde_yaml_ng::from_value::<Settings>(v)?)),
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

/// A model re-estimated on one pool run and scored on the others.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CrossFit {
    pub trained_on: String,
    pub parameters: Vec<crate::estimate::Estimate>,
    pub runs: Vec<RunScore>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DofScore {
    #[serde(flatten)]
    pub metrics: Metrics,
    pub whiteness: Whiteness,
    /// Mean of the fused velocity's standard deviation: the floor no model can beat.
    pub measurement_std: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunScore {
    pub run: String,
    pub role: String,
    pub dofs: BTreeMap<Dof, DofScore>,
    /// The model left the range a vehicle can reach (diverged): its scores are not meaningful.
    pub diverged: bool,
    /// The model's local stability along the run and the simulation window it led to.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stability: Option<Stability>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ModelScore {
    pub model: String,
    pub runs: Vec<RunScore>,
    /// Mean normalised MAE per DOF over the runs of each role (cross-validation summary).
    pub mean_nmae: BTreeMap<String, BTreeMap<Dof, f64>>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Scores {
    pub models: Vec<ModelScore>,
    #[serde(default)]
    pub cross: Vec<CrossFit>,
    #[serde(default)]
    pub notes: Vec<String>,
}

/// A model's simulated velocities on one run (u, v, w, r), for plots and diagnosis.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Simulated {
    pub model: String,
    pub run: String,
    pub t: Vec<f64>,
    /// NaN where the simulation diverged (JSON `null`).
    #[serde(deserialize_with = "crate::validate::series_or_nan")]
    pub nu: BTreeMap<Dof, Vec<f64>>,
}

pub const SCORES: &str = "scores.json";

pub fn load(dir: &Path) -> anyhow::Result<(Scores, Vec<Simulated>)> {
    let scores: Scores = super::read_json(&dir.join(SCORES))?;
    let mut sims = Vec::new();
    for m in &scores.models {
        for r in &m.runs {
            sims.push(super::read_json(&dir.join(sim_file(&m.model, &r.run)))?);
        }
    }
    Ok((scores, sims))
}

fn sim_file(model: &str, run: &str) -> String {
    format!("sim__{model}__{run}.json").replace(['/', '[', ']'], "_")
}

pub use crate::fusion::run::POOL_DOFS;

/// The model's response to a fused run's logged thrust, from the run's first fused state,
/// re-anchored to the fused state every window where `horizon` asks for it (multiple
/// shooting, see [`crate::model::stability`]), and the stability that chose the window.
pub fn simulate_run(
    plant: &Plant,
    run: &pool::FusedRun,
    horizon: Horizon,
) -> (Vec<Vec6>, Stability) {
    let t = &run.fused.t;
    let tau: Vec<Vec6> = run
        .thrust
        .iter()
        .map(|c| [c[0], c[1], c[2], 0.0, 0.0, c[3]])
        .collect();
    // A window after the first starts from the recording's centred mean over five samples, so
    // that one sample's noise is not carried through it.
    let fused_at = |k: usize| -> Vec6 {
        let mut nu = [0.0; 6];
        let (a, b) = if k == 0 {
            (0, 0)
        } else {
            (k.saturating_sub(2), (k + 2).min(t.len() - 1))
        };
        for (j, d) in POOL_DOFS.iter().enumerate() {
            if let Some(v) = &run.fused.vel[j] {
                nu[d.index()] = v[a..=b].iter().sum::<f64>() / (b - a + 1) as f64;
            }
        }
        nu
    };
    let vel: Vec<[f64; 4]> = (0..t.len())
        .map(|k| std::array::from_fn(|j| run.fused.vel[j].as_ref().map_or(0.0, |v| v[k])))
        .collect();
    let stability = crate::model::stability::along(plant, t, &vel, horizon);
    let mut anchors = crate::model::stability::anchors(t, stability.horizon_s);
    anchors.push(t.len());
    let mut out = Vec::with_capacity(t.len());
    for w in anchors.windows(2) {
        let (a, b) = (w[0], w[1]);
        // Each window runs to the next anchor's time; its last sample is the next window's first.
        let end = (b + 1).min(t.len());
        let mut sim = plant.simulate(&t[a..end], &tau[a..end], fused_at(a), 0.01);
        sim.truncate(b - a);
        out.extend(sim);
    }
    (out, stability)
}

/// Scores of one simulation against one fused run, for the DOFs both have.
pub fn score_run(
    vehicle_dofs: &[Dof],
    run: &pool::FusedRun,
    sim: &[Vec6],
    max_lag_s: f64,
) -> RunScore {
    let dt = if run.fused.t.len() > 1 {
        (run.fused.t[run.fused.t.len() - 1] - run.fused.t[0]) / (run.fused.t.len() - 1) as f64
    } else {
        0.05
    };
    let diverged = sim
        .iter()
        .any(|nu| nu.iter().any(|x| !x.is_finite() || x.abs() > 50.0));
    let mut dofs = BTreeMap::new();
    for (j, d) in POOL_DOFS.iter().enumerate() {
        let (Some(v), Some(s)) = (&run.fused.vel[j], &run.fused.std[j]) else {
            continue;
        };
        if !vehicle_dofs.contains(d) {
            continue;
        }
        let simd: Vec<f64> = sim.iter().map(|nu| nu[d.index()]).collect();
        let e: Vec<f64> = simd.iter().zip(v).map(|(a, b)| a - b).collect();
        dofs.insert(
            *d,
            DofScore {
                metrics: validate::metrics(v, &simd),
                whiteness: validate::whiteness(&e, dt, (max_lag_s / dt).round() as usize),
                measurement_std: s.iter().sum::<f64>() / s.len().max(1) as f64,
            },
        );
    }
    RunScore {
        run: run.meta.run.clone(),
        role: run.meta.role.as_str().into(),
        dofs,
        diverged,
        stability: None,
    }
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let fits: Vec<fit::FitResult> = ctx
            .upstream_of(Artifact::Model)
            .map(|u| fit::load(&u.dir))
            .collect::<Result<_, _>>()?;
        let runs: Vec<pool::FusedRun> = ctx
            .upstream_of(Artifact::PoolRuns)
            .map(|u| pool::load_for(&u.dir, ctx.vehicle))
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
    runs: &[pool::FusedRun],
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
