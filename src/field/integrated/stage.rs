//! `kind: integrated` — seed 000's identification of a model linear in its parameters from
//! free-running records without accelerations: each state's derivative written as a sum of
//! named terms (`w: [w, q, pitch, stern]`), integrated over windows, estimated by least
//! squares on the `role: train` runs, checked on the `role: validate` runs by the
//! autocorrelation of the one-step prediction error, and, with `rls`, tracked through each
//! estimation run by recursive least squares with a forgetting factor.

use crate::field::integrated::{
    self as method, Detail, Equation, EquationFit, Prediction, Rls, RunTrace, Trace, Windows,
};
use crate::field::signals;
use crate::pipeline::contract::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use crate::pool::fusion::run::FusedRun;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub static KIND: Kind = Kind {
    consumes: &[Artifact::PoolRuns],
    requires: &[Artifact::PoolRuns],
    uses_vehicle: crate::pipeline::contract::VehicleUse::Dofs,
    ..Kind::new("integrated", Artifact::FieldModel, parse_as::<Settings>)
};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    /// Each modelled state and the terms of its derivative: a signal (`w`, `pitch`, an
    /// actuator), a product (`u*q`), a modulus (`|w|*w`) or `1` (a constant).
    pub equations: BTreeMap<String, Vec<String>>,
    /// Integration window, s (rounded to whole samples). Seed 000 integrates between
    /// subsequent raw samples; the fused velocities are smoothed, which blurs each sharp
    /// change of the input over a few samples and biases short windows, so the default is
    /// 2 s. `0` takes one sample.
    #[serde(default = "two")]
    pub window_s: f64,
    #[serde(default)]
    pub rls: Option<Rls>,
    /// Longest lag of the prediction error's autocorrelation, s (at least 15 windows).
    #[serde(default = "twenty")]
    pub max_lag_s: f64,
}

fn twenty() -> f64 {
    20.0
}

fn two() -> f64 {
    2.0
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        self.check()?;
        let runs: Vec<FusedRun> = ctx
            .upstream_of(Artifact::PoolRuns)
            .map(|u| crate::pool::fusion::run::load(&u.dir))
            .collect::<Result<_, _>>()?;
        let (est, val, inputs) = crate::field::split_runs(&runs)?;
        let step = signals::median_step(&est[0].fused.t);
        let m = (self.window_s / step).round().max(1.0) as usize;
        let window_s = m as f64 * step;
        // Per run, per equation: its windows.
        let wins = |rs: &[&FusedRun]| -> anyhow::Result<Vec<Vec<Windows>>> {
            rs.iter().map(|r| self.windows(r, m)).collect()
        };
        let (we, wv) = (wins(&est)?, wins(&val)?);
        let equations = self.fit(&we)?;
        let traces = self.track(&est, &we);
        let (show, shown) = if val.is_empty() {
            (&est, &we)
        } else {
            (&val, &wv)
        };
        // At least 15 lags, however long the windows.
        let lags = ((self.max_lag_s / window_s).round() as usize).max(15);
        let predictions = show
            .iter()
            .zip(shown)
            .flat_map(|(r, ws)| {
                ws.iter()
                    .zip(&equations)
                    .map(move |(w, e)| prediction(&r.meta.run, e, w, window_s, lags))
            })
            .collect();
        let parameters = parameters(&equations);
        let detail = Detail {
            window_s,
            equations,
            rls: self.rls.clone(),
            traces,
            predictions,
        };
        let mut notes = ctx.failed_notes();
        if val.is_empty() {
            notes.push(
                "no `role: validate` run: the prediction error is shown on the estimation runs"
                    .into(),
            );
        }
        let result = crate::field::FieldResult {
            stage: ctx.stage.into(),
            kind: "integrated".into(),
            method: if self.rls.is_some() { "ls+rls" } else { "ls" }.into(),
            settings: self.settings(),
            inputs,
            estimation_runs: est.iter().map(|r| r.meta.run.clone()).collect(),
            validation_runs: val.iter().map(|r| r.meta.run.clone()).collect(),
            parameters,
            detail: crate::core::finite::to_value(&detail)?,
            notes,
        };
        crate::core::fsutil::write_json(&ctx.out.join(crate::field::RESULT), &result)
    }
}

impl Settings {
    /// Least squares per equation over the windows of every estimation run (`we[run][eq]`).
    fn fit(&self, we: &[Vec<Windows>]) -> anyhow::Result<Vec<EquationFit>> {
        let mut equations = Vec::new();
        for (i, (state, terms)) in self.equations.iter().enumerate() {
            let ws: Vec<&Windows> = we.iter().map(|r| &r[i]).collect();
            let estimate = method::least_squares(&ws).ok_or_else(|| {
                anyhow::anyhow!("equation of `{state}`: the integrated regressor is singular or has fewer windows than terms (a term that never changes, or two that are proportional: {})", terms.join(", "))
            })?;
            let names = terms.iter().map(|t| format!("d{state}/dt:{t}")).collect();
            equations.push(EquationFit {
                state: state.clone(),
                terms: terms.clone(),
                names,
                estimate,
            });
        }
        Ok(equations)
    }

    /// The RLS traces through each estimation run, when `rls` is set.
    fn track(&self, est: &[&FusedRun], we: &[Vec<Windows>]) -> Vec<RunTrace> {
        let Some(r) = &self.rls else {
            return Vec::new();
        };
        est.iter()
            .zip(we)
            .map(|(run, ws)| RunTrace {
                run: run.meta.run.clone(),
                traces: ws
                    .iter()
                    .map(|w| {
                        let zero = vec![0.0; w.f.first().map_or(0, Vec::len)];
                        thin(method::recursive(w, &zero, r.forgetting, r.p0))
                    })
                    .collect(),
            })
            .collect()
    }

    fn check(&self) -> anyhow::Result<()> {
        anyhow::ensure!(
            !self.equations.is_empty(),
            "equations: name at least one state and the terms of its derivative, e.g. `w: [w, q, pitch, stern]`"
        );
        for (s, terms) in &self.equations {
            anyhow::ensure!(!terms.is_empty(), "equations.{s}: no terms");
        }
        let w = self.window_s;
        anyhow::ensure!(
            w.is_finite() && w >= 0.0,
            "window_s must be a number of seconds (0 for one sample), not {w}"
        );
        if let Some(r) = &self.rls {
            anyhow::ensure!(
                r.forgetting > 0.0 && r.forgetting <= 1.0,
                "rls.forgetting must be in (0, 1], not {}",
                r.forgetting
            );
            anyhow::ensure!(
                r.p0.is_finite() && r.p0 > 0.0,
                "rls.p0 must be positive, not {}",
                r.p0
            );
        }
        Ok(())
    }

    /// The windows of every equation on run `r`.
    fn windows(&self, r: &FusedRun, m: usize) -> anyhow::Result<Vec<Windows>> {
        self.equations
            .iter()
            .map(|(state, terms)| {
                let y = signals::signal(r, state)?;
                let mut phi = Vec::new();
                let mut held = Vec::new();
                for t in terms {
                    let (v, h) = term(r, t)?;
                    phi.push(v);
                    held.push(h);
                }
                Ok(method::windows(&r.fused.t, &Equation { y, phi, held }, m))
            })
            .collect()
    }
}

/// Term `expr` of run `r` (`a*b`, `|a|`, `1`), and whether it is held between samples (it
/// contains a command or an actuator).
fn term(r: &FusedRun, expr: &str) -> anyhow::Result<(Vec<f64>, bool)> {
    let n = r.fused.t.len();
    let mut v = vec![1.0; n];
    let mut held = false;
    for f in expr.split('*').map(str::trim) {
        if f == "1" {
            continue;
        }
        let (name, abs) = match f.strip_prefix('|').and_then(|x| x.strip_suffix('|')) {
            Some(inner) => (inner.trim(), true),
            None => (f, false),
        };
        anyhow::ensure!(!name.is_empty(), "term `{expr}`: an empty factor");
        let s = signals::signal(r, name)?;
        held |= !signals::NAMES[..13].contains(&name);
        for (a, b) in v.iter_mut().zip(s) {
            *a *= if abs { b.abs() } else { b };
        }
    }
    Ok((v, held))
}

fn prediction(run: &str, e: &EquationFit, w: &Windows, window_s: f64, lags: usize) -> Prediction {
    let err = method::prediction_errors(w, &e.estimate.theta);
    let (acf, band95) = crate::field::arx::autocorrelation(&err, lags);
    // autocorrelation() gives the 99 % band; seed 000's figure reads against 95 %.
    let band = band95 * 1.96 / 2.58;
    // The measured state rebuilt from its increments, and the one-step prediction of it.
    let mut measured = Vec::with_capacity(w.y.len());
    let mut predicted = Vec::with_capacity(w.y.len());
    let mut level = 0.0;
    for (dy, e) in w.y.iter().zip(&err) {
        predicted.push(level + dy - e);
        level += dy;
        measured.push(level);
    }
    Prediction {
        run: run.into(),
        state: e.state.clone(),
        t: w.t.clone(),
        measured,
        predicted,
        error: err,
        lag_s: (0..acf.len()).map(|l| l as f64 * window_s).collect(),
        acf,
        band,
    }
}

fn parameters(eqs: &[EquationFit]) -> Vec<crate::field::Parameter> {
    let mut out = Vec::new();
    for e in eqs {
        for (j, name) in e.names.iter().enumerate() {
            out.push(crate::field::Parameter {
                name: name.clone(),
                value: e.estimate.theta[j],
                unit: format!(
                    "({})/s per ({})",
                    signals::unit(&e.state),
                    term_unit(&e.terms[j])
                ),
                stderr: e.estimate.stderr[j],
                model: None,
            });
        }
    }
    out
}

fn term_unit(t: &str) -> String {
    t.split('*')
        .map(|f| signals::unit(f.trim().trim_matches('|')))
        .collect::<Vec<_>>()
        .join(" ")
}

/// At most 500 points of a trace.
fn thin(tr: Trace) -> Trace {
    let stride = tr.t.len().div_ceil(500).max(1);
    Trace {
        t: tr.t.iter().step_by(stride).copied().collect(),
        theta: tr.theta.into_iter().step_by(stride).collect(),
    }
}
