//! `kind: fit` — identifies the hydrodynamic parameters from every CFD response it reads.

use super::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use crate::dof::Dof;
use crate::estimate::result::{CaseRef, Expected, FitResult, Objective, RESULT, RunRef};
use crate::estimate::{self, Fit, Regression};
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
}

impl Default for Common {
    fn default() -> Self {
        Common {
            method: "ols".into(),
            objective: Objective::EquationError,
            skip_start_s: 0.0,
            vehicle: None,
            expected: BTreeMap::new(),
            reference_length_m: None,
            added_mass_window_s: None,
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

    /// The options an estimator runs with: the method's settings over the fit's context.
    pub fn options<'a>(
        &self,
        rigid_mass: [f64; 6],
        progress: Option<&'a (dyn Fn(f64) + Sync)>,
        output_error: Option<(&'a crate::model::Vehicle, &'a [&'a crate::io::Response])>,
    ) -> estimate::Options<'a> {
        self.method.options(estimate::Options {
            rigid_mass,
            progress,
            output_error: output_error.filter(|_| self.common.objective == Objective::OutputError),
            ..Default::default()
        })
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

const COMMON_KEYS: [&str; 7] = [
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

impl StageImpl for Settings {
    /// Only the settings the chosen method reads, so tuning the swarm does not rerun a
    /// least-squares fit (and a deterministic method shows no seed).
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let start = std::time::Instant::now();
        let vehicle = self.common.vehicle.as_ref().unwrap_or(ctx.vehicle);
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
            });
            responses.push(r);
        }
        let (runs, pool_responses, mut notes) = training_runs(ctx, vehicle)?;
        notes.extend(ctx.failed_notes());
        let refs: Vec<_> = responses.iter().chain(&pool_responses).collect();
        // Cases that state their own body mass (OpenFOAM) are regressed with it.
        let mut cfd = Regression::build(vehicle, &[], self.common.skip_start_s);
        let mut masses = Vec::new();
        for (c, r) in cases.iter().zip(&responses) {
            let mut v = vehicle.clone();
            if let Some(m) = c.mass_kg {
                v.mass_kg = m;
            }
            masses.push(v.mass_kg);
            cfd.append(Regression::build(&v, &[r], self.common.skip_start_s));
        }
        let pool_refs: Vec<_> = pool_responses.iter().collect();
        let pool = Regression::build(vehicle, &pool_refs, self.common.skip_start_s);
        if !pool_refs.is_empty() {
            masses.push(vehicle.mass_kg);
        }
        let problem = combine(cfd, pool, &mut notes);
        let one_mass = masses.windows(2).all(|w| w[0] == w[1]);
        anyhow::ensure!(
            one_mass || self.common.objective == Objective::EquationError,
            "the output error simulates one body: these cases state different body masses ({masses:?} kg); use objective: equation_error"
        );
        let mut sim_vehicle = vehicle.clone();
        if let Some(m) = masses.first() {
            sim_vehicle.mass_kg = *m;
        }
        let estimator = self.method.estimator;
        ctx.progress.set_message(format!(
            "{} on {} samples",
            self.method.name(),
            problem.rows()
        ));
        let bar = ctx.progress;
        let report = move |f: f64| bar.set_message(format!("{:.0} %", 100.0 * f));
        let opts = self.options(
            sim_vehicle.rigid_mass(),
            Some(&report),
            Some((&sim_vehicle, &refs[..])),
        );
        let (mut fit, one_step) = match self.common.added_mass_window_s {
            None => (estimator.fit(&problem, &opts)?, None),
            Some(window) => {
                anyhow::ensure!(
                    self.method.name() == "ols"
                        && self.common.objective == Objective::EquationError,
                    "added_mass_window_s is a two-step least-squares fit: use method: ols, objective: equation_error"
                );
                anyhow::ensure!(window > 0.0, "added_mass_window_s must be positive");
                anyhow::ensure!(
                    pool_refs.is_empty(),
                    "added_mass_window_s is for CFD runs from rest; remove the pool stage from this fit's `from`"
                );
                let mut early = Regression::build(vehicle, &[], self.common.skip_start_s);
                for (c, r) in cases.iter().zip(&responses) {
                    let mut v = vehicle.clone();
                    if let Some(m) = c.mass_kg {
                        v.mass_kg = m;
                    }
                    early.append(Regression::build(
                        &v,
                        &[&truncate(r, self.common.skip_start_s + window)],
                        self.common.skip_start_s,
                    ));
                }
                let one = estimator.fit(&problem, &opts).ok().map(|f| f.parameters);
                (two_step(&early, &problem)?, one)
            }
        };
        estimate::check_signs(&problem.layout, &mut fit.parameters);
        let result = FitResult {
            stage: ctx.stage.to_string(),
            method: self.method.name().to_string(),
            objective: self.common.objective,
            settings: self.settings(),
            structure: vehicle.structure,
            dofs: vehicle.dofs.clone(),
            constant_force: problem.layout.constant.clone(),
            fit,
            cases,
            runs,
            notes,
            elapsed_s: start.elapsed().as_secs_f64(),
            vehicle: self.common.vehicle.clone(),
            expected: self.common.expected.clone(),
            one_step,
        };
        super::write_json(&ctx.out.join(RESULT), &result)
    }
}

/// The `role: train` pool runs among the upstream, as response tables (logged command, fused
/// velocity and its derivative). Runs without every DOF of the vehicle are left out and said.
fn training_runs(
    ctx: &RunCtx,
    vehicle: &crate::model::Vehicle,
) -> anyhow::Result<(Vec<RunRef>, Vec<crate::io::Response>, Vec<String>)> {
    let (mut refs, mut responses, mut notes) = (Vec::new(), Vec::new(), Vec::new());
    for up in ctx.upstream_of(Artifact::PoolRuns) {
        let run = crate::fusion::run::load_for(&up.dir, vehicle)?;
        if run.meta.role != crate::io::pool::Role::Train {
            continue;
        }
        match run.as_response(vehicle) {
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

/// One problem from CFD rows and pool rows. When both are there each source's rows are divided
/// by that source's own residual level per DOF (from a least-squares fit on it alone), so the
/// noisier source cannot swamp the other: then a residual of 1 means "as good as that source's
/// own fit" in either.
fn combine(mut cfd: Regression, mut pool: Regression, notes: &mut Vec<String>) -> Regression {
    if cfd.rows() == 0 {
        return pool;
    }
    if pool.rows() == 0 {
        return cfd;
    }
    for (name, reg) in [("CFD", &mut cfd), ("pool", &mut pool)] {
        let sigma = source_sigma(reg);
        let levels: Vec<String> = sigma.iter().map(|(d, s)| format!("{d} {s:.3}")).collect();
        notes.push(format!(
            "{name} rows weighted by their own residual level ({})",
            levels.join(", ")
        ));
        reg.scale_rows(&sigma);
    }
    cfd.append(pool);
    cfd
}

/// Residual standard deviation per DOF of an unweighted least-squares fit on `reg` alone;
/// the RMS of its targets where that fit is not possible.
fn source_sigma(reg: &Regression) -> BTreeMap<Dof, f64> {
    let ones: BTreeMap<Dof, f64> = reg.row_dof.iter().map(|d| (*d, 1.0)).collect();
    match estimate::ols::solve(reg, &ones) {
        Ok(theta) => estimate::ols::residual_sigma(reg, &theta),
        Err(_) => {
            let mut acc: BTreeMap<Dof, (f64, usize)> = BTreeMap::new();
            for (y, d) in reg.y.iter().zip(&reg.row_dof) {
                let e = acc.entry(*d).or_default();
                e.0 += y * y;
                e.1 += 1;
            }
            acc.into_iter()
                .map(|(d, (s, n))| (d, (s / n as f64).sqrt().max(1e-9)))
                .collect()
        }
    }
}

/// The samples of a response up to `t_end`.
fn truncate(r: &crate::io::Response, t_end: f64) -> crate::io::Response {
    let n = r.t.iter().take_while(|t| **t <= t_end).count();
    let mut out = r.clone();
    out.t.truncate(n);
    for s in out.dofs.values_mut() {
        s.force.truncate(n);
        s.velocity.truncate(n);
        s.accel.truncate(n);
    }
    out
}

/// Least squares over the columns `cols` of `reg`, with the other parameters held at `held`:
/// values, standard errors and the condition number of that sub-problem.
fn subset_lstsq(
    reg: &Regression,
    cols: &[usize],
    held: &[f64],
) -> anyhow::Result<(Vec<f64>, Vec<f64>, f64)> {
    use nalgebra::{DMatrix, DVector};
    let (n, c) = (reg.rows(), cols.len());
    anyhow::ensure!(
        n > c,
        "{n} equation rows cannot determine {c} parameters: lengthen the window"
    );
    let a = DMatrix::from_fn(n, c, |i, j| reg.row(i)[cols[j]]);
    let b = DVector::from_fn(n, |i, _| {
        reg.y[i]
            - (0..reg.cols())
                .filter(|j| !cols.contains(j))
                .map(|j| reg.row(i)[j] * held[j])
                .sum::<f64>()
    });
    let svd = a.clone().svd(true, true);
    let (smax, smin) = (svd.singular_values.max(), svd.singular_values.min());
    let x = svd
        .solve(&b, 1e-12 * smax)
        .map_err(|e| anyhow::anyhow!("least squares: {e}"))?;
    let res = &b - &a * &x;
    let s2 = res.norm_squared() / (n - c) as f64;
    let cov = (a.transpose() * &a)
        .try_inverse()
        .unwrap_or_else(|| DMatrix::from_element(c, c, f64::INFINITY));
    Ok((
        x.iter().copied().collect(),
        (0..c).map(|j| (s2 * cov[(j, j)]).sqrt()).collect(),
        smax / smin.max(f64::MIN_POSITIVE),
    ))
}

/// Added mass from the acceleration window (drag neglected there), then the drag from every
/// sample with that added mass held.
fn two_step(early: &Regression, all: &Regression) -> anyhow::Result<Fit> {
    use crate::model::params::Group;
    let layout = &all.layout;
    let p = layout.len();
    let added: Vec<usize> = (0..p)
        .filter(|&j| layout.slot(j).0 == Group::AddedMass)
        .collect();
    let drag: Vec<usize> = (0..p)
        .filter(|&j| layout.slot(j).0 != Group::AddedMass)
        .collect();
    // Step 1: drag held at zero over the window.
    let (am, am_se, k1) = subset_lstsq(early, &added, &vec![0.0; p])?;
    let mut theta = vec![0.0; p];
    let mut se = vec![0.0; p];
    for (k, &j) in added.iter().enumerate() {
        theta[j] = am[k];
        se[j] = am_se[k];
    }
    let (dr, dr_se, k2) = subset_lstsq(all, &drag, &theta)?;
    for (k, &j) in drag.iter().enumerate() {
        theta[j] = dr[k];
        se[j] = dr_se[k];
    }
    let mut sigma: BTreeMap<String, (f64, usize)> = BTreeMap::new();
    for i in 0..all.rows() {
        let r = all.y[i]
            - all
                .row(i)
                .iter()
                .zip(&theta)
                .map(|(a, t)| a * t)
                .sum::<f64>();
        let e = sigma.entry(all.row_dof[i].name().to_string()).or_default();
        e.0 += r * r;
        e.1 += 1;
    }
    let condition_number = k1.max(k2);
    Ok(Fit {
        parameters: (0..p)
            .map(|j| estimate::Estimate {
                name: layout.name(j),
                value: theta[j],
                unit: layout.unit(j).to_string(),
                stderr: se[j],
                interval: None,
                identifiable: se[j].is_finite()
                    && se[j] < 0.5 * theta[j].abs()
                    && condition_number < 1e8,
                note: None,
            })
            .collect(),
        residual_sigma: sigma
            .into_iter()
            .map(|(d, (ss, n))| (d, (ss / n.max(1) as f64).sqrt()))
            .collect(),
        samples: all.rows(),
        condition_number,
        evaluations: None,
        objective_value: None,
        stopped_early: None,
        trace: None,
    })
}
