//! Estimators of the hydrodynamic parameters, behind one registry so `pipeline.yaml` can name them.

pub mod attitude_rows;
pub mod constants;
pub mod fallback;
pub mod fit;
pub mod gain;
mod kernels;
pub mod lag;
pub mod method;
pub mod normal;
pub mod ols;
pub mod output_error;
pub mod pem;
pub mod per_run;
pub mod refine;
pub mod regression;
pub mod result;
pub mod rls;
pub mod settings;
pub mod sources;
pub mod stage;
pub mod swarm;
pub mod tls;
pub mod two_step;

pub use method::Method;
pub use regression::Regression;

use serde::{Deserialize, Serialize};

/// One identified parameter with its uncertainty.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    pub name: String,
    pub value: f64,
    pub unit: String,
    /// NaN (JSON `null`) when there is nothing to estimate it from.
    #[serde(deserialize_with = "crate::core::fsutil::f64_or_nan")]
    pub stderr: f64,
    /// For the swarm and genetic methods: the range of the answers of seeded restarts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interval: Option<[f64; 2]>,
    /// False when the data cannot pin the parameter down (near-singular regressor or an
    /// uncertainty larger than half the value, or a value the data push past its physical
    /// sign): the value is then not to be trusted.
    pub identifiable: bool,
    /// Why a parameter is not identifiable, when the reason is more than its uncertainty.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// Flags every coefficient on the wrong side of its physical sign (positive added mass or
/// drag: negative inertia, or drag that feeds energy into the motion) as not identifiable, with
/// the reason. An estimator that constrains signs leaves nothing to flag here.
pub fn check_signs(layout: &crate::core::model::ParamLayout, params: &mut [Estimate]) {
    for (j, p) in params.iter_mut().enumerate().take(layout.len()) {
        let Some(sign) = layout.terms[j].physical_sign() else {
            continue;
        };
        if p.value * sign < 0.0 && p.note.is_none() {
            p.identifiable = false;
            p.note = Some(format!(
                "{} = {:.4} has the wrong sign (physics wants it {}): the data push it past zero, so it stands in for something the model lacks",
                p.name,
                p.value,
                if sign < 0.0 { "<= 0" } else { ">= 0" }
            ));
        }
    }
}

/// What an estimator returns: the parameters and how well the model explains the data.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Fit {
    pub parameters: Vec<Estimate>,
    /// Residual standard deviation of the equation error per DOF (N or N m).
    pub residual_sigma: std::collections::BTreeMap<String, f64>,
    pub samples: usize,
    pub condition_number: f64,
    /// Objective evaluations (population methods).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub evaluations: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub objective_value: Option<f64>,
    /// Why a population method stopped before its iteration limit (its time limit), if it did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stopped_early: Option<String>,
    /// Recursive methods: (row index, parameters) along the data.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trace: Option<Vec<(usize, Vec<f64>)>>,
    /// The prediction-error method: how its output-error refinement went.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refinement: Option<Refinement>,
    /// The prediction-error method: the command lag fitted with the model, when the runs
    /// demanded one (or it was set).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command_lag: Option<lag::LagEstimate>,
    /// `thrust_gain: fit`: the logged command's gain against the CFD cases' force scale.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thrust_gain: Option<gain::GainEstimate>,
}

/// An output-error refinement from an equation-error start: its cost before and after (the
/// weighted mean square velocity error), its steps and the coefficients' correlations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Refinement {
    pub start_cost: f64,
    pub steps: usize,
    /// The coefficients' names, in the order of `correlation`'s rows and columns.
    pub names: Vec<String>,
    /// Correlation matrix of the coefficients (empty when `J^T J` is singular).
    #[serde(default)]
    pub correlation: Vec<Vec<f64>>,
    /// What the per-run nuisance parameters came to, per kind and DOF.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub per_run: Vec<per_run::Summary>,
}

/// What an estimator may be told besides the data (the fit stage's settings).
pub struct Options<'a> {
    pub rigid_mass: [f64; 6],
    pub seed: u64,
    pub population: usize,
    pub iterations: usize,
    pub restarts: usize,
    pub norm: swarm::Norm,
    /// RLS forgetting factor (1 = none).
    pub forgetting: f64,
    pub progress: Option<&'a (dyn Fn(f64) + Sync)>,
    /// Minimise the output error over these cases instead of the equation error (population
    /// methods only).
    pub output_error: Option<(
        &'a crate::core::model::Vehicle,
        &'a [&'a crate::core::response::Response],
    )>,
    /// Wall-clock limit of a population method, s: it then returns its best so far and says so
    /// (such a result depends on the machine's speed, not only on the seed).
    pub max_seconds: Option<f64>,
    /// Largest added mass per DOF as a multiple of its rigid-body term (the prediction-error
    /// method's plausibility prior).
    pub added_mass_prior: [f64; 6],
    /// The prediction-error method's command lag.
    pub command_lag: lag::CommandLag,
    /// The per-run nuisance parameters the prediction-error method estimates.
    pub per_run: per_run::Kinds,
    /// Where the prediction-error method's refinement starts, in the layout's order, instead
    /// of the least-squares answer (the constants' choice has fitted near it already).
    pub start: Option<&'a [f64]>,
}

impl<'a> Options<'a> {
    /// A copy (the progress callback is shared).
    pub fn clone_opts(&self) -> Options<'a> {
        Options {
            progress: self.progress,
            ..*self
        }
    }
}

impl Default for Options<'_> {
    fn default() -> Self {
        Options {
            rigid_mass: [0.0; 6],
            seed: 1,
            population: 40,
            iterations: 2000,
            restarts: 5,
            norm: swarm::Norm::L2,
            forgetting: 1.0,
            progress: None,
            output_error: None,
            max_seconds: None,
            added_mass_prior: [pem::DEFAULT_PRIOR; 6],
            command_lag: lag::CommandLag::None,
            per_run: per_run::Kinds::DEFAULT,
            start: None,
        }
    }
}

/// An estimator for the equation-error problem, with the settings of its own that a `fit`
/// stage may give it. Adding one is a new file (its settings struct, its validation, its fit)
/// and a line in [`REGISTRY`].
pub trait Estimator: Sync {
    fn name(&self) -> &'static str;
    /// Whether its answer depends on a random seed (then part of the key and provenance).
    fn stochastic(&self) -> bool {
        false
    }
    /// Whether it minimises the output error of the pool runs whatever the `objective`
    /// setting says (the prediction-error method): it is then given the runs to simulate.
    fn minimises_output_error(&self) -> bool {
        false
    }
    /// Reads and checks the method's own settings (the keys of a fit's settings that are not
    /// common to every method), returning them typed, with defaults filled in. Unknown keys
    /// are errors.
    fn settings(
        &self,
        own: serde_json::Map<String, serde_json::Value>,
    ) -> Result<OwnSettings, String> {
        own_settings::<NoSettings>(own).map(OwnSettings::None)
    }
    fn fit(&self, problem: &Regression, opts: &Options) -> Result<Fit, EstimateError>;
}

/// Parses a method's own settings into `S`, whose serde attributes reject unknown keys and
/// fill defaults.
pub fn own_settings<S>(own: serde_json::Map<String, serde_json::Value>) -> Result<S, String>
where
    S: serde::de::DeserializeOwned,
{
    serde_json::from_value(serde_json::Value::Object(own)).map_err(|e| e.to_string())
}

/// The settings of a method that has none of its own.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoSettings {}

/// A method's own settings, typed from `pipeline.yaml` to the solver: each kind puts itself
/// into the [`Options`] a fit runs with. Serialised (untagged, as the settings struct itself)
/// only for the cache key and the provenance.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum OwnSettings {
    None(NoSettings),
    Pem(pem::PemSettings),
    Population(swarm::PopulationSettings),
    Rls(rls::RlsSettings),
}

impl OwnSettings {
    /// Puts the settings into `opts`.
    pub fn apply(&self, opts: &mut Options) {
        match self {
            OwnSettings::None(_) => {}
            OwnSettings::Pem(s) => s.apply(opts),
            OwnSettings::Population(s) => s.apply(opts),
            OwnSettings::Rls(s) => opts.forgetting = s.forgetting,
        }
    }

    /// What tells two configurations of a method apart in a table, if anything (a norm).
    pub fn detail(&self) -> Option<String> {
        match self {
            OwnSettings::Population(s) => Some(format!("{:?}", s.norm)),
            _ => None,
        }
    }
}

/// Every estimator `pipeline.yaml` can name.
pub const REGISTRY: &[&dyn Estimator] = &[
    &pem::Pem,
    &ols::Ols,
    &tls::Tls,
    &rls::Rls,
    &swarm::qpso::ESTIMATOR,
    &swarm::pso::ESTIMATOR,
    &swarm::ga::ESTIMATOR,
];

pub fn by_name(name: &str) -> Option<&'static dyn Estimator> {
    REGISTRY.iter().copied().find(|e| e.name() == name)
}

pub fn names() -> Vec<&'static str> {
    REGISTRY.iter().map(|e| e.name()).collect()
}

#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    #[error(
        "the cases never excite {dof}: {params} cannot be identified. Add CFD cases that move the vehicle in {dof}, or remove {dof} from vehicle.dofs"
    )]
    Unexcited { dof: String, params: String },
    #[error("no samples to fit: no CFD case or pool run reached this stage")]
    NoData,
    #[error("the least-squares solution is not finite (the regressor is singular)")]
    Singular,
    #[error("interrupted (Ctrl-C): nothing was kept")]
    Interrupted,
    #[error(
        "{0} minimises the equation error only; for objective: output_error use qpso, pso or ga (or pem, on pool runs)"
    )]
    NoOutputError(&'static str),
}
