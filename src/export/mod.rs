//! The identified model taken where it is used: written in the terms and sign conventions of
//! the simulators and toolboxes vehicle teams run (gz-sim's Hydrodynamics system, uuv_simulator,
//! Stonefish, MATLAB's MSS, or hydrofit's own YAML), with its provenance in a header, and read
//! back from them, so that the parameters already in a simulator can be validated against the
//! pool runs beside the identified model. What a format cannot hold is listed in the file and
//! on stderr, never dropped silently. Each writer's module says its mapping; the tests evaluate
//! each target's own documented force equation on the exported numbers.

pub mod gazebo;
pub mod mss;
pub mod stage;
pub mod stonefish;
pub mod uuv;
pub mod yaml;

use crate::core::dof::Dof;
use crate::core::model::{Hydro, Mat6};
use crate::core::provenance::InputFile;
use crate::identify::result::FitResult;
use serde::{Deserialize, Serialize};

/// A target format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    /// An SDF model for gz-sim (Harmonic and later): mass and inertia, the added mass as the
    /// link's `fluid_added_mass`, damping in the Hydrodynamics system.
    Gazebo,
    /// uuv_simulator's `fossen` hydrodynamic model, as the Gazebo block of a URDF/xacro.
    Uuv,
    /// A Stonefish body: what its format can hold (mass, inertia, centre of gravity).
    Stonefish,
    /// A MATLAB function returning MSS-style matrices (Fossen's M, D, C_A, g).
    Mss,
    /// hydrofit's own YAML: every coefficient by name, the lag, the provenance.
    Yaml,
}

impl Format {
    pub const ALL: [Format; 5] = [
        Format::Gazebo,
        Format::Uuv,
        Format::Stonefish,
        Format::Mss,
        Format::Yaml,
    ];

    /// The file name a model of stage `stage` is written to.
    pub fn file_name(self, stage: &str) -> String {
        let s: String = stage
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect();
        match self {
            Format::Gazebo => format!("{s}.sdf"),
            Format::Uuv => format!("{s}.uuv.xacro"),
            Format::Stonefish => format!("{s}.stonefish.xml"),
            Format::Mss => format!("hydrofit_{s}.m"),
            Format::Yaml => format!("{s}.model.yaml"),
        }
    }

    /// The format of a file, by its name.
    pub fn of_path(path: &str) -> Option<Format> {
        let p = path.to_ascii_lowercase();
        [
            (".sdf", Format::Gazebo),
            (".uuv.xacro", Format::Uuv),
            (".urdf", Format::Uuv),
            (".xacro", Format::Uuv),
            (".stonefish.xml", Format::Stonefish),
            (".scn", Format::Stonefish),
            (".m", Format::Mss),
            (".yaml", Format::Yaml),
            (".yml", Format::Yaml),
        ]
        .iter()
        .find(|(ext, _)| p.ends_with(ext))
        .map(|(_, f)| *f)
    }
}

/// The model as every format is written from: rigid body, coefficients (SNAME signs, body
/// frame x forward, y starboard, z down, about the centre of gravity), the command lag, and
/// where it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    pub name: String,
    pub mass_kg: f64,
    /// Principal moments of inertia about the centre of gravity, kg m^2.
    pub inertia_kg_m2: [f64; 3],
    pub dofs: Vec<Dof>,
    pub hydro: Hydro,
    /// The first-order lag between a command and the force, s (0: none).
    pub command_lag_s: f64,
    pub provenance: Provenance,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Provenance {
    pub hydrofit: String,
    pub stage: String,
    pub method: String,
    pub inputs: Vec<InputFile>,
    /// Coefficients the runs could not determine, by name.
    #[serde(default)]
    pub not_identifiable: Vec<String>,
}

/// A written model: its file name, text, and what the format could not hold.
pub struct Exported {
    pub file_name: String,
    pub text: String,
    pub left_out: Vec<String>,
}

impl Model {
    /// The model fit `f` identified for `vehicle` (the fit's own body when it has one).
    pub fn of(f: &FitResult, vehicle: &crate::core::model::Vehicle) -> Model {
        let v = f.vehicle.as_ref().unwrap_or(vehicle);
        Model {
            name: v.name.clone(),
            mass_kg: v.mass_kg,
            inertia_kg_m2: [v.inertia_kg_m2.xx, v.inertia_kg_m2.yy, v.inertia_kg_m2.zz],
            dofs: v.dofs.clone(),
            hydro: f.hydro(),
            command_lag_s: f.fit.command_lag.as_ref().map_or(0.0, |l| l.value_s),
            provenance: Provenance {
                hydrofit: crate::pipeline::key::TOOL.to_string(),
                stage: f.stage.clone(),
                method: f.method.clone(),
                inputs: f.input_files(),
                not_identifiable: f
                    .fit
                    .parameters
                    .iter()
                    .filter(|p| !p.identifiable)
                    .map(|p| p.name.clone())
                    .collect(),
            },
        }
    }

    /// The rigid-body mass matrix's diagonal.
    pub fn rigid(&self) -> [f64; 6] {
        let m = self.mass_kg;
        let [a, b, c] = self.inertia_kg_m2;
        [m, m, m, a, b, c]
    }
}

/// Writes `m` in format `f`.
pub fn export(m: &Model, f: Format) -> Exported {
    let (text, left_out) = match f {
        Format::Gazebo => gazebo::write(m),
        Format::Uuv => uuv::write(m),
        Format::Stonefish => stonefish::write(m),
        Format::Mss => mss::write(m),
        Format::Yaml => yaml::write(m),
    };
    Exported {
        file_name: f.file_name(&m.provenance.stage),
        text,
        left_out,
    }
}

/// Reads a model written in format `f` (by hydrofit or by hand).
pub fn import(f: Format, text: &str) -> Result<Model, String> {
    match f {
        Format::Gazebo => gazebo::read(text),
        Format::Uuv => uuv::read(text),
        Format::Stonefish => stonefish::read(text),
        Format::Mss => mss::read(text),
        Format::Yaml => yaml::read(text),
    }
}

/// The provenance as comment lines (without the comment marker).
pub fn header(m: &Model, format: &str) -> Vec<String> {
    let p = &m.provenance;
    let mut out = vec![
        format!("{format} model of {} written by hydrofit {}", m.name, p.hydrofit),
        format!("identified by fit stage `{}`, method {}", p.stage, p.method),
        "SNAME signs; from the body frame x forward, y starboard, z down about the centre of gravity".into(),
        "inputs (blake3):".into(),
    ];
    out.extend(
        p.inputs
            .iter()
            .map(|i| format!("  {} {}", i.blake3, i.path)),
    );
    if !p.not_identifiable.is_empty() {
        out.push(format!(
            "not identifiable from these runs (values kept, flagged in the report): {}",
            p.not_identifiable.join(", ")
        ));
    }
    out
}

/// What a format that holds the added mass, the damping (`full_quadratic`: every quadratic
/// term, else only the diagonal ones) and `buoyancy` cannot hold of `m`.
pub fn left_out(m: &Model, full_quadratic: bool, buoyancy: bool) -> Vec<String> {
    let h = &m.hydro;
    let mut out = Vec::new();
    if h.constant.iter().any(|c| *c != 0.0) {
        out.push(format!(
            "the constant generalised force X_0..N_0 = {:?} (net buoyancy, a tether's pull, a thruster offset): add it as a constant wrench",
            h.constant
        ));
    }
    if !buoyancy && (h.net_weight != 0.0 || h.moment.iter().any(|x| *x != 0.0)) {
        out.push(format!(
            "the weight less the buoyancy W-B = {} N and its moment eta = {:?} N m: set the simulator's buoyancy to match",
            h.net_weight, h.moment
        ));
    }
    if !full_quadratic {
        let off = (0..6).flat_map(|k| (0..6).flat_map(move |i| (0..6).map(move |j| (k, i, j))));
        if off
            .filter(|&(k, i, j)| !(k == i && i == j))
            .any(|(k, i, j)| h.quad[k][i][j] != 0.0)
        {
            out.push("the quadratic drag's cross terms (only its diagonal is held)".into());
        }
    }
    if h.lever != [0.0; 3] {
        out.push(format!(
            "the centre of gravity r_g = {:?} m from the thrusters' layout origin (x_g, y_g, z_g): the model's moments are about the centre of gravity, so place each thruster at its layout position less r_g",
            h.lever
        ));
    }
    if m.command_lag_s > 0.0 {
        out.push(format!(
            "the command lag T_cmd = {:.3} s: pass the thrusters' commands through a first-order lag of that time constant",
            m.command_lag_s
        ));
    }
    out
}

/// The 6x6 rotation that takes body vectors from x forward, y starboard, z down to ROS's
/// x forward, y left, z up (REP-103): the sign of each of u, v, w, p, q, r.
pub const FLU: [f64; 6] = [1.0, -1.0, -1.0, 1.0, -1.0, -1.0];

/// A matrix of force per velocity in the other frame: s_i s_j a_ij.
pub fn flip(a: &Mat6) -> Mat6 {
    std::array::from_fn(|i| std::array::from_fn(|j| FLU[i] * FLU[j] * a[i][j]))
}

/// Formats a number so that it reads back exactly.
pub fn num(x: f64) -> String {
    let s = format!("{x:?}");
    if s == "-0.0" { "0.0".into() } else { s }
}

#[cfg(test)]
pub(crate) mod tests;
