//! `kind: export` — writes every model it reads (`from` fit stages) in the formats of
//! `to`, published to `reports/`; what a format cannot hold is said in the file and the build's
//! output. `kind: model` — reads a simulator's model file (one instance per file) as a model
//! the validation scores beside the identified ones, so the parameters already in a simulator
//! are checked against the pool runs.

use super::{Format, Model};
use crate::identify::result::{FitResult, RESULT};
use crate::pipeline::contract::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use serde::{Deserialize, Serialize};

pub static EXPORT: Kind = Kind {
    consumes: &[Artifact::Model],
    requires: &[Artifact::Model],
    publishes_to: Some("reports"),
    ..Kind::new("export", Artifact::Exports, parse_as::<ExportSettings>)
};

pub static MODEL: Kind = Kind {
    fan_out: true,
    file_inputs: true,
    ..Kind::new("model", Artifact::Model, parse_as::<ModelSettings>)
};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ExportSettings {
    /// The formats to write: `gazebo`, `uuv`, `stonefish`, `mss`, `yaml`.
    pub to: Vec<Format>,
}

impl Default for ExportSettings {
    fn default() -> Self {
        ExportSettings {
            to: vec![Format::Gazebo, Format::Uuv, Format::Mss, Format::Yaml],
        }
    }
}

impl StageImpl for ExportSettings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        for u in ctx.upstream_of(Artifact::Model) {
            let f = crate::identify::result::load(&u.dir)?;
            let m = Model::of(&f, ctx.vehicle);
            for &format in &self.to {
                let e = super::export(&m, format);
                for l in &e.left_out {
                    ctx.progress
                        .println(format!("{}: {:?} cannot hold {l}", u.id, format));
                }
                crate::core::fsutil::write_atomic(&ctx.out.join(&e.file_name), e.text.as_bytes())?;
            }
        }
        Ok(())
    }
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModelSettings {
    /// The file's format, when its name does not say it (`.sdf`, `.urdf`/`.xacro`,
    /// `.stonefish.xml`, `.m`, `.yaml`).
    pub format: Option<Format>,
}

impl StageImpl for ModelSettings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let input = ctx
            .inputs
            .first()
            .ok_or_else(|| anyhow::anyhow!("{}: no model file", ctx.id))?;
        let format = self.format.or_else(|| Format::of_path(&input.path)).ok_or_else(|| {
            anyhow::anyhow!(
                "{}: which simulator's model is this?\n  help: name it .sdf (gz-sim), .urdf or .xacro (uuv_simulator), .stonefish.xml, .m (MSS) or .yaml (hydrofit), or set `format` in the stage's settings",
                input.path
            )
        })?;
        let text =
            crate::core::input::read(ctx.root, &input.path, "give the model file as text")?.text;
        let m = super::import(format, &text).map_err(|e| anyhow::anyhow!("{}: {e}", input.path))?;
        let fit = imported(ctx, &m, input, format);
        crate::core::fsutil::write_json(&ctx.out.join(RESULT), &fit)
    }
}

/// A model read from a file as a fit result: every term it has that the vehicle's DOFs use,
/// its rigid body where the file gives one, and the file as its input.
fn imported(
    ctx: &RunCtx,
    m: &Model,
    input: &crate::core::provenance::InputFile,
    format: Format,
) -> FitResult {
    use crate::core::model::{CustomTerms, ParamLayout, Structure};
    let mut vehicle = ctx.vehicle.clone();
    if m.mass_kg > 0.0 {
        vehicle.mass_kg = m.mass_kg;
    }
    let [xx, yy, zz] = m.inertia_kg_m2;
    for (slot, x) in [
        (&mut vehicle.inertia_kg_m2.xx, xx),
        (&mut vehicle.inertia_kg_m2.yy, yy),
        (&mut vehicle.inertia_kg_m2.zz, zz),
    ] {
        if x > 0.0 {
            *slot = x;
        }
    }
    let names: Vec<String> = crate::core::model::terms::terms_over(&vehicle.dofs, &vehicle.dofs)
        .into_iter()
        .filter(|t| m.hydro.get(*t) != 0.0)
        .map(|t| t.name())
        .collect();
    vehicle.constant_force = vehicle
        .dofs
        .iter()
        .copied()
        .filter(|d| m.hydro.constant[d.index()] != 0.0)
        .collect();
    let custom = CustomTerms::only(&names, &vehicle.dofs, &vehicle.constant_force);
    vehicle.structure = Structure::Custom;
    vehicle.custom_terms = Some(custom);
    let layout = ParamLayout::of(&vehicle);
    let theta = layout.from_hydro(&m.hydro);
    let parameters = (0..layout.len())
        .map(|j| crate::identify::Estimate {
            name: layout.name(j),
            value: theta[j],
            unit: layout.unit(j).to_string(),
            stderr: 0.0,
            interval: None,
            identifiable: false,
            note: Some(format!(
                "read from {} ({format:?}), not identified",
                input.path
            )),
        })
        .collect();
    FitResult::imported(
        ctx.id,
        vehicle,
        layout,
        parameters,
        m.command_lag_s,
        input.clone(),
    )
}
