//! `kind: validate` — simulates every identified model under every pool run's logged thrust,
//! from the run's fused initial state, and scores it per DOF: MAE, normalised MAE (seed 003),
//! RMSE as % of the run's peak speed (seed 001) and the residual's whiteness (seed 000); and
//! under every CFD case's applied force, from the case's first state ([`super::cases`]). The
//! report shows these scores and simulations; it simulates nothing itself.

use crate::core::model::stability::Horizon;
use crate::pipeline::contract::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use crate::validate::cases::{CASES, Case};
use crate::validate::models::{Options, Validation, score_models};
use crate::validate::pool::{SCORES, sim_file};
use serde::{Deserialize, Serialize};

pub static KIND: Kind = Kind {
    version: 2,
    consumes: &[Artifact::Model, Artifact::PoolRuns, Artifact::Responses],
    requires: &[Artifact::Model],
    requires_one_of: &[Artifact::PoolRuns, Artifact::Responses],
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
    /// Simulation window (multiple shooting): `auto` (the default) re-anchors the simulation to
    /// the fused state each time the model's local instability along the run would have
    /// doubled an error, and simulates stable stretches and stable runs whole; `whole_run`; or
    /// a window in seconds.
    pub horizon_s: Horizon,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            max_lag_s: 5.0,
            cross_validate: true,
            horizon_s: Horizon::Auto,
        }
    }
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let fits: Vec<crate::identify::result::FitResult> = ctx
            .upstream_of(Artifact::Model)
            .map(|u| crate::identify::result::load(&u.dir))
            .collect::<Result<_, _>>()?;
        let runs: Vec<crate::pool::fusion::run::FusedRun> = ctx
            .upstream_of(Artifact::PoolRuns)
            .map(|u| crate::pool::fusion::run::load_for(&u.dir, ctx.vehicle))
            .collect::<Result<_, _>>()?;
        let cases = cfd_cases(ctx)?;
        let scored = crate::validate::cases::score_cases(ctx.vehicle, &fits, &cases);
        if !scored.is_empty() {
            crate::core::fsutil::write_json(&ctx.out.join(CASES), &scored)?;
        }
        // A model fitted on another body's cases (cases that state their body's mass: the
        // OpenFOAM cylinder) is scored on those cases only, never on the vehicle's runs.
        let other_body = |f: &crate::identify::result::FitResult| {
            f.cases
                .iter()
                .any(|c| cases.iter().any(|x| x.id == c.id && x.mass.is_some()))
        };
        let vehicle_fits: Vec<_> = fits.into_iter().filter(|f| !other_body(f)).collect();
        if runs.is_empty() || vehicle_fits.is_empty() {
            return Ok(());
        }
        let opts = Options {
            max_lag_s: self.max_lag_s,
            cross_validate: self.cross_validate,
            horizon: self.horizon_s,
        };
        let Validation {
            mut scores,
            simulations,
        } = score_models(ctx.vehicle, &vehicle_fits, &runs, &opts);
        for s in &simulations {
            crate::core::fsutil::write_json(&ctx.out.join(sim_file(&s.model, &s.run)), s)?;
        }
        scores.notes.extend(ctx.failed_notes());
        crate::core::fsutil::write_json(&ctx.out.join(SCORES), &scores)
    }
}

/// The CFD responses among the upstream, as validation reads them.
fn cfd_cases(ctx: &RunCtx) -> anyhow::Result<Vec<Case>> {
    let responses = crate::validate::cases::upstream_responses(ctx)?;
    Ok(responses
        .into_iter()
        .map(|(u, meta, response)| Case {
            id: u.id.clone(),
            name: meta.case,
            response,
            mass: meta.body_mass_kg,
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use crate::core::model::{Hydro, Plant, Vehicle};
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
