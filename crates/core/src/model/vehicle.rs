//! The vehicle section of `pipeline.yaml`: rigid-body mass, inertia, DOFs and model structure.

use super::params::ParamLayout;
use crate::dof::Dof;
use serde::{Deserialize, Serialize};

pub use super::terms::{CustomTerms, Structure};

/// Principal moments of inertia about the centre of gravity, kg m^2.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Inertia {
    #[serde(default)]
    pub xx: f64,
    #[serde(default)]
    pub yy: f64,
    #[serde(default)]
    pub zz: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Vehicle {
    #[serde(default)]
    pub name: String,
    /// Dry mass, kg (weighed or from the CAD model; known, not identified).
    pub mass_kg: f64,
    #[serde(default)]
    pub inertia_kg_m2: Inertia,
    /// The DOFs the vehicle moves in, e.g. `[surge, sway, heave, yaw]`.
    pub dofs: Vec<Dof>,
    /// Which terms are identified: `diagonal` (seed 001) or a parameter set of seed 003
    /// Table I (`full_qd`, `diag_qd`, `diag_mass`, `diag_all`, `full_ld`, `custom`). A fit
    /// stage may choose its own.
    #[serde(default)]
    pub structure: Structure,
    /// The terms of `structure: custom`: a base set and terms added and removed by name
    /// (`{base: full_qd, add: [K_p], remove: [K_pp]}`, seed 003's CUSTOM, when left out).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub custom_terms: Option<CustomTerms>,
    /// DOFs whose model carries a constant generalised force X_0 .. N_0 to identify: net
    /// buoyancy (heave), a steady tether pull, a thruster offset. Empty by default (CFD runs
    /// of a neutrally buoyant body have none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub constant_force: Vec<Dof>,
    /// The largest command the thrusters can deliver per DOF (N or N m), when known: logged
    /// commands beyond it are clipped (a closed-loop controller asks for more than it gets).
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub command_limits: std::collections::BTreeMap<Dof, f64>,
    /// The thrusters, when runs log per-thruster commands (PWM, normalised, rpm) instead of
    /// the body wrench: the commands become the wrench through them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thrusters: Option<super::thrusters::Thrusters>,
}

impl Vehicle {
    /// The seed-001 open-frame ROV (docs/formats.md, reference vehicle).
    pub fn reference() -> Vehicle {
        Vehicle {
            name: "open-frame ROV (seed 001)".into(),
            mass_kg: 35.2,
            inertia_kg_m2: Inertia {
                xx: 0.0,
                yy: 0.0,
                zz: 1.38,
            },
            dofs: vec![Dof::Surge, Dof::Sway, Dof::Heave, Dof::Yaw],
            structure: Structure::Diagonal,
            custom_terms: None,
            constant_force: Vec::new(),
            command_limits: Default::default(),
            thrusters: None,
        }
    }

    /// A logged command as the thrusters can deliver it: clipped at `command_limits`.
    pub fn clip_command(&self, dof: Dof, x: f64) -> f64 {
        match self.command_limits.get(&dof) {
            Some(&l) => x.clamp(-l, l),
            None => x,
        }
    }

    /// Diagonal of the rigid-body mass matrix M_RB (seed 001 eq. 3, centre of gravity at the origin).
    pub fn rigid_mass(&self) -> [f64; 6] {
        let m = self.mass_kg;
        let i = self.inertia_kg_m2;
        [m, m, m, i.xx, i.yy, i.zz]
    }

    /// Which of the six DOFs are free.
    pub fn active(&self) -> [bool; 6] {
        let mut a = [false; 6];
        for d in &self.dofs {
            a[d.index()] = true;
        }
        a
    }

    /// Problems a person must fix, worded as such; empty when the vehicle is usable.
    pub fn problems(&self) -> Vec<String> {
        let mut out = Vec::new();
        if !(self.mass_kg > 0.0 && self.mass_kg.is_finite()) {
            out.push(format!(
                "mass_kg must be a positive number of kilograms, not {}",
                self.mass_kg
            ));
        }
        for (axis, v) in [
            ("xx", self.inertia_kg_m2.xx),
            ("yy", self.inertia_kg_m2.yy),
            ("zz", self.inertia_kg_m2.zz),
        ] {
            if !v.is_finite() || v < 0.0 {
                out.push(format!(
                    "inertia_kg_m2.{axis} must be a positive number of kg m^2, not {v}"
                ));
            }
        }
        if let Some(d) = self
            .dofs
            .iter()
            .enumerate()
            .find_map(|(i, d)| self.dofs[..i].contains(d).then_some(d))
        {
            out.push(format!("dofs lists {d} twice"));
        }
        if self.dofs.is_empty() {
            out.push(
                "dofs is empty: list the DOFs the vehicle moves in, e.g. [surge, sway, heave, yaw]"
                    .into(),
            );
        }
        if let Some(t) = &self.thrusters {
            out.extend(t.problems());
        }
        let mrb = self.rigid_mass();
        for d in &self.dofs {
            if d.is_angular() && (mrb[d.index()].is_nan() || mrb[d.index()] <= 0.0) {
                let axis = ["xx", "yy", "zz"][d.index() - 3];
                out.push(format!("{d} is a DOF but inertia_kg_m2.{axis} is not set: give the moment of inertia about the centre of gravity"));
            }
        }
        for d in &self.constant_force {
            if !self.dofs.contains(d) {
                out.push(format!("constant_force lists {d}, which is not in dofs"));
            }
        }
        for (d, l) in &self.command_limits {
            if !(l.is_finite() && *l > 0.0) {
                out.push(format!(
                    "command_limits.{d} must be a positive number (N or N m), not {l}"
                ));
            }
        }
        if let Err(e) = ParamLayout::build(
            self.structure,
            &self.dofs,
            &self.constant_force,
            &self.custom_terms.clone().unwrap_or_default(),
        ) {
            out.push(e);
        }
        if self.custom_terms.is_some() && self.structure != Structure::Custom {
            out.push(format!(
                "custom_terms is set but structure is {}: set structure: custom to use them",
                self.structure.label()
            ));
        }
        let mut seen = std::collections::BTreeSet::new();
        for d in &self.dofs {
            if !seen.insert(*d) {
                out.push(format!("{d} is listed twice in dofs"));
            }
        }
        out
    }
}

// The layout lives with the vehicle that chooses it: `params` knows structures and DOFs, not
// vehicles.
impl ParamLayout {
    /// The layout of a vehicle: its structure, DOFs and the DOFs with a constant force term.
    /// A vehicle is checked before use (`Vehicle::problems`), so its structure builds.
    pub fn of(vehicle: &Vehicle) -> ParamLayout {
        ParamLayout::build(
            vehicle.structure,
            &vehicle.dofs,
            &vehicle.constant_force,
            &vehicle.custom_terms.clone().unwrap_or_default(),
        )
        .expect("a checked vehicle's structure")
    }
}
