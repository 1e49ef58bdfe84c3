//! `kind: arx` — ARX transfer functions from one input to one output of the pool runs
//! (seed 002): estimated on the `role: train` runs, the order and delay chosen over a grid by
//! a stated criterion, named candidate structures (the paper's tf1-tf4) compared beside the
//! chosen one, each simulated from the input alone on the `role: validate` runs.

use crate::field::arx::{self, Arx, Criterion, Detail, Model, Orders, Record, RunFit, Simulation};
use crate::field::signals;
use crate::pipeline::contract::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use crate::pool::fusion::run::FusedRun;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub static KIND: Kind = Kind {
    consumes: &[Artifact::PoolRuns],
    requires: &[Artifact::PoolRuns],
    uses_vehicle: crate::pipeline::contract::VehicleUse::Dofs,
    ..Kind::new("arx", Artifact::FieldModel, parse_as::<Settings>)
};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Detrend {
    /// Each run's mean input and output removed (the operating point), as MATLAB's `detrend`
    /// with `'constant'`.
    Mean,
    None,
}

/// The grid searched for the order and delay (inclusive ranges).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Search {
    pub na: [usize; 2],
    pub nb: [usize; 2],
    pub k: [usize; 2],
}

impl Default for Search {
    fn default() -> Search {
        Search {
            na: [1, 8],
            nb: [1, 6],
            k: [0, 4],
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    /// The input signal: an actuator of `actuators.csv` by name, or a command `X Y Z K M N`.
    pub input: String,
    /// The output signal: `u v w p q r`, `roll pitch yaw`, `depth`, `depth_rate`, ...
    pub output: String,
    /// Sample interval of the model, s; default the runs' own median step.
    #[serde(default)]
    pub sample_s: Option<f64>,
    #[serde(default = "mean")]
    pub detrend: Detrend,
    /// Named structures compared beside the chosen one, `name: [na, nb, k]`.
    #[serde(default)]
    pub structures: BTreeMap<String, [usize; 3]>,
    #[serde(default)]
    pub search: Search,
    #[serde(default = "mdl")]
    pub criterion: Criterion,
    /// Longest lag of the residual autocorrelation, samples.
    #[serde(default = "twenty")]
    pub max_lag: usize,
}

fn mean() -> Detrend {
    Detrend::Mean
}
fn mdl() -> Criterion {
    Criterion::Mdl
}
fn twenty() -> usize {
    20
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let runs: Vec<FusedRun> = ctx
            .upstream_of(Artifact::PoolRuns)
            .map(|u| crate::pool::fusion::run::load(&u.dir))
            .collect::<Result<_, _>>()?;
        let (est_runs, val_runs, inputs) = crate::field::split_runs(&runs)?;
        let h = self.sample_step(&est_runs[0].fused.t)?;
        let records = |rs: &[&FusedRun]| -> anyhow::Result<Vec<(Record, Vec<f64>)>> {
            rs.iter().map(|r| self.record(r, h)).collect()
        };
        let est = records(&est_runs)?;
        let val = records(&val_runs)?;
        let est_r: Vec<Record> = est.iter().map(|(r, _)| r.clone()).collect();
        let val_r: Vec<Record> = val.iter().map(|(r, _)| r.clone()).collect();
        let grid = self.grid()?;
        ctx.progress
            .set_message(format!("{} ARX structures", grid.len()));
        let ranking = arx::select(&est_r, &val_r, &grid, self.criterion);
        let best = ranking.first().ok_or_else(|| {
            anyhow::anyhow!("no ARX structure of the grid could be estimated: the runs are too short for these orders, or the input does not change")
        })?;
        let (models, mut notes) = self.models(best.orders, &est_r, &val_r)?;
        let show: Vec<&(Record, Vec<f64>)> = if val.is_empty() {
            est.iter().collect()
        } else {
            val.iter().collect()
        };
        let simulations = show
            .iter()
            .map(|(r, t)| simulation(r, t, &models))
            .collect();
        let (rr, _) = show[0];
        let (acf, band) = self.residual_acf(rr, &models);
        let parameters = parameters(&models, &self.input, &self.output);
        let detail = Detail {
            input: self.input.clone(),
            output: self.output.clone(),
            input_unit: signals::unit(&self.input).into(),
            output_unit: signals::unit(&self.output).into(),
            sample_s: h,
            criterion: self.criterion,
            grid_size: grid.len(),
            ranking: ranking.into_iter().take(12).collect(),
            models,
            simulations,
            residual_run: rr.name.clone(),
            residual_acf: acf,
            residual_band: band,
        };
        notes.extend(ctx.failed_notes());
        let result = crate::field::FieldResult {
            stage: ctx.stage.into(),
            kind: "arx".into(),
            method: "arx".into(),
            settings: self.settings(),
            inputs,
            estimation_runs: est_runs.iter().map(|r| r.meta.run.clone()).collect(),
            validation_runs: val_runs.iter().map(|r| r.meta.run.clone()).collect(),
            parameters,
            detail: crate::core::finite::to_value(&detail)?,
            notes,
        };
        crate::core::fsutil::write_json(&ctx.out.join(crate::field::RESULT), &result)
    }
}

impl Settings {
    /// The sampling step: `sample_s`, or the median step of the first estimation run.
    fn sample_step(&self, t: &[f64]) -> anyhow::Result<f64> {
        match self.sample_s {
            Some(h) => {
                anyhow::ensure!(
                    h.is_finite() && h > 0.0,
                    "sample_s must be a positive number of seconds, not {h}"
                );
                Ok(h)
            }
            None => Ok(signals::median_step(t)),
        }
    }

    /// The autocorrelation (and its 95 % band) of the selected model's one-step prediction
    /// error on the run `rr` (seed 000's whiteness check).
    fn residual_acf(&self, rr: &Record, models: &[Model]) -> (Vec<f64>, f64) {
        let chosen = models
            .iter()
            .find(|m| m.selected)
            .expect("the selected structure is estimated");
        let e: Vec<f64> =
            rr.y.iter()
                .zip(chosen.arx.predict(rr))
                .map(|(y, p)| y - p)
                .collect();
        arx::autocorrelation(&e, self.max_lag)
    }

    /// The structures of the search grid.
    fn grid(&self) -> anyhow::Result<Vec<Orders>> {
        let s = &self.search;
        anyhow::ensure!(
            s.na[0] <= s.na[1] && s.nb[0] <= s.nb[1] && s.k[0] <= s.k[1] && s.nb[1] >= 1,
            "search: each range is [lowest, highest] and nb reaches at least 1"
        );
        Ok(arx::grid(s.na, s.nb, s.k))
    }

    /// The named structures and the selected one (`best`), estimated and scored on `val`;
    /// a note for each that could not be estimated.
    fn models(
        &self,
        best: Orders,
        est: &[Record],
        val: &[Record],
    ) -> anyhow::Result<(Vec<Model>, Vec<String>)> {
        let mut named: Vec<(String, Orders)> = self
            .structures
            .iter()
            .map(|(n, [na, nb, k])| {
                (
                    n.clone(),
                    Orders {
                        na: *na,
                        nb: *nb,
                        k: *k,
                    },
                )
            })
            .collect();
        if !named.iter().any(|(_, o)| *o == best) {
            named.push(("selected".into(), best));
        }
        let mut models = Vec::new();
        let mut notes = Vec::new();
        for (name, o) in &named {
            anyhow::ensure!(o.nb >= 1, "structure `{name}`: nb must be at least 1");
            match arx::estimate(est, *o) {
                Some(m) => models.push(model(name, m, *o == best, val)),
                None => notes.push(format!("structure `{name}` ({o}) could not be estimated: too few samples or a singular regressor")),
            }
        }
        Ok((models, notes))
    }

    /// Run `r` resampled at `h`: the output interpolated, the input held (a command stays
    /// until the next), both detrended as set; and the record's times.
    fn record(&self, r: &FusedRun, h: f64) -> anyhow::Result<(Record, Vec<f64>)> {
        let t = &r.fused.t;
        let u = signals::signal(r, &self.input)?;
        let y = signals::signal(r, &self.output)?;
        let at = signals::grid(t[0], t[t.len() - 1], h);
        let mut u = hold(t, &u, &at);
        let mut y = signals::interpolate(t, &y, &at);
        if self.detrend == Detrend::Mean {
            for v in [&mut u, &mut y] {
                let m = v.iter().sum::<f64>() / v.len() as f64;
                v.iter_mut().for_each(|x| *x -= m);
            }
        }
        Ok((
            Record {
                name: r.meta.run.clone(),
                u,
                y,
            },
            at,
        ))
    }
}

fn model(name: &str, m: Arx, selected: bool, val: &[Record]) -> Model {
    let validation = val
        .iter()
        .map(|r| {
            let sim = m.simulate(r);
            let finite = |x: f64| Some(x).filter(|v| v.is_finite());
            RunFit {
                run: r.name.clone(),
                fit_pct: finite(arx::fit_percent(&r.y, &sim)),
                simulation_loss: finite(arx::mean_square(&r.y, &sim)),
                prediction_loss: finite(arx::mean_square(&r.y, &m.predict(r))),
            }
        })
        .collect();
    Model {
        name: name.to_string(),
        selected,
        poles: m.poles(),
        zeros: m.zeros(),
        stable: m.stable(),
        gain: m.gain(),
        arx: m,
        validation,
    }
}

fn simulation(r: &Record, t: &[f64], models: &[Model]) -> Simulation {
    Simulation {
        run: r.name.clone(),
        t: t.to_vec(),
        input: r.u.clone(),
        measured: r.y.clone(),
        // A diverged simulation is left out of the plot (its table row says so).
        models: models
            .iter()
            .map(|m| {
                let sim = m.arx.simulate(r);
                let ok =
                    arx::fit_percent(&r.y, &sim).is_finite() && sim.iter().all(|v| v.is_finite());
                (m.name.clone(), if ok { sim } else { Vec::new() })
            })
            .collect(),
    }
}

/// The coefficients of every model as parameters (`a1`, `b1`, ... of the model's name).
fn parameters(models: &[Model], input: &str, output: &str) -> Vec<crate::field::Parameter> {
    let (ui, uo) = (signals::unit(input), signals::unit(output));
    let mut out = Vec::new();
    for m in models {
        let a = m
            .arx
            .a
            .iter()
            .zip(&m.arx.a_std)
            .enumerate()
            .map(|(i, (v, s))| (format!("a{}", i + 1), *v, *s, String::from("1")));
        let b = m
            .arx
            .b
            .iter()
            .zip(&m.arx.b_std)
            .enumerate()
            .map(|(i, (v, s))| (format!("b{}", i + 1), *v, *s, format!("({uo})/({ui})")));
        for (name, value, stderr, unit) in a.chain(b) {
            out.push(crate::field::Parameter {
                name,
                value,
                unit,
                stderr,
                model: Some(m.name.clone()),
            });
        }
    }
    out
}

/// `y(t)` held from the last sample at or before each of `at`.
fn hold(t: &[f64], y: &[f64], at: &[f64]) -> Vec<f64> {
    let mut j = 0usize;
    at.iter()
        .map(|&x| {
            while j + 1 < t.len() && t[j + 1] <= x + 1e-9 {
                j += 1;
            }
            y[j]
        })
        .collect()
}
