//! The engine's contract with a stage kind: what a kind declares ([`Kind`]), what a running
//! stage may touch ([`RunCtx`]), and what a configured stage does ([`StageImpl`]). The kinds
//! themselves live in `crate::stage`; the engine knows them only through a [`Registry`].

use crate::core::model::Vehicle;
use crate::core::provenance::InputFile;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The stage kinds a project may use, looked up by name.
pub type Registry = &'static [&'static Kind];

/// The kind called `name` in `kinds`.
pub fn find(kinds: Registry, name: &str) -> Option<&'static Kind> {
    kinds.iter().copied().find(|k| k.name == name)
}

/// What a stage produces, so the spec can check that `from` connects compatible stages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Artifact {
    /// A CFD response table (force, velocity, acceleration per DOF).
    Responses,
    /// An identified vehicle model.
    Model,
    /// A field-trial identification (ARX, integrated-regressor LS / RLS, adaptive).
    FieldModel,
    /// A pool run fused into body-frame velocities.
    PoolRuns,
    /// Scores of models on pool runs and CFD cases.
    Validation,
    /// Estimators side by side.
    Comparison,
    /// Why the recordings and the model differ.
    Diagnosis,
    /// The published report.
    Report,
    /// A model written for a simulator or a toolbox.
    Exports,
    /// The next run to fly, designed for what the runs could not tell.
    Design,
}

impl Artifact {
    pub fn describe(self) -> &'static str {
        match self {
            Artifact::Responses => "CFD responses",
            Artifact::Model => "an identified model",
            Artifact::FieldModel => "a field-trial identification",
            Artifact::PoolRuns => "fused pool runs",
            Artifact::Validation => "validation scores",
            Artifact::Comparison => "an estimator comparison",
            Artifact::Diagnosis => "a missing-physics diagnosis",
            Artifact::Report => "a report",
            Artifact::Exports => "a model written for a simulator",
            Artifact::Design => "a designed run",
        }
    }

    pub fn example(self) -> &'static str {
        match self {
            Artifact::Responses => "a `starccm` stage",
            Artifact::Model => "a `fit` (or `model`) stage",
            Artifact::FieldModel => "an `arx`, `integrated` or `adaptive` stage",
            Artifact::PoolRuns => "a `pool` stage",
            Artifact::Validation => "a `validate` stage",
            Artifact::Comparison => "a `compare` stage",
            Artifact::Diagnosis => "a `diagnose` stage",
            Artifact::Report => "a `report` stage",
            Artifact::Exports => "an `export` stage",
            Artifact::Design => "a `design` stage",
        }
    }
}

/// How much of the vehicle a kind depends on: an importer needs only the DOF list, so a new
/// mass reruns the fit but not every import.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VehicleUse {
    Dofs,
    All,
}

/// A stage kind: its contract with the engine.
pub struct Kind {
    pub name: &'static str,
    /// Bump when the kind's algorithm or artifact format changes: part of every cache key.
    pub version: u32,
    /// One instance per input file or folder matched by the stage's globs.
    pub fan_out: bool,
    /// A single-instance kind that may also read files by glob (the report reads the twin's
    /// truth when there is one); a glob that matches nothing is then not an error.
    pub reads_files: bool,
    /// For a fan-out over folders: which files of a matched folder (path relative to it) are
    /// inputs; None takes them all. An OpenFOAM case folder also holds the results of its runs.
    pub input_filter: Option<fn(&str) -> bool>,
    /// A fan-out over files (one export each): a folder its globs match is an error, not a
    /// file to look inside.
    pub file_inputs: bool,
    pub produces: Artifact,
    /// What it may read from (`from`), and what it must read from.
    pub consumes: &'static [Artifact],
    pub requires: &'static [Artifact],
    /// At least one of these must be under `from` (a fit reads CFD responses, pool runs or both).
    pub requires_one_of: &'static [Artifact],
    /// The artifact of the stage that scores models on CFD responses, for a kind that shows
    /// them (the report shows the validate stage's scores): when a stage of this kind reads
    /// both models and CFD responses, such a stage must be under its `from` and read them all.
    pub scored_by: Option<Artifact>,
    /// Which part of the vehicle section is part of its key.
    pub uses_vehicle: VehicleUse,
    /// Folder of the project its results are copied to (the report), if any.
    pub publishes_to: Option<&'static str>,
    /// Parses the stage's `settings` (unknown keys rejected).
    pub parse: ParseSettings,
}

/// How a kind parses its `settings`.
pub type ParseSettings =
    fn(serde_yaml_ng::Value) -> Result<std::sync::Arc<dyn StageImpl>, serde_yaml_ng::Error>;

impl Kind {
    /// A single-instance kind producing `produces` that reads nothing (`from` empty), keyed on
    /// the whole vehicle; a kind states only where it differs:
    /// `Kind { fan_out: true, ..Kind::new("pool", Artifact::PoolRuns, parse_as::<Settings>) }`.
    pub const fn new(name: &'static str, produces: Artifact, parse: ParseSettings) -> Kind {
        Kind {
            name,
            version: 1,
            fan_out: false,
            reads_files: false,
            input_filter: None,
            file_inputs: false,
            produces,
            consumes: &[],
            requires: &[],
            requires_one_of: &[],
            scored_by: None,
            uses_vehicle: VehicleUse::All,
            publishes_to: None,
            parse,
        }
    }
}

/// Parses settings into `S`, unknown keys rejected by `S`'s `deny_unknown_fields`.
pub fn parse_as<S>(
    v: serde_yaml_ng::Value,
) -> Result<std::sync::Arc<dyn StageImpl>, serde_yaml_ng::Error>
where
    S: StageImpl + serde::de::DeserializeOwned + 'static,
{
    Ok(std::sync::Arc::new(serde_yaml_ng::from_value::<S>(v)?))
}

/// A finished upstream instance whose artifacts a stage reads.
#[derive(Debug, Clone)]
pub struct Upstream {
    pub id: String,
    pub stage: String,
    pub produces: Artifact,
    pub dir: PathBuf,
}

/// Everything a running stage may touch.
pub struct RunCtx<'a> {
    pub id: &'a str,
    pub stage: &'a str,
    pub root: &'a Path,
    pub vehicle: &'a Vehicle,
    pub inputs: &'a [InputFile],
    /// The instance's own parameters, for a stage that fans out over settings (a case
    /// series): the entries set in its case, in order. Empty otherwise.
    pub params: &'a [(String, String)],
    pub upstream: Vec<Upstream>,
    /// Upstream instances that failed and that this stage goes on without (pool runs that
    /// could not be imported or fused), with their errors: list them, use the rest.
    pub failed_upstream: Vec<(String, String)>,
    /// Fresh, empty folder for the artifacts; renamed into the cache only if `run` succeeds.
    pub out: &'a Path,
    pub progress: &'a indicatif::ProgressBar,
}

impl RunCtx<'_> {
    /// An error about this stage's setting `key` (the path below `settings`, dotted), at the
    /// setting's line in `pipeline.yaml` (or its stage's, when the setting is a default).
    pub fn setting_error(
        &self,
        key: &str,
        what: impl Into<String>,
        fix: impl Into<String>,
    ) -> anyhow::Error {
        let file = super::SPEC_FILE;
        let e = crate::core::diag::InputError::file(file, what, fix);
        let Ok(text) = std::fs::read_to_string(self.root.join(file)) else {
            return e.into();
        };
        let index = super::locate::KeyIndex::new(&text);
        match index.find(&format!("stages.{}.settings.{key}", self.stage)) {
            Some((l, c)) => e.at(l, Some(c)).with_source(&text).into(),
            None => e.into(),
        }
    }

    pub fn upstream_of(&self, a: Artifact) -> impl Iterator<Item = &Upstream> {
        self.upstream.iter().filter(move |u| u.produces == a)
    }

    /// One line per failed upstream this stage went on without: `pool[x] failed: <error>`.
    pub fn failed_notes(&self) -> Vec<String> {
        self.failed_upstream
            .iter()
            .map(|(id, e)| {
                format!(
                    "{id} failed and is left out: {}",
                    e.lines().next().unwrap_or("")
                )
            })
            .collect()
    }
}

/// A configured stage: the kind's settings, ready to run.
pub trait StageImpl: Send + Sync {
    /// The settings with defaults filled in, as hashed into the key and shown by `--explain`.
    fn settings(&self) -> serde_json::Value;
    /// Runs the stage, writing its artifacts into `ctx.out`.
    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()>;

    /// For a fan-out kind whose settings define its instances (a case series swept over
    /// parameters): one [`Variant`] per instance, all reading the files the stage's globs
    /// match. `None` fans out over the matched files as usual. An error says what is wrong
    /// with the settings.
    fn variants(&self) -> Result<Option<Vec<Variant>>, String> {
        Ok(None)
    }

    /// Called once per build with the stage's instances that are about to run, before any
    /// of them does: a kind that can hand them to a scheduler together (one Slurm array job)
    /// does so here. What it returns is said to the user and kept until the build ends.
    fn prepare(&self, _pending: &[Pending]) -> anyhow::Result<Option<Prepared>> {
        Ok(None)
    }
}

/// One instance of a stage defined by its settings: its name (`stage[name]`) and its
/// parameters, which are part of its key.
#[derive(Debug, Clone, PartialEq)]
pub struct Variant {
    pub name: String,
    pub params: Vec<(String, String)>,
}

/// What [`StageImpl::prepare`] did: a line for the user (`6 cases submitted as Slurm array
/// job 13`), and what must live until the build ends (dropped then: it may cancel or clean).
pub struct Prepared {
    pub message: String,
    pub keep: Box<dyn std::any::Any + Send + Sync>,
}

/// An instance about to run, as [`StageImpl::prepare`] sees it.
pub struct Pending<'a> {
    pub id: &'a str,
    pub stage: &'a str,
    pub root: &'a Path,
    pub inputs: Vec<InputFile>,
    pub params: &'a [(String, String)],
}
