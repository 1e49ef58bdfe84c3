//! The cache key of a stage instance and its explaining twin: one ordered list of fields is
//! either hashed (blake3, length-prefixed) or shown to a person, so `--explain` and `status`
//! cannot drift from the real decision.

use super::contract::VehicleUse;
use super::graph::Graph;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Fields(pub Vec<(String, String)>);

impl Fields {
    fn push(&mut self, name: impl Into<String>, value: impl Into<String>) {
        self.0.push((name.into(), value.into()));
    }

    pub fn key(&self) -> String {
        let mut h = blake3::Hasher::new();
        for (n, v) in &self.0 {
            for s in [n, v] {
                h.update(&(s.len() as u64).to_le_bytes());
                h.update(s.as_bytes());
            }
        }
        h.finalize().to_hex().to_string()
    }

    pub fn get(&self, name: &str) -> Option<&str> {
        self.0
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    /// The fields as text, one per line.
    pub fn text(&self) -> String {
        self.0.iter().map(|(n, v)| format!("{n} = {v}\n")).collect()
    }
}

fn flatten(prefix: &str, v: &serde_json::Value, f: &mut Fields) {
    match v {
        serde_json::Value::Object(m) if !m.is_empty() => {
            for (k, x) in m {
                f.push(format!("{prefix}.{k}"), x.to_string());
            }
        }
        other => f.push(prefix, other.to_string()),
    }
}

/// The tool version in every key: the package version and a fingerprint of its sources.
pub const TOOL: &str = concat!(env!("CARGO_PKG_VERSION"), "+", env!("HYDROFIT_SOURCE_HASH"));

/// Fields of instance `i`: kind, its version, the tool version, settings, vehicle (when the
/// kind uses it), every input file's blake3 and every upstream instance's key.
pub fn fields(
    graph: &Graph,
    i: usize,
    hashes: &BTreeMap<String, String>,
    keys: &[String],
) -> Fields {
    let inst = &graph.instances[i];
    let st = graph.stage_of(i);
    let mut f = Fields::default();
    f.push("kind", st.kind.name);
    f.push("kind version", st.kind.version.to_string());
    f.push("hydrofit", TOOL);
    flatten("setting", &st.imp.settings(), &mut f);
    let vehicle = serde_json::to_value(&graph.spec.vehicle).expect("vehicle serialises");
    match st.kind.uses_vehicle {
        VehicleUse::All => flatten("vehicle", &vehicle, &mut f),
        VehicleUse::Dofs => {
            f.push("vehicle.dofs", vehicle["dofs"].to_string());
            // Per-thruster commands become the wrench on import, through the thrusters.
            if let Some(t) = vehicle.get("thrusters") {
                flatten("vehicle.thrusters", t, &mut f);
            }
        }
    }
    for p in &inst.inputs {
        f.push(format!("input {p}"), hashes[p].clone());
    }
    for (name, value) in &inst.params {
        f.push(format!("parameter {name}"), value.clone());
    }
    for &d in &inst.deps {
        f.push(
            format!("upstream {}", graph.instances[d].id),
            keys[d].clone(),
        );
    }
    f
}
