//! `kind: diagnose` — why the pool recordings and the CFD-identified model differ: drift or
//! missing structure, where the mismatch is, which left-out effect explains it (fitted by output
//! error on the training runs, chosen and proven on the held-out runs). See [`crate::diagnose`].

use crate::diagnose::result::{FIGURES, RESULT};
use crate::diagnose::{Criteria, Slots, diagnose};
use crate::identify::result::FitResult;
use crate::pipeline::contract::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use serde::{Deserialize, Serialize};

pub static KIND: Kind = Kind {
    consumes: &[Artifact::Model, Artifact::PoolRuns],
    requires: &[Artifact::Model, Artifact::PoolRuns],
    ..Kind::new("diagnose", Artifact::Diagnosis, parse_as::<Settings>)
};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {
    /// The fit stage whose model is diagnosed; default: the first fit of the pipeline's vehicle.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    #[serde(flatten)]
    pub criteria: Criteria,
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let fits: Vec<FitResult> = ctx
            .upstream_of(Artifact::Model)
            .map(|u| crate::identify::result::load(&u.dir))
            .collect::<Result<_, _>>()?;
        let fused: Vec<crate::pool::fusion::run::FusedRun> = ctx
            .upstream_of(Artifact::PoolRuns)
            .map(|u| crate::pool::fusion::run::load_for(&u.dir, ctx.vehicle))
            .collect::<Result<_, _>>()?;
        let (f, started_from) = self.pick(&fits, &fused, ctx)?;
        let plant = f.plant(ctx.vehicle);
        if Slots::of(&plant).is_none() {
            let dofs: Vec<String> = f.dofs.iter().map(|d| d.to_string()).collect();
            let reason = format!(
                "Not diagnosed: the diagnosis compares a model in surge, sway, heave and yaw, or in heave, roll, pitch and yaw, and model `{}` moves in none of them ({}). The fit and its validation above stand without it.",
                f.stage,
                dofs.join(", ")
            );
            ctx.progress.println(format!("{}: {reason}", ctx.id));
            return crate::core::fsutil::write_json(
                &ctx.out.join(crate::diagnose::result::NOT_RUN),
                &serde_json::json!({ "reason": reason }),
            );
        }
        // The model's command lag is part of it: the runs are diagnosed under the command as
        // the model passes it on.
        let fused: Vec<_> = fused
            .into_iter()
            .map(|r| r.with_command_of(&plant))
            .collect();
        let progress = |m: &str| ctx.progress.set_message(m.to_string());
        let (mut diagnosis, figures) = diagnose(
            ctx.vehicle,
            &f.stage,
            &plant,
            &fused,
            &self.criteria,
            &progress,
        )?;
        diagnosis.runs.skipped.extend(ctx.failed_notes());
        diagnosis.started_from = started_from;
        the_logs_own_lag(&mut diagnosis, &fused);
        crate::core::fsutil::write_json(&ctx.out.join(RESULT), &diagnosis)?;
        crate::core::fsutil::write_json(&ctx.out.join(FIGURES), &figures)
    }
}

/// A lag named where the runs measured their navigation log's latency against the depth gauge,
/// and the diagnosis did not take it out (the model's command lag holds it), says so beside
/// its evidence: the two look alike, and the log's part is not the thrusters'.
fn the_logs_own_lag(
    d: &mut crate::diagnose::result::Diagnosis,
    fused: &[crate::pool::fusion::run::FusedRun],
) {
    if d.runs.latency_taken_out_s.is_some() {
        return;
    }
    let Some(s) =
        crate::pool::fusion::latency::Summary::of_runs(fused).filter(|s| s.median_s > 0.0)
    else {
        return;
    };
    for e in &mut d.effects {
        if e.name == "thruster_lag" || e.name == "sensor_delay" {
            e.evidence
                .push_str(&format!(" Of this lag, {}.", s.sentence()));
        }
    }
}

impl Settings {
    /// The fit to diagnose: the one named, else the only fit of the vehicle among `from`, else
    /// as [`crate::diagnose::start::choose`] chooses (each one's score returned).
    fn pick<'a>(
        &self,
        fits: &'a [FitResult],
        fused: &[crate::pool::fusion::run::FusedRun],
        ctx: &RunCtx,
    ) -> anyhow::Result<(&'a FitResult, Vec<crate::diagnose::start::Start>)> {
        let own: Vec<&FitResult> = fits.iter().filter(|f| f.vehicle.is_none()).collect();
        let mut started_from = Vec::new();
        let f = match &self.model {
            Some(name) => fits.iter().find(|f| &f.stage == name).ok_or_else(|| anyhow::anyhow!("model `{name}` is not among this stage's `from` fits ({})", fits.iter().map(|f| f.stage.as_str()).collect::<Vec<_>>().join(", ")))?,
            None if own.len() > 1 => {
                // Several fits of the vehicle: start from a CFD one (else the one that
                // predicts the held-out runs best), and say how each did.
                started_from = own
                    .iter()
                    .map(|f| (f, f.plant(ctx.vehicle)))
                    .filter(|(_, plant)| Slots::of(plant).is_some())
                    .map(|(f, plant)| crate::diagnose::start::held_out(f, &plant, fused, &self.criteria))
                    .collect();
                let i = crate::diagnose::start::choose(&mut started_from);
                match started_from.get(i) {
                    Some(s) => own.iter().copied().find(|f| f.stage == s.model).expect("scored from these"),
                    None => own[0],
                }
            }
            None => own.first().copied().ok_or_else(|| anyhow::anyhow!("no fit of the pipeline's vehicle among `from`\n  help: name a `fit` stage that identifies the vehicle"))?,
        };
        Ok((f, started_from))
    }
}
