//! `kind: adaptive` — seed 004's adaptive identifier of plant and actuator parameters, run
//! over the `role: train` runs alongside their data (body velocities from the DVL, rates and
//! attitude from the AHRS, the logged fin and propeller commands), the result fixed in scale
//! by one known parameter, the excitation of every run checked, and the identified model
//! simulated on every run (self-validation on the training runs, cross-validation on the
//! others: seed 004 Table 6 and Fig. 4 in form).

use crate::field::adaptive::aid::{self, Gains, Record};
use crate::field::adaptive::result::{Detail, RunExcitation, Simulation, Validation};
use crate::field::adaptive::{Actuators, NAMES, P};
use crate::field::signals;
use crate::pipeline::contract::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use crate::pool::fusion::run::FusedRun;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub static KIND: Kind = Kind {
    consumes: &[Artifact::PoolRuns],
    requires: &[Artifact::PoolRuns],
    uses_vehicle: crate::pipeline::contract::VehicleUse::Dofs,
    ..Kind::new("adaptive", Artifact::FieldModel, parse_as::<Settings>)
};

/// The known parameter that fixes the scale.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Known {
    pub name: String,
    pub value: f64,
}

/// The excitation check.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Excite {
    pub window_s: f64,
    /// Eigenvalues below this fraction of the largest are reported as not excited.
    pub threshold: f64,
}

impl Default for Excite {
    fn default() -> Excite {
        Excite {
            window_s: 200.0,
            threshold: 1e-4,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    #[serde(flatten)]
    pub actuators: Actuators,
    /// A starting value for every parameter (seed 004 Table 5: arbitrary, of the right
    /// magnitude; masses positive). Their sizes also scale the adaptation.
    pub initial: BTreeMap<String, f64>,
    pub gains: Gains,
    /// How many times the identifier runs through the training runs.
    #[serde(default = "one")]
    pub passes: usize,
    pub scale_by: Known,
    #[serde(default)]
    pub excitation: Excite,
}

fn one() -> usize {
    1
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let (theta0, known) = self.check()?;
        let runs: Vec<FusedRun> = ctx
            .upstream_of(Artifact::PoolRuns)
            .map(|u| crate::pool::fusion::run::load(&u.dir))
            .collect::<Result<_, _>>()?;
        let (est, val, inputs) = crate::field::split_runs(&runs)?;
        let records: Vec<(Record, &str)> = runs
            .iter()
            .map(|r| Ok((self.record(r)?, r.meta.role.as_str())))
            .collect::<anyhow::Result<_>>()?;
        let train: Vec<&Record> = records
            .iter()
            .filter(|(_, role)| *role == "train")
            .map(|(r, _)| r)
            .collect();
        let id = self.identify(ctx, &train, &theta0, known);
        let Identified {
            theta,
            trace_t,
            trace,
            last_rms,
        } = id;
        anyhow::ensure!(
            theta.iter().all(|x| x.is_finite()),
            "the identifier diverged: lower gains.adaptation"
        );
        let scaled = aid::scaled(&theta, known, self.scale_by.value);
        let excitation: Vec<RunExcitation> = records
            .iter()
            .map(|(r, _)| self.excitation(r, &theta))
            .collect();
        // Fig. 4 on the held-out run that excites most (a manoeuvring dive, not a straight one).
        let shown = records
            .iter()
            .zip(&excitation)
            .filter(|((_, role), _)| *role == "validate")
            .max_by(|a, b| a.1.whole.min_ratio.total_cmp(&b.1.whole.min_ratio))
            .map(|((r, _), _)| r.name.clone());
        let (validation, simulations) = validate(
            &self.actuators,
            &records,
            &train,
            (&theta0, &theta),
            shown.as_deref(),
        );
        let parameters = parameters(&scaled, &trace);
        let detail = Detail {
            names: NAMES.iter().map(|(n, _)| n.to_string()).collect(),
            initial: theta0,
            raw: theta,
            scaled,
            scale_by: self.scale_by.name.clone(),
            known_value: self.scale_by.value,
            trace_t,
            trace,
            velocity_error_rms: last_rms,
            excitation,
            threshold: self.excitation.threshold,
            validation,
            simulations,
        };
        let result = crate::field::FieldResult {
            stage: ctx.stage.into(),
            kind: "adaptive".into(),
            method: "aid".into(),
            settings: self.settings(),
            inputs,
            estimation_runs: est.iter().map(|r| r.meta.run.clone()).collect(),
            validation_runs: val.iter().map(|r| r.meta.run.clone()).collect(),
            parameters,
            detail: crate::core::finite::to_value(&detail)?,
            notes: ctx.failed_notes(),
        };
        crate::core::fsutil::write_json(&ctx.out.join(crate::field::RESULT), &result)
    }
}

/// The identifier's result over the training runs.
struct Identified {
    theta: Vec<f64>,
    trace_t: Vec<f64>,
    trace: Vec<Vec<f64>>,
    last_rms: [f64; 6],
}

impl Settings {
    /// The identifier run `passes` times through the training runs, one after the other, the
    /// scaled estimate traced on one clock.
    fn identify(
        &self,
        ctx: &RunCtx,
        train: &[&Record],
        theta0: &[f64],
        known: usize,
    ) -> Identified {
        let power = mean_power(&self.actuators, train);
        let size: Vec<f64> = theta0.iter().map(|x| x.abs()).collect();
        let mut id = Identified {
            theta: theta0.to_vec(),
            trace_t: vec![],
            trace: vec![],
            last_rms: [0.0; 6],
        };
        let mut offset = 0.0;
        for pass in 0..self.passes {
            // Ctrl-C: stop; the executor keeps nothing of a stage cut short.
            if crate::core::interrupt::requested() {
                break;
            }
            for rec in train {
                ctx.progress
                    .set_message(format!("pass {} on {}", pass + 1, rec.name));
                let run = aid::identify(&self.actuators, rec, &id.theta, self.gains, &power, &size);
                for (t, th) in run.t.iter().zip(&run.theta) {
                    id.trace_t.push(offset + t - rec.t[0]);
                    id.trace.push(aid::scaled(th, known, self.scale_by.value));
                }
                offset += rec.t[rec.t.len() - 1] - rec.t[0];
                id.theta = run.last;
                id.last_rms = run.velocity_error_rms;
            }
        }
        id
    }

    /// The initial vector in the model's order and the index of the known parameter.
    fn check(&self) -> anyhow::Result<(Vec<f64>, usize)> {
        let names: Vec<&str> = NAMES.iter().map(|(n, _)| *n).collect();
        for k in self.initial.keys() {
            anyhow::ensure!(
                names.contains(&k.as_str()),
                "initial: unknown parameter `{k}`; the model's are {}",
                names.join(", ")
            );
        }
        let missing: Vec<&str> = names
            .iter()
            .copied()
            .filter(|n| !self.initial.contains_key(*n))
            .collect();
        anyhow::ensure!(
            missing.is_empty(),
            "initial: give a starting value for {} (of the right magnitude: it also sets how fast each adapts)",
            missing.join(", ")
        );
        let theta0: Vec<f64> = names.iter().map(|n| self.initial[*n]).collect();
        anyhow::ensure!(
            theta0[..6].iter().all(|m| *m > 0.0),
            "initial: the masses m_u..m_r must be positive"
        );
        if let Some((n, _)) = names
            .iter()
            .zip(&theta0)
            .find(|(_, v)| **v == 0.0 || !v.is_finite())
        {
            anyhow::bail!(
                "initial.{n}: give a non-zero starting value of the expected magnitude (it sets how far the parameter adapts per second; 0 would freeze it)"
            );
        }
        let known = names
            .iter()
            .position(|n| *n == self.scale_by.name)
            .ok_or_else(|| {
                anyhow::anyhow!("scale_by: unknown parameter `{}`", self.scale_by.name)
            })?;
        anyhow::ensure!(
            self.scale_by.value.is_finite() && self.scale_by.value != 0.0,
            "scale_by.value must be a known, non-zero value"
        );
        let g = self.gains;
        anyhow::ensure!(
            g.velocity > 0.0 && g.adaptation > 0.0,
            "gains: velocity and adaptation must be positive"
        );
        anyhow::ensure!(self.passes >= 1, "passes must be at least 1");
        anyhow::ensure!(
            !self.actuators.fins.is_empty() || !self.actuators.thruster.is_empty(),
            "name the fins and the thruster"
        );
        Ok((theta0, known))
    }

    fn record(&self, r: &FusedRun) -> anyhow::Result<Record> {
        let sig = |n: &str| signals::signal(r, n);
        let cols: Vec<Vec<f64>> = ["u", "v", "w", "p", "q", "r"]
            .iter()
            .map(|n| sig(n))
            .collect::<Result<_, _>>()?;
        let (roll, pitch) = (sig("roll")?, sig("pitch")?);
        let fins: Vec<Vec<f64>> = self
            .actuators
            .fins
            .iter()
            .map(|f| sig(&f.name))
            .collect::<Result<_, _>>()?;
        let n = r.fused.t.len();
        Ok(Record {
            name: r.meta.run.clone(),
            t: r.fused.t.clone(),
            nu: (0..n)
                .map(|k| std::array::from_fn(|i| cols[i][k]))
                .collect(),
            roll_pitch: (0..n).map(|k| [roll[k], pitch[k]]).collect(),
            fins: (0..n)
                .map(|k| fins.iter().map(|f| f[k]).collect())
                .collect(),
            prop: sig(&self.actuators.thruster)?,
        })
    }

    fn excitation(&self, r: &Record, theta: &[f64]) -> RunExcitation {
        let acc = r.accelerations();
        let n = r.t.len();
        let step = signals::median_step(&r.t);
        let w = ((self.excitation.window_s / step).round() as usize).clamp(10, n.max(10));
        let th = self.excitation.threshold;
        let windows = (0..n / w)
            .map(|i| aid::excitation(&self.actuators, r, &acc, i * w..(i + 1) * w, theta, th))
            .collect();
        RunExcitation {
            run: r.name.clone(),
            windows,
            whole: aid::excitation(&self.actuators, r, &acc, 0..n, theta, th),
        }
    }
}

fn mean_power(act: &Actuators, train: &[&Record]) -> Vec<f64> {
    let mut p = vec![0.0; P];
    for r in train {
        for (a, b) in p.iter_mut().zip(aid::column_power(act, r)) {
            *a += b / train.len() as f64;
        }
    }
    p
}

/// Every run simulated with the initial and the identified parameters, and the traces of the
/// held-out run `shown`.
fn validate(
    act: &Actuators,
    records: &[(Record, &str)],
    train: &[&Record],
    (theta0, theta): (&[f64], &[f64]),
    shown: Option<&str>,
) -> (Vec<Validation>, Vec<Simulation>) {
    let trained_on = train
        .iter()
        .map(|r| r.name.as_str())
        .collect::<Vec<_>>()
        .join(", ");
    let mut out = Vec::new();
    let mut sims = Vec::new();
    for (r, role) in records {
        let s0 = aid::simulate(act, r, theta0);
        let s1 = aid::simulate(act, r, theta);
        out.push(Validation {
            trained_on: trained_on.clone(),
            run: r.name.clone(),
            role: role.to_string(),
            initial: s0.as_ref().map(|s| aid::mae(r, s)),
            identified: s1.as_ref().map(|s| aid::mae(r, s)),
        });
        if shown == Some(r.name.as_str()) {
            let stride = r.t.len().div_ceil(800).max(1);
            let thin = |v: &[[f64; 6]]| v.iter().step_by(stride).copied().collect::<Vec<_>>();
            sims.push(Simulation {
                run: r.name.clone(),
                t: r.t.iter().step_by(stride).copied().collect(),
                measured: thin(&r.nu),
                initial: s0.as_deref().map_or(Vec::new(), thin),
                identified: s1.as_deref().map_or(Vec::new(), thin),
            });
        }
    }
    (out, sims)
}

/// The scaled estimates, each with the spread of its scaled trace over the last quarter of
/// the identification as its uncertainty.
fn parameters(scaled: &[f64], trace: &[Vec<f64>]) -> Vec<crate::field::Parameter> {
    let tail = &trace[trace.len() * 3 / 4..];
    NAMES
        .iter()
        .enumerate()
        .map(|(j, (name, unit))| {
            let n = tail.len().max(1) as f64;
            let mean = tail.iter().map(|t| t[j]).sum::<f64>() / n;
            let sd = (tail.iter().map(|t| (t[j] - mean).powi(2)).sum::<f64>() / n).sqrt();
            crate::field::Parameter {
                name: name.to_string(),
                value: scaled[j],
                unit: unit.to_string(),
                stderr: sd,
                model: None,
            }
        })
        .collect()
}
