//! `kind: starccm` — imports one STAR-CCM+ DFBI export into a response table (one instance per file).

use crate::cfd::starccm::{self, ColumnMap, ImportOptions};
use crate::core::dof::Dof;
use crate::core::response::{META, ResponseMeta, TABLE};
use crate::pipeline::contract::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub static KIND: Kind = Kind {
    fan_out: true,
    file_inputs: true,
    uses_vehicle: crate::pipeline::contract::VehicleUse::Dofs,
    ..Kind::new("starccm", Artifact::Responses, parse_as::<Settings>)
};

/// Applied force for exports without a force column, for the files a glob matches.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AppliedForce {
    pub files: String,
    pub force: BTreeMap<Dof, f64>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {
    pub columns: ColumnMap,
    pub applied_force: Vec<AppliedForce>,
}

impl Settings {
    /// The applied force for the export at `path`: every `applied_force` entry whose glob
    /// matches it, later entries overriding earlier ones per DOF.
    fn configured_force(&self, path: &str) -> BTreeMap<Dof, f64> {
        let mut configured_force = BTreeMap::new();
        for af in &self.applied_force {
            if glob::Pattern::new(&af.files).is_ok_and(|p| p.matches(path)) {
                configured_force.extend(af.force.iter().map(|(d, f)| (*d, *f)));
            }
        }
        configured_force
    }
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let input = ctx
            .inputs
            .first()
            .ok_or_else(|| anyhow::anyhow!("no input file"))?;
        let text = read_text(ctx.root, &input.path)?;
        let opts = ImportOptions {
            columns: &self.columns,
            dofs: &ctx.vehicle.dofs,
            configured_force: self.configured_force(&input.path),
        };
        let imported = starccm::parse(&input.path, &text, &opts)?;
        imported.response.write_parquet(&ctx.out.join(TABLE))?;
        let case = std::path::Path::new(&input.path)
            .file_stem()
            .map_or(input.path.clone(), |s| s.to_string_lossy().into_owned());
        let meta = ResponseMeta {
            case,
            source: input.clone(),
            dofs: imported.response.dofs.keys().copied().collect(),
            sources: imported.response.sources(),
            rows_read: imported.rows_read,
            rows_kept: imported.rows_kept,
            notes: imported.notes,
            body_mass_kg: None,
            per_metre_of_span: false,
            all_inputs: Vec::new(),
            openfoam: None,
        };
        crate::core::fsutil::write_json(&ctx.out.join(META), &meta)
    }
}

/// The export at `path` (relative to `root`) as text; an error located in the file when it is
/// not UTF-8.
fn read_text(root: &std::path::Path, path: &str) -> anyhow::Result<String> {
    Ok(crate::core::input::read(
        root,
        path,
        "export as CSV text from STAR-CCM+, not a binary or spreadsheet file",
    )?
    .text)
}
