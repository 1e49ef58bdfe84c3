//! Provenance records: which input file, by content hash, a result came from.

use serde::{Deserialize, Serialize};

/// An input file of a stage instance, with the content hash its key used.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputFile {
    /// Relative to the project root, `/`-separated (absolute for a log read from outside the
    /// project, such as a dataset that cannot be copied into it).
    pub path: String,
    pub blake3: String,
    /// For a vehicle's log: the topic each signal was read from.
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub topics: std::collections::BTreeMap<String, String>,
    /// For a vehicle's log: the span read, seconds from the log's first message.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub span_s: Option<[f64; 2]>,
}

impl InputFile {
    /// A file of the project with its content hash.
    pub fn new(path: impl Into<String>, blake3: impl Into<String>) -> InputFile {
        InputFile {
            path: path.into(),
            blake3: blake3.into(),
            topics: Default::default(),
            span_s: None,
        }
    }
}
