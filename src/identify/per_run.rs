//! Per-run nuisance parameters of the prediction-error method (Ljung 1999, sec. 7.3): what
//! differs from run to run but is no part of the vehicle, estimated beside the model's
//! coefficients so that it does not bend them.
//!
//! - `initial_state`: each run's initial velocity. A simulation starts from the first fused
//!   sample, one noisy sample of a late, low-passed navigation log; its error then decays with
//!   the DOF's time constant and is blamed on the coefficients.
//! - `force`: a constant force per run and DOF about the runs' mean (a current's drag or a
//!   tether's pull that changes from run to run). The mean stays with the model (its
//!   `constant_force` term, or none), so a held-out run is predicted with the mean.
//! - `sensor_bias`: a constant velocity offset per run and DOF about the runs' mean (a DVL's
//!   or a gyro's bias that the navigation filter re-estimates each run).
//!
//! The offsets of `force` and `sensor_bias` are contrasts: runs 2..n are free and run 1's is
//! minus their sum, so they average to zero and never trade with the model's own constant.

use crate::core::dof::Dof;
use crate::core::model::Vec6;
use serde::{Deserialize, Serialize};

/// One kind of per-run nuisance parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    InitialState,
    Force,
    SensorBias,
}

impl Kind {
    pub const ALL: [Kind; 3] = [Kind::InitialState, Kind::Force, Kind::SensorBias];

    pub fn name(self) -> &'static str {
        match self {
            Kind::InitialState => "initial_state",
            Kind::Force => "force",
            Kind::SensorBias => "sensor_bias",
        }
    }

    /// Whether the runs' offsets are contrasts about a zero mean.
    pub(crate) fn contrast(self) -> bool {
        self != Kind::InitialState
    }

    /// What a value of this kind is, for the report.
    fn what(self) -> &'static str {
        match self {
            Kind::InitialState => "initial velocity",
            Kind::Force => "constant force about the runs' mean",
            Kind::SensorBias => "velocity-sensor bias about the runs' mean",
        }
    }
}

/// Which kinds a fit estimates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Kinds(pub [bool; 3]);

impl Kinds {
    /// None: the prediction-error method's default (see `docs/pool.md` for why).
    pub const DEFAULT: Kinds = Kinds([false, false, false]);

    pub fn of(list: &[Kind]) -> Kinds {
        Kinds(std::array::from_fn(|i| list.contains(&Kind::ALL[i])))
    }

    pub fn has(self, k: Kind) -> bool {
        self.0[k as usize]
    }
}

/// One nuisance parameter: its kind, the run (index into the fit's runs) and the DOF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nuisance {
    pub kind: Kind,
    pub case: usize,
    pub dof: Dof,
}

/// The nuisance parameters of `kinds` over runs whose recorded DOFs are `dofs` (per run), in
/// order: kind by kind, run by run, DOF by DOF. A contrast kind has none for the first run
/// (nor at all with one run).
pub fn layout(kinds: Kinds, dofs: &[Vec<Dof>]) -> Vec<Nuisance> {
    let mut out = Vec::new();
    for kind in Kind::ALL.into_iter().filter(|k| kinds.has(*k)) {
        let first = usize::from(kind.contrast());
        for (case, ds) in dofs.iter().enumerate().skip(first) {
            for &dof in ds {
                // A contrast needs the DOF in the first run, whose offset balances the others.
                if kind.contrast() && !dofs[0].contains(&dof) {
                    continue;
                }
                out.push(Nuisance { kind, case, dof });
            }
        }
    }
    out
}

/// A run's offsets: added to its first state, to its force, to its simulated velocity.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Offsets {
    pub start: Vec6,
    pub force: Vec6,
    pub bias: Vec6,
}

impl Offsets {
    fn get(&self, kind: Kind) -> Vec6 {
        match kind {
            Kind::InitialState => self.start,
            Kind::Force => self.force,
            Kind::SensorBias => self.bias,
        }
    }

    fn slot(&mut self, kind: Kind) -> &mut Vec6 {
        match kind {
            Kind::InitialState => &mut self.start,
            Kind::Force => &mut self.force,
            Kind::SensorBias => &mut self.bias,
        }
    }
}

/// Every run's offsets from the nuisance values `x` (in the order of `nuisance`).
pub fn offsets(nuisance: &[Nuisance], x: &[f64], cases: usize) -> Vec<Offsets> {
    let mut out = vec![Offsets::default(); cases];
    for (n, v) in nuisance.iter().zip(x) {
        let i = n.dof.index();
        out[n.case].slot(n.kind)[i] += v;
        if n.kind.contrast() {
            out[0].slot(n.kind)[i] -= v;
        }
    }
    out
}

/// What the estimated nuisance parameters of one kind and DOF came to over the runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub kind: Kind,
    pub dof: Dof,
    pub runs: usize,
    /// Root mean square of the runs' values (SI: m/s, rad/s or N, N m).
    pub rms: f64,
    /// The largest in magnitude, signed.
    pub largest: f64,
}

impl Summary {
    /// One line for the report.
    pub fn sentence(&self) -> String {
        let unit = match self.kind {
            Kind::Force => self.dof.force_unit(),
            _ => self.dof.velocity_unit(),
        };
        format!(
            "{} {} of {} runs: rms {:.3} {unit}, largest {:+.3} {unit}",
            self.dof,
            self.kind.what(),
            self.runs,
            self.rms,
            self.largest
        )
    }
}

/// Per kind and DOF, the runs' offsets from `x`.
pub fn summarise(nuisance: &[Nuisance], x: &[f64], cases: usize) -> Vec<Summary> {
    let offs = offsets(nuisance, x, cases);
    let mut keys: Vec<(Kind, Dof)> = nuisance.iter().map(|n| (n.kind, n.dof)).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter()
        .map(|(kind, dof)| {
            let values: Vec<f64> = (0..cases)
                .filter(|&c| {
                    nuisance
                        .iter()
                        .any(|n| n.kind == kind && n.dof == dof && n.case == c)
                        || (kind.contrast() && c == 0)
                })
                .map(|c| offs[c].get(kind)[dof.index()])
                .collect();
            let rms =
                (values.iter().map(|v| v * v).sum::<f64>() / values.len().max(1) as f64).sqrt();
            let largest = values
                .iter()
                .copied()
                .max_by(|a, b| a.abs().total_cmp(&b.abs()))
                .unwrap_or(0.0);
            Summary {
                kind,
                dof,
                runs: values.len(),
                rms,
                largest,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contrasts_balance_on_the_first_run() {
        let dofs = vec![
            vec![Dof::Surge, Dof::Yaw],
            vec![Dof::Surge],
            vec![Dof::Surge, Dof::Yaw],
        ];
        let n = layout(Kinds::of(&[Kind::Force, Kind::InitialState]), &dofs);
        // 5 initial states; force: run 2 surge, run 3 surge and yaw.
        assert_eq!(n.len(), 8);
        let x = [0.1, 0.2, 0.3, 0.4, 0.5, 2.0, 3.0, -1.0];
        let o = offsets(&n, &x, 3);
        assert_eq!(o[0].start[0], 0.1);
        assert_eq!(o[0].start[5], 0.2);
        assert_eq!(o[1].force[0], 2.0);
        assert_eq!(o[2].force[5], -1.0);
        assert_eq!(o[0].force[0], -5.0);
        assert_eq!(o[0].force[5], 1.0);
        let s = summarise(&n, &x, 3);
        let surge = s
            .iter()
            .find(|s| s.kind == Kind::Force && s.dof == Dof::Surge)
            .unwrap();
        assert_eq!((surge.runs, surge.largest), (3, -5.0));
        assert!((surge.rms - (38.0f64 / 3.0).sqrt()).abs() < 1e-12);
    }

    /// Surge runs of a 30 kg vehicle, each with its own constant force (a current's pull that
    /// changes from run to run) and a first recorded sample 0.3 m/s off: the prediction-error
    /// fit recovers the drag and the offsets only when it estimates them.
    #[test]
    fn per_run_forces_and_initial_states_are_estimated_beside_the_drag() {
        use crate::core::model::{ParamLayout, Plant, Vehicle};
        use crate::core::response::{Response, Series, Source};
        use crate::identify::output_error::OutputError;
        use crate::identify::refine::{Bounds, output_error_lm_within};
        let mut vehicle = Vehicle::reference();
        (vehicle.mass_kg, vehicle.dofs) = (30.0, vec![Dof::Surge]);
        let layout = ParamLayout::new(&[Dof::Surge]);
        let truth = layout.from_hydro(&crate::twin::field::hydro());
        let plant = Plant::new(&vehicle, layout.to_hydro(&truth));
        let pulls = [6.0, -4.0, 3.0, -7.0, 2.0, 0.0];
        let runs: Vec<Response> = pulls
            .iter()
            .enumerate()
            .map(|(c, pull)| {
                let (dt, n) = (0.1, 400);
                let mut u = 0.0;
                let (mut t, mut f, mut v) = (vec![], vec![], vec![]);
                for k in 0..n {
                    let tk = k as f64 * dt;
                    let cmd = 40.0 * (0.3 * tk + c as f64).sin()
                        + 25.0 * (0.11 * tk + 0.5 * c as f64).sin().signum();
                    t.push(tk);
                    f.push(cmd);
                    v.push(u);
                    for _ in 0..20 {
                        let a = plant.accel(
                            &[u, 0.0, 0.0, 0.0, 0.0, 0.0],
                            &[cmd + pull, 0.0, 0.0, 0.0, 0.0, 0.0],
                        );
                        u += a[0] * dt / 20.0;
                    }
                }
                v[0] += 0.3;
                let series = Series {
                    accel: vec![0.0; n],
                    force: f,
                    velocity: v,
                    force_source: Source::Column,
                    accel_source: Source::Differentiated,
                };
                Response {
                    t,
                    dofs: [(Dof::Surge, series)].into(),
                    attitude: vec![],
                }
            })
            .collect();
        let refs: Vec<&Response> = runs.iter().collect();
        let start: Vec<f64> = truth.iter().map(|x| 0.6 * x).collect();
        let bounds = Bounds::signs(&layout);
        let fit = |kinds: &[Kind]| {
            let oe = OutputError::new(&vehicle, &refs).with_per_run(Kinds::of(kinds));
            let r = output_error_lm_within(&oe, &layout, &start, 60, &bounds);
            let s = summarise(&oe.nuisance, &r.nuisance, refs.len());
            (r, s)
        };
        let drag = |theta: &[f64]| {
            (theta[1] / truth[1] - 1.0)
                .abs()
                .max((theta[2] / truth[2] - 1.0).abs())
        };
        let (plain, _) = fit(&[]);
        let (both, summary) = fit(&[Kind::InitialState, Kind::Force]);
        assert!(drag(&both.theta) < 0.05, "{:?} vs {truth:?}", both.theta);
        assert!(
            drag(&plain.theta) > 2.0 * drag(&both.theta),
            "{:?}",
            plain.theta
        );
        assert!(
            both.cost_after < 0.05 * plain.cost_after,
            "{} {}",
            both.cost_after,
            plain.cost_after
        );
        // The pulls' offsets about their mean (0), and the starts 0.3 m/s back (less the pull of
        // the first sample, itself a measurement of the start).
        let force = summary.iter().find(|s| s.kind == Kind::Force).unwrap();
        let rms = (pulls.iter().map(|p| p * p).sum::<f64>() / 6.0).sqrt();
        assert!((force.rms - rms).abs() < 0.05 * rms, "{force:?} vs {rms}");
        assert!((force.largest + 7.0).abs() < 0.35, "{force:?}");
        let start = summary
            .iter()
            .find(|s| s.kind == Kind::InitialState)
            .unwrap();
        assert!(
            (start.rms - 0.3).abs() < 0.06 && start.largest < 0.0,
            "{start:?}"
        );
    }
}
