//! Field-trial identifiers of the source papers that need no acceleration signal and work on
//! what a free-running vehicle logs (seed 000, seed 002, seed 004): ARX transfer functions
//! with order selection ([`arx`]), least squares on an integrated regressor and recursive
//! least squares with forgetting ([`integrated`]), over the named signals of a fused pool run
//! ([`signals`]).

pub mod adaptive;
pub mod arx;
pub mod integrated;
pub mod report;
pub mod signals;
pub mod truth;

use crate::core::provenance::InputFile;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One identified value of a field-trial identifier, as `parameters.json` lists it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Parameter {
    pub name: String,
    pub value: f64,
    pub unit: String,
    pub stderr: f64,
    /// The model within the stage it belongs to (an ARX structure), when there are several.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
}

/// What a field-trial stage stores: the common part every report and audit reads, and the
/// identifier's own results in `detail` (see each kind).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FieldResult {
    pub stage: String,
    /// `arx`, `integrated` or `adaptive`.
    pub kind: String,
    pub method: String,
    pub settings: serde_json::Value,
    /// Every input file of the runs used, with its blake3.
    pub inputs: Vec<InputFile>,
    pub estimation_runs: Vec<String>,
    pub validation_runs: Vec<String>,
    pub parameters: Vec<Parameter>,
    pub detail: serde_json::Value,
    pub notes: Vec<String>,
}

pub const RESULT: &str = "field.json";

pub fn load(dir: &Path) -> anyhow::Result<FieldResult> {
    crate::core::fsutil::read_json(&dir.join(RESULT))
}

/// The runs of `runs` for estimation (`role: train`) and validation (`role: validate`), and
/// the union of their input files; an error when no run is for estimation.
pub fn split_runs(
    runs: &[crate::pool::fusion::run::FusedRun],
) -> anyhow::Result<(
    Vec<&crate::pool::fusion::run::FusedRun>,
    Vec<&crate::pool::fusion::run::FusedRun>,
    Vec<InputFile>,
)> {
    use crate::pool::import::Role;
    let est: Vec<_> = runs.iter().filter(|r| r.meta.role == Role::Train).collect();
    let val: Vec<_> = runs
        .iter()
        .filter(|r| r.meta.role == Role::Validate)
        .collect();
    anyhow::ensure!(
        !est.is_empty(),
        "no pool run has `role: train`: the identifier needs at least one run to estimate from (and preferably one `role: validate` run to check it on)"
    );
    let mut inputs: Vec<InputFile> = runs.iter().flat_map(|r| r.meta.sources.clone()).collect();
    inputs.sort_by(|a, b| a.path.cmp(&b.path));
    inputs.dedup();
    Ok((est, val, inputs))
}
