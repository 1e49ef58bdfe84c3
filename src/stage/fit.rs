//! `kind: fit` — identifies the hydrodynamic parameters from every CFD response it reads.

use super::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use crate::estimate::identify;
use crate::estimate::result::{CaseRef, Expected, FitResult, Objective, RESULT, RunRef};
use crate::estimate::{self};
use crate::io::response;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub static KIND: Kind = Kind {
    consumes: &[Artifact::Responses, Artifact::PoolRuns],
    requires_one_of: &[Artifact::Responses, Artifact::PoolRuns],
    ..Kind::new("fit", Artifact::Model, parse_as::<Settings>)
};

/// A fit's settings: the method with its own settings (resolved when parsed), and the
/// settings every method shares. Written flat in `pipeline.yaml` (`method: qpso`,
/// `population: 60`, `skip_start_s: 0.2`); a key neither the method nor the fit reads is an
/// error.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    pub method: estimate::Method,
    pub common: Common,
}

/// The settings of a fit that do not depend on its method.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Common {
    pub method: String,
    pub objective: Objective,
    /// Samples before this time in each case are left out: the start-up transient of the
    /// fluid-body coupling (impulsive start, pressure waves) is not vehicle dynamics.
    pub skip_start_s: f64,
    /// The body this fit identifies, when it is not the pipeline's vehicle (a CFD test body
    /// such as the OpenFOAM cylinder). A case that states its own mass overrides `mass_kg`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vehicle: Option<crate::model::Vehicle>,
    /// Reference values to show beside the identified ones (e.g. potential-flow added mass);
    /// not used by the fit.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub expected: BTreeMap<String, Expected>,
    /// Length for the drag coefficients the report shows for a 2D body per metre of span,
    /// Cd = drag / (1/2 rho u^2 L) (a cylinder: its diameter), m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_length_m: Option<f64>,
    /// Two-step identification (method ols): the added mass from the first this-many seconds
    /// of each case after `skip_start_s`, while the body accelerates from rest and its drag is
    /// still negligible, then the drag coefficients from every sample with that added mass
    /// held. For bodies whose drag depends on the history of the motion (a wake that builds
    /// up), which a one-step fit would fold into the added mass.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub added_mass_window_s: Option<f64>,
    /// The parameter set this fit identifies, when not the vehicle's (`full_qd`, `diag_qd`,
    /// `diag_mass`, `diag_all`, `full_ld`, `custom`: seed 003 Table I; `diagonal`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub structure: Option<crate::model::Structure>,
    /// The terms of `structure: custom`, when not the vehicle's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub custom_terms: Option<crate::model::CustomTerms>,
    /// Seed 003's median outlier filter on the pool runs' velocities (translational) and
    /// accelerations (angular) before the regression: `median_filter: {}` for its values
    /// (length 9, 0.03 m/s, 0.3 deg/s^2). Off when not set.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub median_filter: Option<estimate::median::MedianFilter>,
}

impl Default for Common {
    fn default() -> Self {
        Common {
            // The prediction-error method: least squares where there are only CFD cases, the
            // simulation error of the pool runs where there are any (see estimate::pem).
            method: "pem".into(),
            objective: Objective::EquationError,
            skip_start_s: 0.0,
            vehicle: None,
            expected: BTreeMap::new(),
            reference_length_m: None,
            added_mass_window_s: None,
            structure: None,
            custom_terms: None,
            median_filter: None,
        }
    }
}

impl Settings {
    /// Method `name` with its default settings and the default common ones.
    pub fn of_method(name: &str) -> Settings {
        Settings {
            method: estimate::Method::parse(name, Default::default()).expect("a registered method"),
            common: Common {
                method: name.into(),
                ..Common::default()
            },
        }
    }

    /// `ols`, `qpso (l1, output error)`: how tables name this configuration.
    pub fn label(&self) -> String {
        self.method
            .label(self.common.objective == Objective::OutputError)
    }
}

impl Default for Settings {
    fn default() -> Self {
        Settings::of_method("ols")
    }
}

const COMMON_KEYS: [&str; 10] = [
    "median_filter",
    "structure",
    "custom_terms",
    "method",
    "objective",
    "skip_start_s",
    "vehicle",
    "expected",
    "reference_length_m",
    "added_mass_window_s",
];

/// A method's "unknown field" error, with every key the fit reads as the expected ones (so
/// a misspelled common key is suggested too) and what the method itself reads.
fn unknown_key(e: &str, method: &str) -> String {
    let Some(rest) = e.strip_prefix("unknown field `") else {
        return format!("{e} (settings of method {method})");
    };
    let key = rest.split('`').next().unwrap_or_default();
    let own: Vec<&str> = e
        .split("expected")
        .nth(1)
        .map_or(vec![], |s| s.split('`').skip(1).step_by(2).collect());
    let all: Vec<String> = own
        .iter()
        .chain(COMMON_KEYS.iter())
        .map(|k| format!("`{k}`"))
        .collect();
    let reads = if own.is_empty() {
        "no settings of its own".to_string()
    } else {
        own.join(", ")
    };
    format!(
        "unknown field `{key}`, expected one of {} (method {method} reads {reads})",
        all.join(", ")
    )
}

impl<'de> Deserialize<'de> for Settings {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Settings, D::Error> {
        use serde::de::Error;
        let mut all = serde_json::Map::<String, serde_json::Value>::deserialize(d)?;
        let mut common = serde_json::Map::new();
        for k in COMMON_KEYS {
            if let Some(v) = all.remove(k) {
                common.insert(k.to_string(), v);
            }
        }
        let common: Common =
            serde_json::from_value(serde_json::Value::Object(common)).map_err(D::Error::custom)?;
        let known = estimate::by_name(&common.method).is_some();
        let method = estimate::Method::parse(&common.method, all).map_err(|e| {
            if known {
                D::Error::custom(unknown_key(&e, &common.method))
            } else {
                D::Error::custom(e)
            }
        })?;
        Ok(Settings { method, common })
    }
}

impl Serialize for Settings {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut v = serde_json::to_value(&self.common).map_err(serde::ser::Error::custom)?;
        let obj = v.as_object_mut().expect("settings are a map");
        if let Some(own) = self.method.settings.as_object() {
            obj.extend(own.clone());
        }
        v.serialize(s)
    }
}

impl Settings {
    /// The body this fit identifies with the structure it identifies.
    fn vehicle(&self, pipeline: &crate::model::Vehicle) -> anyhow::Result<crate::model::Vehicle> {
        let mut v = self
            .common
            .vehicle
            .clone()
            .unwrap_or_else(|| pipeline.clone());
        if let Some(s) = self.common.structure {
            v.structure = s;
        }
        if self.common.custom_terms.is_some() {
            v.custom_terms = self.common.custom_terms.clone();
        }
        let problems = v.problems();
        anyhow::ensure!(
            problems.is_empty(),
            "this fit's model cannot be built: {}",
            problems.join("; ")
        );
        Ok(v)
    }
}

impl StageImpl for Settings {
    /// Only the settings the chosen method reads, so tuning the swarm does not rerun a
    /// least-squares fit (and a deterministic method shows no seed).
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let start = std::time::Instant::now();
        let vehicle = &self.vehicle(ctx.vehicle)?;
        let (cases, responses) = cfd_cases(ctx)?;
        let (runs, pool_responses, mut notes) =
            training_runs(ctx, vehicle, self.common.median_filter.as_ref())?;
        notes.extend(ctx.failed_notes());
        check_windows(ctx, &self.common, responses.iter().chain(&pool_responses))?;
        let labelled = cases
            .iter()
            .map(|c| c.source.path.clone())
            .zip(&responses)
            .chain(
                runs.iter()
                    .map(|r| format!("pool run {}", r.run))
                    .zip(&pool_responses),
            );
        for (source, r) in labelled {
            if let Some(bad) = r.non_finite(&vehicle.dofs, self.common.skip_start_s) {
                anyhow::bail!(
                    "{source}: {bad}: no estimator can use it\n  help: fix or remove that sample in the input (or start the fit after it with skip_start_s)"
                );
            }
        }
        let data = identify::Data {
            vehicle,
            cases: responses
                .iter()
                .zip(&cases)
                .map(|(r, c)| (r, c.mass_kg))
                .collect(),
            pool: pool_responses.iter().collect(),
            skip_start_s: self.common.skip_start_s,
        };
        ctx.progress
            .set_message(format!("fitting with {}", self.method.name()));
        let bar = ctx.progress;
        let report = move |f: f64| bar.set_message(format!("{:.0} %", 100.0 * f));
        let id = identify::identify(
            &data,
            &identify::Request {
                method: &self.method,
                objective: self.common.objective,
                added_mass_window_s: self.common.added_mass_window_s,
                progress: Some(&report),
            },
        )?;
        notes.extend(id.notes);
        let mut fit = id.fit;
        let objective = match fit.refinement {
            Some(_) => Objective::OutputError,
            None => self.common.objective,
        };
        let theta: Vec<f64> = fit.parameters.iter().map(|p| p.value).collect();
        let layout = crate::model::ParamLayout::of(vehicle);
        let plant = crate::model::Plant::new(vehicle, layout.to_hydro(&theta));
        if let Some(why) = plant.mass_problem() {
            anyhow::bail!(
                "the identified {} model is refused: {why}\n  help: a structure with fewer mass terms (diag_mass, diag_all), or runs that excite the coupled DOFs more, give a physical mass matrix",
                vehicle.structure.label()
            );
        }
        if per_metre_of_span(&cases, runs.len())? {
            for p in &mut fit.parameters {
                p.unit = crate::model::params::per_metre_of_span(&p.unit);
            }
        }
        let result = FitResult {
            stage: ctx.stage.to_string(),
            method: self.method.name().to_string(),
            objective,
            settings: self.settings(),
            structure: vehicle.structure,
            custom_terms: vehicle.custom_terms.clone(),
            dofs: vehicle.dofs.clone(),
            constant_force: id.constant_force,
            fit,
            cases,
            runs,
            notes,
            elapsed_s: start.elapsed().as_secs_f64(),
            vehicle: self.common.vehicle.clone(),
            expected: self.common.expected.clone(),
            one_step: id.one_step,
        };
        super::write_json(&ctx.out.join(RESULT), &result)
    }
}

/// `skip_start_s` (and the added-mass window after it) must leave samples to fit: a time
/// beyond every run is a setting to fix, said at its line.
fn check_windows<'r>(
    ctx: &RunCtx,
    common: &Common,
    responses: impl Iterator<Item = &'r crate::io::Response>,
) -> anyhow::Result<()> {
    let end = responses
        .filter_map(|r| r.t.last().copied())
        .fold(f64::NEG_INFINITY, f64::max);
    if end.is_finite() && common.skip_start_s >= end {
        return Err(ctx.setting_error(
            "skip_start_s",
            format!(
                "skip_start_s = {} s leaves no sample to fit: the longest run ends at {end} s",
                common.skip_start_s
            ),
            "set skip_start_s below the runs' length (it drops each run's first seconds, the start-up transient)",
        ));
    }
    if let Some(w) = common.added_mass_window_s
        && (w.is_nan() || w <= 0.0)
    {
        return Err(ctx.setting_error(
            "added_mass_window_s",
            format!("added_mass_window_s = {w} s: the window must be longer than 0"),
            "set the seconds after skip_start_s in which the body accelerates from rest",
        ));
    }
    Ok(())
}

/// Whether the coefficients are per metre of span: every case is 2D. A 2D case's forces and
/// masses are per metre, a 3D case's and a pool run's are not, and one fit cannot mix them.
fn per_metre_of_span(cases: &[CaseRef], pool_runs: usize) -> anyhow::Result<bool> {
    let two_d = cases.iter().filter(|c| c.per_metre_of_span).count();
    if two_d == 0 {
        return Ok(false);
    }
    anyhow::ensure!(
        two_d == cases.len() && pool_runs == 0,
        "this fit reads {two_d} 2D cases (forces and masses per metre of span) together with {} 3D cases and {pool_runs} pool runs; their coefficients are in different units\n  help: fit the 2D cases in a stage of their own (`from: [openfoam]`)",
        cases.len() - two_d
    );
    Ok(true)
}

/// The CFD responses among the upstream, with what the result says of each case.
fn cfd_cases(ctx: &RunCtx) -> anyhow::Result<(Vec<CaseRef>, Vec<crate::io::Response>)> {
    let mut cases = Vec::new();
    let mut responses = Vec::new();
    for up in ctx.upstream_of(Artifact::Responses) {
        let (meta, r) = response::load(&up.dir)?;
        cases.push(CaseRef {
            id: up.id.clone(),
            case: meta.case,
            source: meta.source,
            inputs: meta.all_inputs,
            mass_kg: meta.body_mass_kg,
            per_metre_of_span: meta.per_metre_of_span,
        });
        responses.push(r);
    }
    Ok((cases, responses))
}

/// The `role: train` pool runs among the upstream, as response tables (logged command, fused
/// velocity and its derivative). Runs without every DOF of the vehicle are left out and said.
fn training_runs(
    ctx: &RunCtx,
    vehicle: &crate::model::Vehicle,
    filter: Option<&estimate::median::MedianFilter>,
) -> anyhow::Result<(Vec<RunRef>, Vec<crate::io::Response>, Vec<String>)> {
    let (mut refs, mut responses, mut notes) = (Vec::new(), Vec::new(), Vec::new());
    for up in ctx.upstream_of(Artifact::PoolRuns) {
        let run = crate::fusion::run::load_for(&up.dir, vehicle)?;
        if run.meta.role != crate::io::pool::Role::Train {
            continue;
        }
        match run.as_response(vehicle, filter) {
            Some(r) => {
                refs.push(RunRef {
                    id: up.id.clone(),
                    run: run.meta.run.clone(),
                    inputs: run.meta.sources.clone(),
                });
                responses.push(r);
            }
            None => {
                let missing: Vec<String> = run
                    .missing_dofs(vehicle)
                    .iter()
                    .map(|d| d.to_string())
                    .collect();
                notes.push(format!(
                    "pool run {} left out: its sensors gave no {} velocity",
                    run.meta.run,
                    missing.join(", ")
                ));
            }
        }
    }
    if ctx.upstream_of(Artifact::PoolRuns).next().is_some() && refs.is_empty() {
        anyhow::bail!(
            "no pool run with `role: train` and every DOF fused to fit on\n  help: mark the runs to identify from `role: train` in their run.yaml; {}",
            if notes.is_empty() {
                "the others are held out for validation".into()
            } else {
                notes.join("; ")
            }
        );
    }
    Ok((refs, responses, notes))
}
