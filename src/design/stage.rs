//! `kind: design` — the next run to fly, proposed at every build: the same design as
//! `hydrofit design` (settings as its options: `duration_s`, `margin_m`, `pool`, `start`,
//! `for`, `candidates`, `seed`, `model`), from the fit among `from`, the pool runs it was
//! fitted to (`from` lists their pool stage) and a diagnosis when one is among `from`. Its
//! files are published to `reports/design/`.

use super::propose::{Ask, Diagnosed, propose};
use crate::identify::result::FitResult;
use crate::pipeline::contract::{Artifact, Kind, RunCtx, StageImpl, parse_as};

pub static KIND: Kind = Kind {
    consumes: &[Artifact::Model, Artifact::PoolRuns, Artifact::Diagnosis],
    requires: &[Artifact::Model, Artifact::PoolRuns],
    publishes_to: Some("reports/design"),
    ..Kind::new("design", Artifact::Design, parse_as::<Ask>)
};

impl StageImpl for Ask {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let f = the_fit(self, ctx)?;
        let vehicle = f.vehicle.clone().unwrap_or(ctx.vehicle.clone());
        let trained: std::collections::BTreeSet<&str> =
            f.runs.iter().map(|r| r.id.as_str()).collect();
        let runs: Vec<_> = ctx
            .upstream_of(Artifact::PoolRuns)
            .filter(|u| trained.contains(u.id.as_str()))
            .map(|u| crate::pool::fusion::run::load_for(&u.dir, &vehicle))
            .collect::<Result<_, _>>()?;
        let diagnosis: Option<crate::diagnose::Diagnosis> = ctx
            .upstream_of(Artifact::Diagnosis)
            .find_map(|u| crate::core::fsutil::read_json(&u.dir.join("diagnosis.json")).ok());
        // The diagnosed model, when it is another of `from`'s fits than the one designed for.
        let diagnosed = diagnosis.as_ref().map(|d| Diagnosed {
            diagnosis: d,
            plant: ctx
                .upstream_of(Artifact::Model)
                .filter_map(|u| crate::identify::result::load(&u.dir).ok())
                .find(|g| g.stage == d.baseline.model && g.stage != f.stage)
                .map(|g| g.plant(ctx.vehicle)),
        });
        let p = propose(
            &f,
            &runs,
            ctx.vehicle,
            diagnosed,
            self,
            &|line| ctx.progress.set_message(line),
            &|x| {
                ctx.progress
                    .set_message(format!("design search {:.0} %", 100.0 * x))
            },
        )?;
        p.write(ctx.out)?;
        for line in p.written.table() {
            ctx.progress.println(format!("{}: {line}", ctx.id));
        }
        Ok(())
    }
}

/// The fit named by `model`, else the only fit among `from` (else the fit of the pipeline's
/// vehicle).
fn the_fit(ask: &Ask, ctx: &RunCtx) -> anyhow::Result<FitResult> {
    let mut fits: Vec<FitResult> = ctx
        .upstream_of(Artifact::Model)
        .map(|u| crate::identify::result::load(&u.dir))
        .collect::<Result<_, _>>()?;
    let names = || {
        fits.iter()
            .map(|f| f.stage.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let i = match &ask.model {
        Some(name) => fits.iter().position(|f| &f.stage == name).ok_or_else(|| {
            ctx.setting_error(
                "model",
                format!("model `{name}` is not among this stage's `from` fits ({})", names()),
                "name one of them, or add the fit stage to `from`",
            )
        })?,
        None if fits.len() == 1 => 0,
        None => fits.iter().position(|f| f.vehicle.is_none()).ok_or_else(|| {
            anyhow::anyhow!(
                "{}: which model is the run designed for? `from` lists the fits {}\n  help: set `model` in the stage's settings",
                ctx.id,
                names()
            )
        })?,
    };
    Ok(fits.swap_remove(i))
}
