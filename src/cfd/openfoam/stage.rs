//! `kind: openfoam` — one instance per OpenFOAM case folder: runs the case (blockMesh, then
//! its solver) when its inputs have no results yet, or reuses the results a run of exactly
//! these inputs left in the folder, and turns the body's motion into a response table.

use crate::cfd::openfoam::series::Series;
use crate::cfd::openfoam::{self, case_run::CaseRun};
use crate::cfd::slurm::SlurmOptions;
use crate::core::provenance::InputFile;
use crate::core::response::{META, TABLE};
use crate::pipeline::contract::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use crate::pipeline::contract::{Pending, Prepared, Variant};
use serde::{Deserialize, Serialize};

pub static KIND: Kind = Kind {
    fan_out: true,
    input_filter: Some(openfoam::is_case_input),
    uses_vehicle: crate::pipeline::contract::VehicleUse::Dofs,
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
    /// A case series: the stage's inputs are one template case, and each combination of the
    /// swept entries is a case of its own, written under `series.cases` (see [`Series`]).
    /// The sweep is not part of the key as a whole: each case is keyed on its own values.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub series: Option<Series>,
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
            series: None,
        }
    }
}

impl Settings {
    /// The input files of the case instance `id` runs: its case folder's, or for a series
    /// the case written from the template with the instance's parameters.
    fn case_inputs(
        &self,
        root: &std::path::Path,
        stage: &str,
        id: &str,
        inputs: &[InputFile],
        params: &[(String, String)],
    ) -> anyhow::Result<Vec<InputFile>> {
        let Some(series) = &self.series else {
            return Ok(inputs.to_vec());
        };
        let name = id
            .strip_prefix(stage)
            .and_then(|s| s.strip_prefix('['))
            .and_then(|s| s.strip_suffix(']'))
            .unwrap_or(id);
        let template = openfoam::series::template_folder(stage, inputs)?;
        let case = format!("{}/{name}", series.cases_dir(stage));
        anyhow::ensure!(
            !case.starts_with(&format!("{template}/")),
            "the series' cases ({}) cannot be written inside its template {template}",
            series.cases_dir(stage)
        );
        openfoam::series::write_case(root, inputs, &template, &case, params)
    }
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        // The key's settings: what changes the results, not where they are computed.
        serde_json::json!({"keep_results_in_case": self.keep_results_in_case})
    }

    fn variants(&self) -> Result<Option<Vec<Variant>>, String> {
        self.series.as_ref().map(Series::variants).transpose()
    }

    /// With `executor: slurm`, the cases that have to run go to Slurm as one array job.
    fn prepare(&self, pending: &[Pending]) -> anyhow::Result<Option<Prepared>> {
        if self.executor != ExecutorKind::Slurm || pending.len() < 2 {
            return Ok(None);
        }
        // A case that cannot be written is left out: its own instance fails and says why.
        let cases: Vec<Vec<InputFile>> = pending
            .iter()
            .filter_map(|p| {
                self.case_inputs(p.root, p.stage, p.id, &p.inputs, p.params)
                    .ok()
            })
            .collect();
        let root = pending[0].root;
        let array = openfoam::case_run::submit_series(root, &cases, &self.slurm, pending[0].stage)?;
        Ok(array.map(|a| Prepared {
            message: format!(
                "{} cases submitted to Slurm as array job {} (squeue -j {})",
                a.tasks(),
                a.ids().join(", "),
                a.ids().join(",")
            ),
            keep: Box::new(a),
        }))
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let bar = ctx.progress;
        let message = move |m: String| bar.set_message(m);
        let slurm = (self.executor == ExecutorKind::Slurm).then_some(&self.slurm);
        let inputs = self.case_inputs(ctx.root, ctx.stage, ctx.id, ctx.inputs, ctx.params)?;
        let case = CaseRun::obtain(ctx.root, &inputs, &message, slurm)?;
        case.keep_results(ctx.out, self.keep_results_in_case)?;
        // The results left in the case folder are read, not keyed (a run writes them): an
        // edit to one after this reruns the stage, as an edit to an input does. So does an
        // edit to a case of a series, which the series writes.
        let written = self.series.is_some().then_some(&inputs);
        let watched: Vec<String> = openfoam::result_files(&case.setup.application)
            .into_iter()
            .chain([openfoam::STAMP.to_string()])
            .map(|rel| format!("{}/{rel}", case.rel))
            .chain(written.into_iter().flatten().map(|i| i.path.clone()))
            .collect();
        crate::pipeline::cache::write_watched(ctx.out, ctx.root, &watched)?;
        let (response, meta) = crate::cfd::openfoam::table::import(&case, &ctx.vehicle.dofs)?;
        response.write_parquet(&ctx.out.join(TABLE))?;
        crate::core::fsutil::write_json(&ctx.out.join(openfoam::TRACK), &case.track)?;
        crate::core::fsutil::write_json(&ctx.out.join(META), &meta)
    }
}
