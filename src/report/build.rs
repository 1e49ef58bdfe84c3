//! The whole report from the artifacts of the stages it reads: the models' scores on the CFD
//! cases and pool runs (the validate stage's), the sections of the HTML page, and the
//! published JSON files.

use super::html;
use super::json::{self, DofMetrics, ModelScore, RunScore, Validation};
use crate::compare::artifact::Comparison;
use crate::core::dof::Dof;
use crate::core::fsutil::json_bytes;
use crate::core::model::{Vec6, Vehicle};
use crate::core::plot as plots;
use crate::core::response::Response;
use crate::diagnose::{Diagnosis, Figure};
use crate::identify::result::FitResult;
use crate::pool::fusion::run::FusedRun;
use crate::validate::Metrics;
use crate::validate::cases::CaseScore;
use crate::validate::pool::{Scores, Simulated};
use maud::Markup;
use std::collections::BTreeMap;

/// A CFD case as the report reads it.
pub struct Case {
    pub id: String,
    pub name: String,
    pub response: Response,
    pub notes: Vec<String>,
    pub openfoam: Option<crate::cfd::openfoam::RunInfo>,
    pub track: Option<crate::cfd::openfoam::Track>,
    /// A 2D case (forces and masses per metre of span).
    pub two_dimensional: bool,
}

/// What a twin's truth files among the report stage's inputs say, read and compared with the
/// runs by the stage ([`super::stage`]) so that the report only renders it.
#[derive(Default)]
pub struct Truth {
    /// The fusion's accuracy per pool run that has a truth file of its name.
    pub fusion: Vec<crate::pool::report::FusionAccuracy>,
    /// The twin's coefficients (`truth/parameters.csv`), for the parameter sets.
    pub parameters: Option<BTreeMap<String, f64>>,
    /// The field twin's hidden values, for the field identifiers.
    pub field: crate::field::truth::Truth,
}

/// Everything the report is made from.
pub struct Inputs<'a> {
    pub vehicle: &'a Vehicle,
    pub fits: Vec<FitResult>,
    pub cases: Vec<Case>,
    pub pool_runs: Vec<FusedRun>,
    /// Field-trial identifications (ARX, integrated LS / RLS, adaptive).
    pub field: Vec<crate::field::Field>,
    pub pool_scores: Option<(Scores, Vec<Simulated>)>,
    /// The validate stage's scores and simulations of the models on the CFD cases.
    pub case_scores: Vec<CaseScore>,
    pub comparison: Option<Comparison>,
    pub diagnosis: Option<(Diagnosis, Vec<Figure>)>,
    /// Why the diagnose stage diagnosed nothing, when it did not (the model's DOFs).
    pub not_diagnosed: Option<String>,
    /// What the twin's truth files among the stage's inputs say (empty without them).
    pub truth: Truth,
    /// Upstream instances that failed, one line each.
    pub failed: Vec<String>,
}

/// The published files (name, contents), `index.html` first.
pub fn build(inp: &Inputs) -> anyhow::Result<Vec<(&'static str, Vec<u8>)>> {
    let mut models = Vec::new();
    let mut first_sims: Vec<Option<Vec<Vec6>>> = vec![None; inp.cases.len()];
    let mut bodies = Vec::new();
    for f in &inp.fits {
        let (score, section) = score_model(inp, f, &mut first_sims)?;
        models.push(score);
        bodies.extend(section);
    }
    let accuracy = &inp.truth.fusion;
    let pool_html = pool_html(inp, accuracy)?;
    let plotted: Vec<(&Case, &Vec<Vec6>)> = inp
        .cases
        .iter()
        .zip(&first_sims)
        .filter_map(|(c, s)| Some((c, s.as_ref()?)))
        .collect();
    let svgs = velocity_plots(&plotted)?;
    let mut parameters = json::parameters(&inp.fits);
    parameters
        .parameters
        .extend(json::field_parameters(&inp.field));
    let baselines = inp.pool_scores.as_ref().map_or(vec![], |(s, _)| {
        s.baselines
            .iter()
            .map(|b| ModelScore {
                model: b.model.clone(),
                runs: run_scores(b),
                below_baselines: vec![],
                behind_identified: vec![],
                short_horizon: vec![],
            })
            .collect()
    });
    let validation = Validation { models, baselines };
    let page = html::Page {
        vehicle: inp.vehicle,
        fits: &inp.fits,
        parameters: &parameters,
        validation: &validation,
        plots: svgs,
        notes: import_notes(inp),
        pool_html,
        bodies,
        failed: inp.failed.clone(),
    };
    let mut files = vec![
        ("index.html", page.render().into_bytes()),
        ("parameters.json", json_bytes(&parameters)?),
        ("validation.json", json_bytes(&validation)?),
        ("fusion.json", json_bytes(&fusion_json(inp, accuracy))?),
    ];
    if let Some((d, _)) = &inp.diagnosis {
        files.push(("diagnosis.json", json_bytes(d)?));
    }
    if !inp.field.is_empty() {
        let results: Vec<&crate::field::FieldResult> =
            inp.field.iter().map(|f| &f.result).collect();
        let field = serde_json::json!({ "identifiers": results });
        files.push(("field.json", json_bytes(&field)?));
    }
    Ok(files)
}

/// The sections after the CFD ones: the parameter sets, the field identifiers, the comparison
/// of methods, the designed runs, the diagnosis and the pool runs.
fn pool_html(
    inp: &Inputs,
    accuracy: &[crate::pool::report::FusionAccuracy],
) -> anyhow::Result<Markup> {
    let truth = inp.truth.parameters.as_ref();
    let field_truth = &inp.truth.field;
    let scores = inp.pool_scores.as_ref();
    let diagnosis = inp.diagnosis.as_ref();
    Ok(maud::html! {
        @if let Some((s, _)) = scores { (crate::validate::sets::section(&inp.fits, s, truth)) }
        (crate::field::report::sections(&inp.field, field_truth)?)
        @if let Some(c) = &inp.comparison { (crate::compare::report::section(c)) }
        (crate::design::report::section(&inp.pool_runs, &inp.fits, diagnosis.map(|(d, _)| d)))
        @if let Some((d, figs)) = diagnosis { (crate::diagnose::report::section(d, figs)) }
        @if let Some(why) = &inp.not_diagnosed {
            h2 id="diagnosis" { "Why the pool runs and the model differ" }
            p.warn { (why) }
        }
        (crate::pool::report::thrusters_section(inp.vehicle.thrusters.as_ref())?)
        (crate::pool::report::section(&inp.pool_runs, accuracy))
        (crate::validate::report::section(
            &inp.pool_runs,
            scores.map(|(s, _)| s),
            scores.map_or(&[][..], |(_, v)| v),
        )?)
    })
}

/// The import notes of every CFD case, then of every pool run.
fn import_notes(inp: &Inputs) -> Vec<(String, Vec<String>)> {
    inp.cases
        .iter()
        .map(|c| (c.name.clone(), c.notes.clone()))
        .chain(
            inp.pool_runs
                .iter()
                .map(|r| (r.meta.run.clone(), r.meta.notes.clone())),
        )
        .collect()
}

/// `fusion.json`: how each pool run was fused and, where a truth exists, how accurately.
fn fusion_json(
    inp: &Inputs,
    accuracy: &[crate::pool::report::FusionAccuracy],
) -> serde_json::Value {
    let fusion: Vec<serde_json::Value> = inp
            .pool_runs
            .iter()
            .map(|r| serde_json::json!({"run": r.meta.run, "role": r.meta.role, "sensors": r.meta.sensors, "stats": r.meta.stats, "accuracy_against_truth": accuracy.iter().find(|a| a.run == r.meta.run)}))
            .collect();
    serde_json::json!({ "runs": fusion })
}

/// A case a model of a body other than the vehicle was scored on: its index in the inputs,
/// the model's NMAE in its first DOF, and the model's surge velocity.
struct OwnCase {
    index: usize,
    nmae: f64,
    sim: Vec<Vec6>,
}

/// Model `f`'s scores on the CFD cases and the pool runs (the validate stage's), with the
/// OpenFOAM section of its own body's cases; the first simulation of each case by a model of
/// the vehicle goes to `first_sims`, for the plots.
fn score_model(
    inp: &Inputs,
    f: &FitResult,
    first_sims: &mut [Option<Vec<Vec6>>],
) -> anyhow::Result<(ModelScore, Option<Markup>)> {
    let (mut runs, own_cases) = case_scores(inp, f, first_sims);
    let html = openfoam_section(inp, f, own_cases)?;
    runs.extend(pool_scores(inp, f));
    let below_baselines = pool_model(inp, &f.stage).map_or(vec![], |m| m.shortfalls.clone());
    let behind_identified =
        pool_model(inp, &f.stage).map_or(vec![], |m| m.behind_identified.clone());
    let short_horizon = pool_model(inp, &f.stage).map_or(vec![], |m| m.short_horizon.clone());
    Ok((
        ModelScore {
            model: f.stage.clone(),
            runs,
            below_baselines,
            behind_identified,
            short_horizon,
        },
        html,
    ))
}

/// The validate stage's scores of the model called `name` on the pool runs, if any.
fn pool_model<'a>(inp: &'a Inputs, name: &str) -> Option<&'a crate::validate::pool::ModelScore> {
    let (s, _) = inp.pool_scores.as_ref()?;
    s.models.iter().find(|m| m.model == name)
}

/// Model `f`'s scores on the CFD cases (the validate stage's), and those of its own body's
/// cases; the first simulation of each case by a model of the vehicle goes to `first_sims`.
fn case_scores(
    inp: &Inputs,
    f: &FitResult,
    first_sims: &mut [Option<Vec<Vec6>>],
) -> (Vec<RunScore>, Vec<OwnCase>) {
    let mut runs = Vec::new();
    let mut own_cases = Vec::new();
    for s in inp.case_scores.iter().filter(|s| s.model == f.stage) {
        let Some(ci) = inp.cases.iter().position(|c| c.id == s.case_id) else {
            continue;
        };
        let sim = s.simulated.clone();
        if f.vehicle.is_some() {
            own_cases.push(OwnCase {
                index: ci,
                nmae: s.scores.first().map_or(f64::NAN, |(_, m)| m.nmae),
                sim: sim.clone(),
            });
        }
        runs.push(case_score(&inp.cases[ci], &s.role, s.scores.clone()));
        if first_sims[ci].is_none() && f.vehicle.is_none() {
            first_sims[ci] = Some(sim);
        }
    }
    (runs, own_cases)
}

/// The score of CFD case `c` in `validation.json`: its role and its metrics per DOF.
fn case_score(c: &Case, role: &str, scores: Vec<(Dof, Metrics)>) -> RunScore {
    let dofs = scores
        .into_iter()
        .map(|(d, metrics)| {
            (
                d.name().to_string(),
                DofMetrics {
                    metrics,
                    residual_acf_outside_band: None,
                    nmae_ahead: BTreeMap::new(),
                },
            )
        })
        .collect();
    RunScore {
        run: c.name.clone(),
        role: role.into(),
        dofs,
    }
}

/// The OpenFOAM section of model `f` on its own body's cases (empty when it has none).
fn openfoam_section(
    inp: &Inputs,
    f: &FitResult,
    own_cases: Vec<OwnCase>,
) -> anyhow::Result<Option<Markup>> {
    let of_cases: Vec<crate::cfd::openfoam::report::Case> = own_cases
        .into_iter()
        .filter_map(|o| {
            let c = &inp.cases[o.index];
            let info = c.openfoam.as_ref()?;
            // The DOF the case pushes the body in (its largest force component).
            let axis = (0..3)
                .max_by(|&a, &b| {
                    info.applied_force_n[a]
                        .abs()
                        .total_cmp(&info.applied_force_n[b].abs())
                })
                .expect("three axes");
            let dof = [Dof::Surge, Dof::Sway, Dof::Heave][axis];
            let s = c.response.dofs.get(&dof)?;
            Some(crate::cfd::openfoam::report::Case {
                name: &c.name,
                dof,
                info,
                t: &c.response.t,
                velocity: &s.velocity,
                accel: &s.accel,
                simulated: o.sim.iter().map(|nu| nu[dof.index()]).collect(),
                nmae: o.nmae,
                track: c.track.as_ref(),
                two_dimensional: c.two_dimensional,
            })
        })
        .collect();
    if of_cases.is_empty() {
        Ok(None)
    } else {
        crate::cfd::openfoam::report::section(f, &of_cases).map(Some)
    }
}

/// Model `f`'s scores on the pool runs the validate stage scored it on, with residual whiteness.
fn pool_scores(inp: &Inputs, f: &FitResult) -> Vec<RunScore> {
    pool_model(inp, &f.stage).map_or(vec![], run_scores)
}

/// A pool model's scores per run and DOF as `validation.json` has them.
fn run_scores(ms: &crate::validate::pool::ModelScore) -> Vec<RunScore> {
    ms.runs
        .iter()
        .map(|r| {
            let dofs = r
                .dofs
                .iter()
                .map(|(d, s)| {
                    (
                        d.name().to_string(),
                        DofMetrics {
                            metrics: s.metrics,
                            residual_acf_outside_band: Some(s.whiteness.outside),
                            nmae_ahead: s.nmae_ahead.clone(),
                        },
                    )
                })
                .collect();
            RunScore {
                run: r.run.clone(),
                role: r.role.clone(),
                dofs,
            }
        })
        .collect()
}

/// One plot per DOF with every case that moves in it, against the first model's simulation.
fn velocity_plots(plotted: &[(&Case, &Vec<Vec6>)]) -> anyhow::Result<Vec<(String, String)>> {
    let mut by_dof: BTreeMap<Dof, Vec<(&Case, Vec<f64>)>> = BTreeMap::new();
    for (c, sim) in plotted {
        for d in c.response.dofs.keys() {
            by_dof
                .entry(*d)
                .or_default()
                .push((c, sim.iter().map(|nu| nu[d.index()]).collect()));
        }
    }
    by_dof
        .into_iter()
        .map(|(d, list)| {
            let mut traces: Vec<plots::Trace> = list
                .iter()
                .map(|(c, s)| plots::Trace {
                    label: &c.name,
                    t: &c.response.t,
                    measured: &c.response.dofs[&d].velocity,
                    simulated: s,
                })
                .collect();
            plots::sort_by_final_value(&mut traces);
            Ok((d.name().to_string(), plots::velocity(d, &traces)?))
        })
        .collect()
}
