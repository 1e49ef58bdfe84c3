//! The `compare` stage's artifact: estimators side by side on the same cases, with their
//! errors against a known truth and their held-out pool scores.

use crate::identify::Estimate;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, Clone, Serialize, Deserialize)]
/// One estimator's result.
pub struct Row {
    pub label: String,
    pub settings: serde_json::Value,
    pub parameters: Vec<Estimate>,
    /// Relative error against truth per parameter, %.
    pub error_pct: BTreeMap<String, f64>,
    pub max_abs_error_pct: Option<f64>,
    /// Mean NMAE over DOFs and pool runs of role `validate` (all runs when none is).
    pub pool_nmae: Option<f64>,
    pub seconds: f64,
    pub evaluations: Option<usize>,
    pub error: Option<String>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
/// Every estimator of the stage, on the same data.
pub struct Comparison {
    pub rows: Vec<Row>,
    pub samples: usize,
    pub cases: usize,
    pub pool_runs: Vec<String>,
}

pub const RESULT: &str = "compare.json";

pub fn load(dir: &Path) -> anyhow::Result<Comparison> {
    crate::core::fsutil::read_json(&dir.join(RESULT))
}
