//! Validation on pool runs: a model simulated under a fused run's logged command, scored per
//! DOF against the fused velocities, as the `validate` stage stores it (`scores.json` plus one
//! simulation per model and run).

use super::{Metrics, Whiteness};
use crate::core::dof::Dof;
use crate::core::model::stability::{Horizon, Stability};
use crate::core::model::{Plant, Vec6};
use crate::pool::fusion::run::FusedRun;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// A model re-estimated on one pool run and scored on the others.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CrossFit {
    pub trained_on: String,
    pub parameters: Vec<crate::identify::Estimate>,
    pub runs: Vec<RunScore>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DofScore {
    #[serde(flatten)]
    pub metrics: Metrics,
    pub whiteness: Whiteness,
    /// Mean of the fused velocity's standard deviation: the floor no model can beat.
    pub measurement_std: f64,
    /// NMAE of the prediction [`AHEAD`] samples ahead from the fused state (MATLAB's
    /// `compare` with a finite horizon), one per horizon, where the run is long enough.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub nmae_ahead: BTreeMap<usize, f64>,
}

/// The prediction horizons scored besides the free run, in samples: one step (the noise and
/// the acceleration), ten (the transient) and a hundred (the drag).
pub const AHEAD: [usize; 3] = [1, 10, 100];

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
    /// The DOFs in which the model does not beat both baselines on the held-out runs
    /// (see [`super::baseline`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shortfalls: Vec<Shortfall>,
    /// For a model read from a simulator's file: the DOFs in which it predicts the held-out
    /// runs clearly worse than the identified model (see [`super::baseline::behind`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub behind_identified: Vec<Behind>,
    /// The DOFs in which the model beats the baselines' free run but predicts a few samples
    /// ahead clearly worse than the first-order baseline (see [`super::baseline::short_horizon`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub short_horizon: Vec<ShortHorizon>,
}

/// A DOF in which a model predicts `samples` ahead of the fused state clearly worse than the
/// first-order baseline, on the held-out runs: a model for control over such horizons should
/// not be taken on its free run alone.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShortHorizon {
    pub dof: Dof,
    pub samples: usize,
    /// The horizon in seconds (the fused runs' mean sample interval times `samples`).
    pub seconds: f64,
    pub nmae: f64,
    pub first_order_nmae: f64,
}

impl ShortHorizon {
    /// The sentence the report shows.
    pub fn sentence(&self, model: &str) -> String {
        format!(
            "{model} in {}: {} sample{} ({:.2} s) ahead of the fused state its held-out NMAE is {:.3}, the first-order model's {:.3}: over such horizons (a controller's prediction) the simpler model predicts better; weigh that before using this one for control",
            self.dof,
            self.samples,
            if self.samples == 1 { "" } else { "s" },
            self.seconds,
            self.nmae,
            self.first_order_nmae
        )
    }
}

/// A DOF in which a model read from a file predicts the held-out runs worse than the model
/// identified from them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Behind {
    pub dof: Dof,
    pub nmae: f64,
    pub identified: String,
    pub identified_nmae: f64,
}

impl Behind {
    /// The sentence the report shows.
    pub fn sentence(&self, model: &str) -> String {
        format!(
            "{model} (read from a simulator's file) predicts the held-out runs worse than the model identified from them in {}: NMAE {:.3} against {:.3} for {}; its parameters in {} do not match these recordings",
            self.dof, self.nmae, self.identified_nmae, self.identified, self.dof
        )
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Scores {
    pub models: Vec<ModelScore>,
    #[serde(default)]
    pub cross: Vec<CrossFit>,
    #[serde(default)]
    pub notes: Vec<String>,
    /// What every model must beat on the held-out runs besides predicting rest: the
    /// first-order model per DOF ([`super::baseline::FIRST_ORDER`]), when it could be fitted.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub baselines: Vec<ModelScore>,
}

/// A model's simulated velocities on one run (u, v, w, r), for plots and diagnosis.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Simulated {
    pub model: String,
    pub run: String,
    pub t: Vec<f64>,
    /// NaN where the simulation diverged (JSON `null`).
    #[serde(deserialize_with = "crate::core::fsutil::series_or_nan")]
    pub nu: BTreeMap<Dof, Vec<f64>>,
}

pub const SCORES: &str = "scores.json";

/// The pool scores and simulations a validate stage stored in `dir` (none when it read no
/// pool run).
pub fn load(dir: &Path) -> anyhow::Result<Option<(Scores, Vec<Simulated>)>> {
    if !dir.join(SCORES).exists() {
        return Ok(None);
    }
    let scores: Scores = crate::core::fsutil::read_json(&dir.join(SCORES))?;
    let mut sims = Vec::new();
    for m in &scores.models {
        for r in &m.runs {
            sims.push(crate::core::fsutil::read_json(
                &dir.join(sim_file(&m.model, &r.run)),
            )?);
        }
    }
    Ok(Some((scores, sims)))
}

pub fn sim_file(model: &str, run: &str) -> String {
    format!("sim__{model}__{run}.json").replace(['/', '[', ']'], "_")
}

/// The model's response to a fused run's logged thrust, from the run's first fused state,
/// re-anchored to the fused state every window where `horizon` asks for it (multiple
/// shooting, see [`crate::core::model::stability`]), and the stability that chose the window.
pub fn simulate_run(plant: &Plant, run: &FusedRun, horizon: Horizon) -> (Vec<Vec6>, Stability) {
    let t = &run.fused.t;
    let tau: Vec<Vec6> = (0..t.len()).map(|k| run.tau(k)).collect();
    // The model's command lag (thrusters, command path) and gain, when it has them.
    let tau = plant.command(t, &tau);
    // A window after the first starts from the recording's centred mean over five samples, so
    // that one sample's noise is not carried through it.
    let fused_at = |k: usize| -> Vec6 {
        let mut nu = [0.0; 6];
        let (a, b) = if k == 0 {
            (0, 0)
        } else {
            (k.saturating_sub(2), (k + 2).min(t.len() - 1))
        };
        for d in Dof::ALL {
            if let Some(v) = run.velocity(d) {
                nu[d.index()] = v[a..=b].iter().sum::<f64>() / (b - a + 1) as f64;
            }
        }
        nu
    };
    let vel: Vec<[f64; 4]> = (0..t.len())
        .map(|k| std::array::from_fn(|j| run.fused.vel[j].as_ref().map_or(0.0, |v| v[k])))
        .collect();
    let stability = crate::core::model::stability::along(plant, t, &vel, horizon);
    let mut anchors = crate::core::model::stability::anchors(t, &stability.anchors_s);
    anchors.push(t.len());
    let mut out = Vec::with_capacity(t.len());
    for w in anchors.windows(2) {
        let (a, b) = (w[0], w[1]);
        // Each window runs to the next anchor's time; its last sample is the next window's first.
        let end = (b + 1).min(t.len());
        let mut sim =
            plant.simulate_from(&t[a..end], &tau[a..end], fused_at(a), run.attitude(a), 0.01);
        sim.truncate(b - a);
        out.extend(sim);
    }
    (out, stability)
}

/// The NMAE per DOF of `plant`'s prediction `k` samples ahead on `run`: from the fused state
/// (and attitude) at sample i, simulated under the logged command (through the model's lag
/// and gain, [`Plant::command`]) to sample i + k and compared
/// there, for starts i every max(1, k / 10) samples. Empty when the run is shorter than k.
pub fn ahead(plant: &Plant, run: &FusedRun, dofs: &[Dof], k: usize) -> BTreeMap<Dof, f64> {
    let t = &run.fused.t;
    let n = t.len();
    if n <= k {
        return BTreeMap::new();
    }
    // Through the model's command lag as well as its gain: each start takes the lagged
    // command the run's own history gives there, as the free run does.
    let tau: Vec<Vec6> = (0..n).map(|i| run.tau(i)).collect();
    let tau = plant.command(t, &tau);
    let measured: Vec<(Dof, &Vec<f64>)> = dofs
        .iter()
        .filter_map(|d| Some((*d, run.velocity(*d)?)))
        .collect();
    let mut err = vec![(0.0, 0.0); measured.len()];
    for i in (0..n - k).step_by((k / 10).max(1)) {
        let mut nu0 = [0.0; 6];
        for (d, v) in &measured {
            nu0[d.index()] = v[i];
        }
        let sim = plant.simulate_from(&t[i..=i + k], &tau[i..=i + k], nu0, run.attitude(i), 0.01);
        let end = sim[k];
        for ((d, v), e) in measured.iter().zip(&mut err) {
            let x = end[d.index()] - v[i + k];
            if x.is_finite() {
                e.0 += x.abs();
                e.1 += v[i + k].abs();
            }
        }
    }
    measured
        .iter()
        .zip(err)
        .filter(|(_, (_, den))| *den > 0.0)
        .map(|((d, _), (num, den))| (*d, num / den))
        .collect()
}

/// Scores of one simulation against one fused run, for the DOFs both have.
pub fn score_run(vehicle_dofs: &[Dof], run: &FusedRun, sim: &[Vec6], max_lag_s: f64) -> RunScore {
    let dt = if run.fused.t.len() > 1 {
        (run.fused.t[run.fused.t.len() - 1] - run.fused.t[0]) / (run.fused.t.len() - 1) as f64
    } else {
        0.05
    };
    let diverged = sim
        .iter()
        .any(|nu| nu.iter().any(|x| !x.is_finite() || x.abs() > 50.0));
    let mut dofs = BTreeMap::new();
    for d in &Dof::ALL {
        let (Some(v), Some(s)) = (run.velocity(*d), run.velocity_std(*d)) else {
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
                metrics: super::metrics(v, &simd),
                whiteness: super::whiteness(&e, dt, (max_lag_s / dt).round() as usize),
                measurement_std: s.iter().sum::<f64>() / s.len().max(1) as f64,
                nmae_ahead: BTreeMap::new(),
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

/// Mean normalised MAE of `plant` over the DOFs and runs (whole-run simulations), where it is
/// finite; None when there is none.
pub fn mean_nmae(plant: &Plant, runs: &[&FusedRun], dofs: &[Dof]) -> Option<f64> {
    let nmae: Vec<f64> = runs
        .iter()
        .flat_map(|r| {
            let s = score_run(dofs, r, &simulate_run(plant, r, Default::default()).0, 1.0);
            s.dofs.values().map(|d| d.metrics.nmae).collect::<Vec<_>>()
        })
        .filter(|x| x.is_finite())
        .collect();
    (!nmae.is_empty()).then(|| nmae.iter().sum::<f64>() / nmae.len() as f64)
}

/// A DOF in which a model does not beat both baselines on the held-out runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Shortfall {
    pub dof: Dof,
    /// The model's mean NMAE over the held-out runs; `None` when its simulation diverged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nmae: Option<f64>,
    /// The first-order baseline's, when it could be fitted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first_order_nmae: Option<f64>,
    /// Roll and pitch where the held-out runs roll or pitch and the model leaves them out: a
    /// DOF left out is at rest in the simulation, so what its motion drives here is missing.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unmodelled_motion: Vec<Dof>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::model::{Hydro, Vehicle};
    use crate::pool::fusion::Fused;
    use crate::pool::fusion::run::RunMeta;

    /// A run the reference vehicle flew under a surge and yaw command switching every 2 s,
    /// through a 0.3 s command lag, its velocities recorded exactly at 20 Hz.
    fn lagged_run(plant: &Plant) -> FusedRun {
        let t: Vec<f64> = (0..400).map(|k| k as f64 * 0.05).collect();
        let tau: Vec<Vec6> = t
            .iter()
            .map(|&s| {
                let sign = if ((s / 2.0) as usize).is_multiple_of(2) {
                    1.0
                } else {
                    -1.0
                };
                [40.0 * sign, 0.0, 0.0, 0.0, 0.0, 8.0 * sign]
            })
            .collect();
        let sim = plant.simulate(&t, &plant.command(&t, &tau), [0.0; 6], 0.01);
        let mut fused = Fused {
            t: t.clone(),
            vel: Default::default(),
            std: Default::default(),
            x: vec![f64::NAN; t.len()],
            y: vec![f64::NAN; t.len()],
            z: vec![f64::NAN; t.len()],
            psi: vec![f64::NAN; t.len()],
            roll_pitch: Default::default(),
            tracked: Default::default(),
            stats: Default::default(),
        };
        for (j, i) in [0usize, 1, 2, 5].into_iter().enumerate() {
            fused.vel[j] = Some(sim.iter().map(|nu| nu[i]).collect());
            fused.std[j] = Some(vec![0.01; t.len()]);
        }
        FusedRun {
            meta: RunMeta::bare("lagged", crate::pool::import::Role::Validate),
            thrust: tau.iter().map(|x| [x[0], x[1], x[2], x[5]]).collect(),
            moments: Vec::new(),
            fused,
            without_sonar: None,
            actuators: Vec::new(),
        }
    }

    /// The prediction k samples ahead passes the logged command through the model's lag, as
    /// the free run does: the model that flew the run predicts it exactly at every horizon,
    /// where the same model fed the command without its lag is off by a good share of the
    /// motion after each switch (it was, before the lag was applied here: 10 steps ahead is
    /// half a second, past the lag's time constant).
    #[test]
    fn the_prediction_ahead_goes_through_the_command_lag() {
        let mut plant = Plant::new(&Vehicle::reference(), Hydro::reference());
        plant.command_lag_s = 0.3;
        let run = lagged_run(&plant);
        let dofs = [Dof::Surge, Dof::Sway, Dof::Heave, Dof::Yaw];
        for k in AHEAD {
            let e = ahead(&plant, &run, &dofs, k);
            for d in [Dof::Surge, Dof::Sway, Dof::Yaw] {
                assert!(e[&d] < 1e-3, "{k} ahead, {d:?}: NMAE {}", e[&d]);
            }
        }
        let mut unlagged = plant.clone();
        unlagged.command_lag_s = 0.0;
        let e = ahead(&unlagged, &run, &dofs, 10);
        for d in [Dof::Surge, Dof::Yaw] {
            assert!(e[&d] > 0.02, "without the lag, {d:?}: NMAE {}", e[&d]);
        }
    }
}
