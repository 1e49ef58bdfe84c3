//! What a recorded run is for: fitting the model or holding it to account.

use serde::{Deserialize, Serialize};

/// A run's `role:` in run.yaml.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    Train,
    Validate,
}

impl Role {
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Train => "train",
            Role::Validate => "validate",
        }
    }
}
