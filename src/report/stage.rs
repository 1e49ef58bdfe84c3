//! `kind: report` — assembles the report from the artifacts it reads: the models, the CFD
//! responses and pool runs, the validate stage's scores and simulations, the comparison, the
//! diagnosis and the field identifications. It computes no score and simulates nothing.

use crate::pipeline::contract::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use crate::report::build;
use serde::{Deserialize, Serialize};

pub static KIND: Kind = Kind {
    reads_files: true,
    consumes: &[
        Artifact::Model,
        Artifact::Responses,
        Artifact::PoolRuns,
        Artifact::Validation,
        Artifact::Comparison,
        Artifact::Diagnosis,
        Artifact::FieldModel,
    ],
    requires_one_of: &[Artifact::Model, Artifact::FieldModel],
    scored_by: Some(Artifact::Validation),
    publishes_to: Some("reports"),
    ..Kind::new("report", Artifact::Report, parse_as::<Settings>)
};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {}

pub const FILES: [&str; 6] = [
    "index.html",
    "parameters.json",
    "validation.json",
    "fusion.json",
    "diagnosis.json",
    "field.json",
];

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let fits: Vec<crate::identify::result::FitResult> = ctx
            .upstream_of(Artifact::Model)
            .map(|u| crate::identify::result::load(&u.dir))
            .collect::<Result<_, _>>()?;
        let cases = cfd_cases(ctx)?;
        let mut pool_runs: Vec<crate::pool::fusion::run::FusedRun> = ctx
            .upstream_of(Artifact::PoolRuns)
            .map(|u| {
                // A run steered by its actuators alone (no force log) is shown, not simulated.
                let r = crate::pool::fusion::run::load(&u.dir)?;
                Ok::<_, anyhow::Error>(if r.meta.force_logged {
                    r.clip_to(ctx.vehicle)
                } else {
                    r
                })
            })
            .collect::<Result<_, _>>()?;
        pool_runs.sort_by(|a, b| crate::core::natural::cmp(&a.meta.run, &b.meta.run));
        let field: Vec<crate::field::Field> = ctx
            .upstream_of(Artifact::FieldModel)
            .map(|u| crate::field::load_typed(&u.dir))
            .collect::<Result<_, _>>()?;
        let validation = ctx.upstream_of(Artifact::Validation).next();
        let pool_scores = validation
            .map(|u| crate::validate::pool::load(&u.dir))
            .transpose()?
            .flatten();
        let case_scores = validation
            .map(|u| crate::validate::cases::load(&u.dir))
            .transpose()?
            .unwrap_or_default();
        let truth = read_truth(ctx, &pool_runs)?;
        let diagnose = ctx.upstream_of(Artifact::Diagnosis).next();
        let not_diagnosed = diagnose.and_then(|u| crate::diagnose::result::not_run(&u.dir));
        let diagnosed = diagnose.filter(|_| not_diagnosed.is_none());
        let inputs = build::Inputs {
            vehicle: ctx.vehicle,
            fits,
            cases,
            pool_runs,
            field,
            pool_scores,
            case_scores,
            comparison: ctx
                .upstream_of(Artifact::Comparison)
                .next()
                .map(|u| crate::compare::artifact::load(&u.dir))
                .transpose()?,
            diagnosis: diagnosed
                .map(|u| crate::diagnose::result::load(&u.dir))
                .transpose()?,
            not_diagnosed,
            truth,
            failed: ctx.failed_notes(),
        };
        for (name, bytes) in build::build(&inputs)? {
            crate::core::fsutil::write_atomic(&ctx.out.join(name), &bytes)?;
        }
        Ok(())
    }
}

/// The twin's truth files among the stage's inputs, read: the fusion's accuracy against each
/// pool run's truth, the twin's coefficients and the field twin's hidden values.
fn read_truth(
    ctx: &RunCtx,
    pool_runs: &[crate::pool::fusion::run::FusedRun],
) -> anyhow::Result<build::Truth> {
    let files: Vec<String> = ctx.inputs.iter().map(|i| i.path.clone()).collect();
    let parameters = files
        .iter()
        .find(|p| p.rsplit('/').next() == Some(crate::validate::sets::TRUTH_PARAMETERS))
        .map(|p| crate::validate::sets::read_truth(&ctx.root.join(p)))
        .transpose()?;
    Ok(build::Truth {
        fusion: crate::pool::report::fusion_accuracy(ctx.root, &files, pool_runs)?,
        parameters,
        field: crate::field::truth::read_truth(ctx.root, &files),
    })
}

/// The CFD responses among the upstream, each with what the report shows of its case (and
/// an OpenFOAM case's track).
fn cfd_cases(ctx: &RunCtx) -> anyhow::Result<Vec<build::Case>> {
    let responses = crate::validate::cases::upstream_responses(ctx)?;
    Ok(responses
        .into_iter()
        .map(|(u, meta, response)| build::Case {
            id: u.id.clone(),
            name: meta.case,
            response,
            notes: meta.notes,
            openfoam: meta.openfoam,
            track: crate::cfd::openfoam::load_track(&u.dir),
            two_dimensional: meta.per_metre_of_span,
        })
        .collect())
}
