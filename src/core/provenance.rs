//! Provenance records: which input file, by content hash, a result came from.

use serde::{Deserialize, Serialize};

/// An input file of a stage instance, with the content hash its key used.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputFile {
    /// Relative to the project root, `/`-separated.
    pub path: String,
    pub blake3: String,
}
