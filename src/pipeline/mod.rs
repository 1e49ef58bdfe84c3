//! The build engine: spec -> graph of stage instances -> keys -> cached, parallel execution.

pub mod cache;
pub mod contract;
pub mod executor;
pub mod explain;
pub mod graph;
pub mod key;
pub mod lock;
pub mod spec;
pub use crate::core::input::locate;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub const SPEC_FILE: &str = "pipeline.yaml";
pub const STATE_DIR: &str = ".hydrofit";

/// The project as it is on disk now: its graph, every input's hash and every instance's key.
pub struct Plan {
    pub root: PathBuf,
    pub graph: graph::Graph,
    pub hashes: BTreeMap<String, String>,
    pub fields: Vec<key::Fields>,
    pub keys: Vec<String>,
}

impl Plan {
    /// Reads the project at `root`, whose stages are of the kinds in `kinds`.
    pub fn load(root: &Path, kinds: contract::Registry) -> anyhow::Result<Plan> {
        let spec_path = root.join(SPEC_FILE);
        anyhow::ensure!(
            spec_path.exists(),
            "cannot read {} (is {} a hydrofit project? use --project DIR)",
            spec_path.display(),
            root.display()
        );
        let text = crate::core::input::read_path(
            &spec_path,
            SPEC_FILE,
            "save pipeline.yaml as UTF-8 text",
        )?
        .text;
        let spec = spec::parse(SPEC_FILE, &text, kinds)?;
        let graph = graph::Graph::expand(root, spec)?;
        let hashes = graph.hash_inputs(root)?;
        let mut fields = Vec::with_capacity(graph.instances.len());
        let mut keys: Vec<String> = Vec::with_capacity(graph.instances.len());
        for i in 0..graph.instances.len() {
            let f = key::fields(&graph, i, &hashes, &keys);
            keys.push(f.key());
            fields.push(f);
        }
        Ok(Plan {
            root: root.to_path_buf(),
            graph,
            hashes,
            fields,
            keys,
        })
    }

    pub fn cache(&self) -> cache::Cache {
        cache::Cache::new(&self.root.join(STATE_DIR))
    }
}
