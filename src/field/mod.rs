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
use serde::de::DeserializeOwned;
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

/// An identifier's own results and the settings it ran with, typed by its kind: what a
/// result's `detail` and `settings` hold.
#[derive(Debug, Clone)]
pub enum Detail {
    Arx(Box<arx::Detail>, Box<arx::stage::Settings>),
    Integrated(Box<integrated::Detail>, Box<integrated::stage::Settings>),
    Adaptive(
        Box<adaptive::result::Detail>,
        Box<adaptive::stage::Settings>,
    ),
}

/// A field-trial result with its detail and settings read as its kind's types, once, where
/// it is loaded.
#[derive(Debug, Clone)]
pub struct Field {
    pub result: FieldResult,
    pub detail: Detail,
}

impl FieldResult {
    /// `detail` and `settings` as the types of the result's kind. Read as every artifact is
    /// ([`crate::core::lenient`]): a non-finite float the stage wrote reads back as itself.
    pub fn typed(self) -> anyhow::Result<Field> {
        let detail = match self.kind.as_str() {
            "arx" => {
                let (d, s) = self.parts("arx")?;
                Detail::Arx(d, s)
            }
            "integrated" => {
                let (d, s) = self.parts("integrated")?;
                Detail::Integrated(d, s)
            }
            "adaptive" => {
                let (d, s) = self.parts("adaptive")?;
                Detail::Adaptive(d, s)
            }
            other => anyhow::bail!(
                "stage `{}` stored a field result of unknown kind `{other}` (arx, integrated or adaptive)",
                self.stage
            ),
        };
        Ok(Field {
            result: self,
            detail,
        })
    }

    /// The stored detail and settings read as `D` and `S`, the types of kind `kind`.
    fn parts<D: DeserializeOwned, S: DeserializeOwned>(
        &self,
        kind: &str,
    ) -> anyhow::Result<(Box<D>, Box<S>)> {
        Ok((
            self.read(&self.detail, kind, "detail")?,
            self.read(&self.settings, kind, "settings")?,
        ))
    }

    /// One stored part (`what`: detail or settings) read as `T`.
    fn read<T: DeserializeOwned>(
        &self,
        value: &serde_json::Value,
        kind: &str,
        what: &str,
    ) -> anyhow::Result<Box<T>> {
        crate::core::lenient::from_str(&value.to_string())
            .map(Box::new)
            .map_err(|e| anyhow::anyhow!("the {kind} {what} stored by stage `{}`: {e}", self.stage))
    }
}

/// The result a field-trial stage stored in `dir`, its detail typed.
pub fn load_typed(dir: &Path) -> anyhow::Result<Field> {
    load(dir)?.typed()
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

#[cfg(test)]
mod tests {
    use super::*;

    fn arx_result(band: f64) -> FieldResult {
        let detail = arx::Detail {
            input: "delta".into(),
            output: "q".into(),
            input_unit: "rad".into(),
            output_unit: "rad/s".into(),
            sample_s: 0.1,
            criterion: arx::Criterion::Mdl,
            models: vec![],
            ranking: vec![],
            grid_size: 0,
            simulations: vec![],
            residual_run: "dive".into(),
            residual_acf: vec![1.0, f64::NAN],
            residual_band: band,
        };
        FieldResult {
            stage: "pitch".into(),
            kind: "arx".into(),
            method: "arx".into(),
            settings: serde_json::json!({"input": "delta", "output": "q", "detrend": "none"}),
            inputs: vec![],
            estimation_runs: vec!["dive".into()],
            validation_runs: vec![],
            parameters: vec![],
            detail: crate::core::finite::to_value(&detail).unwrap(),
            notes: vec![],
        }
    }

    /// A stored result reads back typed by its kind, its non-finite floats as themselves (a
    /// diverged autocorrelation used to stop the report with a type error).
    #[test]
    fn a_stored_result_reads_back_typed_with_its_non_finite_floats() {
        let dir = tempfile::tempdir().unwrap();
        crate::core::fsutil::write_json(&dir.path().join(RESULT), &arx_result(f64::INFINITY))
            .unwrap();
        let f = load_typed(dir.path()).unwrap();
        let Detail::Arx(d, s) = &f.detail else {
            panic!("not an ARX detail: {:?}", f.detail)
        };
        assert_eq!(d.residual_band, f64::INFINITY);
        assert_eq!(s.detrend, arx::stage::Detrend::None);
        assert_eq!(s.max_lag, 20, "a setting left out reads as its default");
        assert!(d.residual_acf[0] == 1.0 && d.residual_acf[1].is_nan());
        let mut odd = arx_result(0.2);
        odd.kind = "armax".into();
        let e = odd.typed().unwrap_err().to_string();
        assert!(e.contains("unknown kind `armax`"), "{e}");
        let mut broken = arx_result(0.2);
        broken.settings = serde_json::json!({"input": "delta"});
        let e = broken.typed().unwrap_err().to_string();
        assert!(
            e.contains("the arx settings stored by stage `pitch`"),
            "{e}"
        );
    }
}
