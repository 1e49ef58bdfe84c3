//! `kind: openfoam` — one instance per OpenFOAM case folder: runs the case (blockMesh, then
//! its solver) when its inputs have no results yet, or reuses the results a run of exactly
//! these inputs left in the folder, and turns the body's motion into a response table.

use super::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use crate::io::response::{META, TABLE};
use crate::openfoam::slurm::SlurmOptions;
use crate::openfoam::{self, case_run::CaseRun};
use serde::{Deserialize, Serialize};

pub static KIND: Kind = Kind {
    fan_out: true,
    input_filter: Some(openfoam::is_case_input),
    uses_vehicle: super::VehicleUse::Dofs,
    ..Kind::new("openfoam", Artifact::Responses, parse_as::<Settings>)
};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {
    /// Write the results of a run back into the case folder (log, postProcessing, the run
    /// stamp), as running the case by hand would, so the project builds without OpenFOAM.
    pub keep_results_in_case: bool,
    /// Where a case that has to run runs: `local` (the default) or `slurm` (a batch job per
    /// case, with the `slurm` settings). Not part of the cache key: a case's results are the
    /// same wherever it ran.
    pub executor: ExecutorKind,
    /// What `sbatch` is asked for: `partition`, `time`, `cpus`, `mem`, and `sbatch` (further
    /// options, one argument each).
    pub slurm: SlurmOptions,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ExecutorKind {
    #[default]
    Local,
    Slurm,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            keep_results_in_case: true,
            executor: ExecutorKind::Local,
            slurm: SlurmOptions::default(),
        }
    }
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        // The key's settings: what changes the results, not where they are computed.
        serde_json::json!({"keep_results_in_case": self.keep_results_in_case})
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let bar = ctx.progress;
        let message = move |m: String| bar.set_message(m);
        let slurm = (self.executor == ExecutorKind::Slurm).then_some(&self.slurm);
        let case = CaseRun::obtain(ctx.root, ctx.inputs, &message, slurm)?;
        case.keep_results(ctx.out, self.keep_results_in_case)?;
        // The results left in the case folder are read, not keyed (a run writes them): an
        // edit to one after this reruns the stage, as an edit to an input does.
        let watched: Vec<String> = openfoam::result_files(&case.setup.application)
            .into_iter()
            .chain([openfoam::STAMP.to_string()])
            .map(|rel| format!("{}/{rel}", case.rel))
            .collect();
        crate::pipeline::cache::write_watched(ctx.out, ctx.root, &watched)?;
        let (response, meta) = crate::io::openfoam::import(&case, &ctx.vehicle.dofs)?;
        response.write_parquet(&ctx.out.join(TABLE))?;
        super::write_json(&ctx.out.join(openfoam::TRACK), &case.track)?;
        super::write_json(&ctx.out.join(META), &meta)
    }
}
