//! `kind: report` — validates every model on every CFD response it reads and writes the report.

use super::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use crate::dof::Dof;
use crate::io::Response;
use crate::io::response;
use crate::model::{Plant, Vec6};
use crate::plot as plots;
use crate::report::html;
use crate::report::json::{self, DofMetrics, ModelScore, RunScore, Validation};
use crate::validate;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub static KIND: Kind = Kind {
    reads_files: true,
    consumes: &[
        Artifact::Model,
        Artifact::Responses,
        Artifact::PoolRuns,
        Artifact::Validation,
        Artifact::Comparison,
        Artifact::Diagnosis,
    ],
    requires: &[Artifact::Model],
    publishes_to: Some("reports"),
    ..Kind::new("report", Artifact::Report, parse_as::<Settings>)
};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {}

pub const FILES: [&str; 5] = [
    "index.html",
    "parameters.json",
    "validation.json",
    "fusion.json",
    "diagnosis.json",
];

struct Case {
    id: String,
    name: String,
    response: Response,
    notes: Vec<String>,
    /// The body mass the case states (OpenFOAM), which replaces the vehicle's.
    mass: Option<f64>,
    openfoam: Option<crate::openfoam::RunInfo>,
    track: Option<crate::openfoam::Track>,
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let fits: Vec<crate::estimate::result::FitResult> = ctx
            .upstream_of(Artifact::Model)
            .map(|u| crate::estimate::result::load(&u.dir))
            .collect::<Result<_, _>>()?;
        let mut cases = Vec::new();
        for u in ctx.upstream_of(Artifact::Responses) {
            let (meta, response) = response::load(&u.dir)?;
            let track = crate::openfoam::load_track(&u.dir);
            cases.push(Case {
                id: u.id.clone(),
                name: meta.case,
                response,
                notes: meta.notes,
                mass: meta.body_mass_kg,
                openfoam: meta.openfoam,
                track,
            });
        }
        let pool_runs: Vec<crate::fusion::run::FusedRun> = ctx
            .upstream_of(Artifact::PoolRuns)
            .map(|u| crate::fusion::run::load_for(&u.dir, ctx.vehicle))
            .collect::<Result<_, _>>()?;
        let pool_scores = ctx
            .upstream_of(Artifact::Validation)
            .next()
            .map(|u| crate::validate::pool::load(&u.dir))
            .transpose()?;
        let mut models = Vec::new();
        let mut first_sims: Vec<Option<Vec<Vec6>>> = vec![None; cases.len()];
        let mut body_html = String::new();
        for f in &fits {
            let hydro = f.hydro();
            let vehicle = f.vehicle.as_ref().unwrap_or(ctx.vehicle);
            let mut runs = Vec::new();
            let mut own_cases = Vec::new();
            for (ci, c) in cases.iter().enumerate() {
                let trained = f.cases.iter().any(|x| x.id == c.id);
                // A model of another body (the OpenFOAM cylinder) is scored on its own cases only,
                // and the vehicle's models are not scored on cases of other bodies.
                if (f.vehicle.is_some() && !trained) || (f.vehicle.is_none() && c.mass.is_some()) {
                    continue;
                }
                let mut v = vehicle.clone();
                if let Some(m) = c.mass {
                    v.mass_kg = m;
                }
                let plant = Plant::new(&v, hydro);
                let sim = c.response.simulate(&plant);
                let role = if trained { "train" } else { "validate" };
                let scores = validate::score(&c.response, &sim);
                if f.vehicle.is_some() {
                    own_cases.push((
                        ci,
                        scores.first().map_or(f64::NAN, |(_, m)| m.nmae),
                        sim.iter().map(|nu| nu[0]).collect::<Vec<f64>>(),
                    ));
                }
                let dofs = scores
                    .into_iter()
                    .map(|(d, metrics)| {
                        (
                            d.name().to_string(),
                            DofMetrics {
                                metrics,
                                residual_acf_outside_band: None,
                            },
                        )
                    })
                    .collect();
                runs.push(RunScore {
                    run: c.name.clone(),
                    role: role.into(),
                    dofs,
                });
                if first_sims[ci].is_none() && f.vehicle.is_none() {
                    first_sims[ci] = Some(sim);
                }
            }
            let of_cases: Vec<crate::report::openfoam::Case> = own_cases
                .into_iter()
                .filter_map(|(ci, nmae, simulated)| {
                    let c = &cases[ci];
                    let s = c.response.dofs.get(&Dof::Surge)?;
                    Some(crate::report::openfoam::Case {
                        name: &c.name,
                        info: c.openfoam.as_ref()?,
                        t: &c.response.t,
                        velocity: &s.velocity,
                        accel: &s.accel,
                        simulated,
                        nmae,
                        track: c.track.as_ref(),
                    })
                })
                .collect();
            if !of_cases.is_empty() {
                body_html += &crate::report::openfoam::section(f, &of_cases)?;
            }
            if let Some(ms) = pool_scores
                .as_ref()
                .and_then(|(s, _)| s.models.iter().find(|m| m.model == f.stage))
            {
                for r in &ms.runs {
                    let dofs = r
                        .dofs
                        .iter()
                        .map(|(d, s)| {
                            (
                                d.name().to_string(),
                                DofMetrics {
                                    metrics: s.metrics,
                                    residual_acf_outside_band: Some(s.whiteness.outside),
                                },
                            )
                        })
                        .collect();
                    runs.push(RunScore {
                        run: r.run.clone(),
                        role: r.role.clone(),
                        dofs,
                    });
                }
            }
            models.push(ModelScore {
                model: f.stage.clone(),
                runs,
            });
        }
        let truth_files: Vec<String> = ctx.inputs.iter().map(|i| i.path.clone()).collect();
        let accuracy = crate::report::pool::fusion_accuracy(ctx.root, &truth_files, &pool_runs)?;
        let comparison = ctx
            .upstream_of(Artifact::Comparison)
            .next()
            .map(|u| crate::estimate::comparison::load(&u.dir))
            .transpose()?;
        let compare_html = comparison
            .as_ref()
            .map_or(String::new(), crate::report::compare::section);
        let diagnosis = ctx
            .upstream_of(Artifact::Diagnosis)
            .next()
            .map(|u| crate::diagnose::result::load(&u.dir))
            .transpose()?;
        let diagnosis_html = diagnosis.as_ref().map_or(String::new(), |(d, figs)| {
            crate::report::diagnose::section(d, figs)
        });
        let pool_html = compare_html
            + &diagnosis_html
            + &crate::report::pool::section(
                &pool_runs,
                pool_scores.as_ref().map(|(s, _)| s),
                pool_scores.as_ref().map_or(&[][..], |(_, v)| v),
                &accuracy,
            )?;
        let plotted: Vec<(&Case, &Vec<Vec6>)> = cases
            .iter()
            .zip(&first_sims)
            .filter_map(|(c, s)| Some((c, s.as_ref()?)))
            .collect();
        let svgs = velocity_plots(&plotted)?;
        let parameters = json::parameters(&fits);
        let validation = Validation { models };
        let page = html::Page {
            vehicle: ctx.vehicle,
            fits: &fits,
            parameters: &parameters,
            validation: &validation,
            plots: svgs,
            notes: cases
                .iter()
                .map(|c| (c.name.clone(), c.notes.clone()))
                .chain(
                    pool_runs
                        .iter()
                        .map(|r| (r.meta.run.clone(), r.meta.notes.clone())),
                )
                .collect(),
            pool_html,
            body_html,
            failed: ctx.failed_notes(),
        };
        crate::fsutil::write_atomic(&ctx.out.join("index.html"), page.render().as_bytes())?;
        super::write_json(&ctx.out.join("parameters.json"), &parameters)?;
        super::write_json(&ctx.out.join("validation.json"), &validation)?;
        let fusion: Vec<serde_json::Value> = pool_runs
            .iter()
            .map(|r| serde_json::json!({"run": r.meta.run, "role": r.meta.role, "sensors": r.meta.sensors, "stats": r.meta.stats, "accuracy_against_truth": accuracy.iter().find(|a| a.run == r.meta.run)}))
            .collect();
        super::write_json(
            &ctx.out.join("fusion.json"),
            &serde_json::json!({ "runs": fusion }),
        )?;
        if let Some((d, _)) = &diagnosis {
            super::write_json(&ctx.out.join("diagnosis.json"), d)?;
        }
        Ok(())
    }
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
            let traces: Vec<plots::Trace> = list
                .iter()
                .map(|(c, s)| plots::Trace {
                    label: &c.name,
                    t: &c.response.t,
                    measured: &c.response.dofs[&d].velocity,
                    simulated: s,
                })
                .collect();
            Ok((d.name().to_string(), plots::velocity(d, &traces)?))
        })
        .collect()
}
