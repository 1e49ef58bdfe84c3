//! hydrofit's own model file: the rigid body, every non-zero coefficient by its SNAME name
//! (`X_udot`, `Y_v|r|`, `N_rr`, `W-B`, `eta_z`; body frame x forward, y starboard, z down),
//! the command lag and the provenance, exactly: a model read back from it is the model written.

use super::{Model, Provenance};
use crate::core::dof::Dof;
use crate::core::model::Hydro;
use crate::core::model::terms::{Term, every_term};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: String,
    mass_kg: f64,
    inertia_kg_m2: [f64; 3],
    dofs: Vec<Dof>,
    coefficients: BTreeMap<String, f64>,
    #[serde(default)]
    command_lag_s: f64,
    #[serde(default)]
    provenance: Provenance,
}

pub fn write(m: &Model) -> (String, Vec<String>) {
    let mut text: String = super::header(m, "hydrofit")
        .iter()
        .map(|l| format!("# {l}\n"))
        .collect();
    let coefficients = every_term()
        .into_iter()
        .filter(|t| m.hydro.get(*t) != 0.0)
        .map(|t| (t.name(), m.hydro.get(t)))
        .collect();
    let f = File {
        name: m.name.clone(),
        mass_kg: m.mass_kg,
        inertia_kg_m2: m.inertia_kg_m2,
        dofs: m.dofs.clone(),
        coefficients,
        command_lag_s: m.command_lag_s,
        provenance: m.provenance.clone(),
    };
    text += &serde_yaml_ng::to_string(&f).expect("a model serialises");
    (text, Vec::new())
}

pub fn read(text: &str) -> Result<Model, String> {
    let f: File =
        serde_yaml_ng::from_str(text).map_err(|e| format!("not a hydrofit model file: {e}"))?;
    let mut hydro = Hydro::default();
    for (name, value) in &f.coefficients {
        let t = Term::parse(name).ok_or(format!(
            "coefficients: `{name}` is not a term (names look like X_udot, Y_v|r|, N_rr, W-B, eta_z)"
        ))?;
        hydro.set(t, *value);
    }
    Ok(Model {
        name: f.name,
        mass_kg: f.mass_kg,
        inertia_kg_m2: f.inertia_kg_m2,
        dofs: f.dofs,
        hydro,
        command_lag_s: f.command_lag_s,
        provenance: f.provenance,
    })
}
