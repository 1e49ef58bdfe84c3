//! The fit's artifact: identified parameters with the cases and runs they came from, as
//! `fit.json` stores them, and the objective they were fitted under.

use super::{Estimate, Fit};
use crate::core::dof::Dof;
use crate::core::model::{ParamLayout, Structure};
use crate::core::provenance::InputFile;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Objective {
    /// Force reconstructed from measured velocity and acceleration vs applied force (seed 001 eq. 14).
    #[default]
    EquationError,
    /// Velocity simulated under the applied force vs measured velocity (seed 001 eq. 9).
    OutputError,
}

impl Objective {
    pub fn label(self) -> &'static str {
        match self {
            Objective::EquationError => "equation error (seed 001 eq. 14)",
            Objective::OutputError => "output error (seed 001 eq. 9, simulator in the loop)",
        }
    }
}

/// A reference value of one parameter and where it comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Expected {
    pub value: f64,
    pub source: String,
}

/// A CFD case the fit used.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CaseRef {
    pub id: String,
    pub case: String,
    pub source: InputFile,
    /// All of the case's input files when it has more than `source` (an OpenFOAM case).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub inputs: Vec<InputFile>,
    /// The body mass the case states, when it does.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass_kg: Option<f64>,
    /// A 2D case: its forces and masses are per metre of span.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub per_metre_of_span: bool,
}

/// A pool run the fit used.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunRef {
    pub id: String,
    pub run: String,
    pub inputs: Vec<InputFile>,
}

/// The fit stage's artifact: parameters with their provenance.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FitResult {
    pub stage: String,
    pub method: String,
    pub objective: Objective,
    pub settings: serde_json::Value,
    pub structure: Structure,
    /// The terms of `structure: custom`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub custom_terms: Option<crate::core::model::CustomTerms>,
    pub dofs: Vec<Dof>,
    /// DOFs whose model has a constant force term (X_0 ..), after `dofs`' terms.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub constant_force: Vec<Dof>,
    pub fit: Fit,
    pub cases: Vec<CaseRef>,
    /// The pool runs the fit used (`role: train`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub runs: Vec<RunRef>,
    /// What the fit did besides the numbers (runs left out, how sources were weighted).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    pub elapsed_s: f64,
    /// The body, when it is not the pipeline's vehicle.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vehicle: Option<crate::core::model::Vehicle>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub expected: BTreeMap<String, Expected>,
    /// With `added_mass_window_s`: what the one-step fit over whole runs gives, for contrast.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub one_step: Option<Vec<Estimate>>,
    /// A model read from a simulator's file (a `model` stage), not identified: the file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub imported_from: Option<InputFile>,
}

pub const RESULT: &str = "fit.json";

impl FitResult {
    /// What the fit was fitted on, in words: `CFD cases`, `pool runs` or both.
    pub fn sources(&self) -> &'static str {
        match (self.cases.is_empty(), self.runs.is_empty()) {
            (false, false) => "CFD cases and pool runs",
            (true, false) => "pool runs",
            _ => "CFD cases",
        }
    }

    /// The parameter layout the values are in.
    pub fn layout(&self) -> ParamLayout {
        ParamLayout::build(
            self.structure,
            &self.dofs,
            &self.constant_force,
            &self.custom_terms.clone().unwrap_or_default(),
        )
        .expect("a fit's structure was built when it ran")
    }

    /// The identified coefficients.
    pub fn hydro(&self) -> crate::core::model::Hydro {
        let theta: Vec<f64> = self.fit.parameters.iter().map(|p| p.value).collect();
        self.layout().to_hydro(&theta)
    }

    /// The identified model of `vehicle` (the fit's own body when it has one).
    pub fn plant(&self, vehicle: &crate::core::model::Vehicle) -> crate::core::model::Plant {
        let mut p =
            crate::core::model::Plant::new(self.vehicle.as_ref().unwrap_or(vehicle), self.hydro());
        p.command_lag_s = self.fit.command_lag.as_ref().map_or(0.0, |l| l.value_s);
        p.command_gain = self.fit.thrust_gain.as_ref().map_or(1.0, |g| g.value);
        p
    }

    /// Every input file the values depend on: CFD cases and pool runs.
    pub fn input_files(&self) -> Vec<InputFile> {
        let cfd = self.cases.iter().flat_map(|c| {
            if c.inputs.is_empty() {
                vec![c.source.clone()]
            } else {
                c.inputs.clone()
            }
        });
        cfd.chain(self.runs.iter().flat_map(|r| r.inputs.clone()))
            .chain(self.imported_from.clone())
            .collect()
    }

    /// A model read from a file (see [`Self::imported_from`]): `parameters` in `layout`'s
    /// order for `vehicle`, with its command lag.
    pub fn imported(
        stage: &str,
        vehicle: crate::core::model::Vehicle,
        layout: ParamLayout,
        parameters: Vec<crate::identify::Estimate>,
        command_lag_s: f64,
        file: InputFile,
    ) -> FitResult {
        let lag = (command_lag_s > 0.0).then_some(crate::identify::lag::LagEstimate {
            value_s: command_lag_s,
            stderr_s: 0.0,
            cost_without: f64::NAN,
            cost_with: f64::NAN,
            estimated: false,
            searched_on_candidates: None,
            profile: Vec::new(),
        });
        FitResult {
            stage: stage.to_string(),
            method: "imported".into(),
            objective: Objective::EquationError,
            settings: serde_json::json!({ "file": file.path }),
            structure: vehicle.structure,
            custom_terms: vehicle.custom_terms.clone(),
            dofs: vehicle.dofs.clone(),
            constant_force: layout.constant.clone(),
            fit: crate::identify::Fit {
                parameters,
                residual_sigma: Default::default(),
                samples: 0,
                condition_number: f64::NAN,
                command_lag: lag,
                ..Fit::default()
            },
            cases: Vec::new(),
            runs: Vec::new(),
            notes: vec![format!(
                "read from {} (blake3 {}), not identified",
                file.path, file.blake3
            )],
            elapsed_s: 0.0,
            vehicle: Some(vehicle),
            expected: Default::default(),
            one_step: None,
            imported_from: Some(file),
        }
    }
}

pub fn load(dir: &Path) -> anyhow::Result<FitResult> {
    crate::core::fsutil::read_json(&dir.join(RESULT))
}
