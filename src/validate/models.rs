//! Identified models scored on pool runs, as the `validate` stage stores them: each model
//! simulated under every run's logged thrust and scored per DOF, the scores summarised per
//! run role, and models re-estimated on each training run alone scored on the others.

use super::pool::{CrossFit, ModelScore, RunScore, Scores, Simulated, score_run, simulate_run};
use crate::core::dof::Dof;
use crate::core::model::stability::Horizon;
use crate::core::model::{Plant, Vehicle};
use crate::identify::result::FitResult;
use crate::pool::fusion::run::FusedRun;
use std::collections::BTreeMap;

/// How the models are scored.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// Longest lag of the residual autocorrelation, s.
    pub max_lag_s: f64,
    /// Also re-estimate a model on each training run and score it on the others.
    pub cross_validate: bool,
    /// Simulation window (multiple shooting).
    pub horizon: Horizon,
}

/// The scores, and the simulations behind them (one per model and run, for plots).
pub struct Validation {
    pub scores: Scores,
    pub simulations: Vec<Simulated>,
}

/// Every model of `fits` on every run of `runs`; the notes say which runs cross-validation
/// could not use.
pub fn score_models(
    vehicle: &Vehicle,
    fits: &[FitResult],
    runs: &[FusedRun],
    opts: &Options,
) -> Validation {
    let mut models = Vec::new();
    let mut simulations = Vec::new();
    for f in fits {
        let (score, sims) = score_plant(vehicle, &f.stage, &f.plant(vehicle), runs, opts);
        models.push(score);
        simulations.extend(sims);
    }
    let imported: Vec<bool> = fits.iter().map(|f| f.imported_from.is_some()).collect();
    let (cross, mut notes) = if opts.cross_validate {
        cross_validate(vehicle, runs, opts.max_lag_s)
    } else {
        (vec![], vec![])
    };
    let baselines = match super::baseline::fit_first_order(vehicle, runs) {
        Ok(plant) => {
            let name = super::baseline::FIRST_ORDER;
            vec![score_plant(vehicle, name, &plant, runs, opts).0]
        }
        Err(why) => {
            notes.push(format!(
                "no first-order baseline: {why}; the models are compared with predicting rest only"
            ));
            vec![]
        }
    };
    let left_out = super::baseline::unmodelled_motion(vehicle, runs);
    let dt = mean_interval(runs);
    for m in &mut models {
        m.shortfalls = super::baseline::shortfalls(m, baselines.first());
        for s in &mut m.shortfalls {
            s.unmodelled_motion = left_out.clone();
        }
        if let Some(b) = baselines.first() {
            m.short_horizon = super::baseline::short_horizon(m, b, dt);
        }
    }
    let behind: Vec<Vec<super::pool::Behind>> = models
        .iter()
        .zip(&imported)
        .map(|(m, &from_file)| {
            let identified: Vec<&ModelScore> = models
                .iter()
                .zip(&imported)
                .filter(|(_, i)| !**i)
                .map(|(m, _)| m)
                .collect();
            if from_file {
                super::baseline::behind(m, &identified)
            } else {
                vec![]
            }
        })
        .collect();
    for (m, b) in models.iter_mut().zip(behind) {
        m.behind_identified = b;
    }
    Validation {
        scores: Scores {
            models,
            cross,
            notes,
            baselines,
        },
        simulations,
    }
}

/// One model (`plant`, called `name`) on every run, with the local stability that chose each
/// run's simulation window, and its simulations of the vehicle's DOFs.
fn score_plant(
    vehicle: &Vehicle,
    name: &str,
    plant: &Plant,
    runs: &[FusedRun],
    opts: &Options,
) -> (ModelScore, Vec<Simulated>) {
    let mut scored = Vec::new();
    let mut simulations = Vec::new();
    for run in runs {
        let (sim, stability) = simulate_run(plant, run, opts.horizon);
        let mut score = score_run(&vehicle.dofs, run, &sim, opts.max_lag_s);
        score.stability = Some(stability);
        for k in super::pool::AHEAD {
            for (d, x) in super::pool::ahead(plant, run, &vehicle.dofs, k) {
                if let Some(s) = score.dofs.get_mut(&d) {
                    s.nmae_ahead.insert(k, x);
                }
            }
        }
        scored.push(score);
        let nu = Dof::ALL
            .iter()
            .filter(|d| vehicle.dofs.contains(d))
            .map(|d| (*d, sim.iter().map(|x| x[d.index()]).collect()))
            .collect();
        simulations.push(Simulated {
            model: name.to_string(),
            run: run.meta.run.clone(),
            t: run.fused.t.clone(),
            nu,
        });
    }
    let mean_nmae = mean_nmae_by_role(&scored);
    let score = ModelScore {
        model: name.to_string(),
        runs: scored,
        mean_nmae,
        shortfalls: vec![],
        behind_identified: vec![],
        short_horizon: vec![],
    };
    (score, simulations)
}

/// Mean normalised MAE per DOF over the runs of each role (`train`, `validate`), where it is
/// finite; diverged runs left out.
fn mean_nmae_by_role(scored: &[RunScore]) -> BTreeMap<String, BTreeMap<Dof, f64>> {
    let mut mean_nmae: BTreeMap<String, BTreeMap<Dof, f64>> = BTreeMap::new();
    for role in ["train", "validate"] {
        let of_role: Vec<&RunScore> = scored
            .iter()
            .filter(|r| r.role == role && !r.diverged)
            .collect();
        for d in Dof::ALL {
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
    mean_nmae
}

/// Cross-validation across trials: a model re-estimated on each training run alone
/// (equation error, least squares on the fused velocities) and scored on every other run;
/// notes for the runs that gave no model.
fn cross_validate(
    vehicle: &Vehicle,
    runs: &[FusedRun],
    max_lag_s: f64,
) -> (Vec<CrossFit>, Vec<String>) {
    use crate::identify::Estimator as _;
    let mut out = Vec::new();
    let mut notes = Vec::new();
    for train in runs
        .iter()
        .filter(|r| r.meta.role == crate::pool::import::Role::Train)
    {
        let Some(resp) = train.as_response(vehicle, None) else {
            notes.push(format!(
                "{}: not every DOF was fused, so no model was re-estimated on it",
                train.meta.run
            ));
            continue;
        };
        let problem = crate::identify::Regression::build(vehicle, &[&resp], 1.0);
        let fit = match crate::identify::ols::Ols.fit(&problem, &Default::default()) {
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

/// The mean sample interval of the fused runs, s (0.05 when none has two samples).
fn mean_interval(runs: &[FusedRun]) -> f64 {
    let (span, n) = runs
        .iter()
        .filter(|r| r.fused.t.len() > 1)
        .fold((0.0, 0usize), |(s, n), r| {
            let t = &r.fused.t;
            (s + t[t.len() - 1] - t[0], n + t.len() - 1)
        });
    if n == 0 { 0.05 } else { span / n as f64 }
}
