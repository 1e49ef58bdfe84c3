//! Estimators of the hydrodynamic parameters, behind one registry so `pipeline.yaml` can name them.

pub mod ols;
pub mod regression;

pub use regression::Regression;

use serde::{Deserialize, Serialize};

/// One identified parameter with its uncertainty.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    pub name: String,
    pub value: f64,
    pub unit: String,
    pub stderr: f64,
    /// False when the data cannot pin the parameter down (near-singular regressor or an
    /// uncertainty larger than half the value): the value is then not to be trusted.
    pub identifiable: bool,
}

/// What an estimator returns: the parameters and how well the model explains the data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fit {
    pub parameters: Vec<Estimate>,
    /// Residual standard deviation of the equation error per DOF (N or N m).
    pub residual_sigma: std::collections::BTreeMap<String, f64>,
    pub samples: usize,
    pub condition_number: f64,
}

/// An estimator for the equation-error problem. Adding one is a new file and a line in `REGISTRY`.
pub trait Estimator: Sync {
    fn name(&self) -> &'static str;
    fn fit(&self, problem: &Regression) -> Result<Fit, EstimateError>;
}

pub const REGISTRY: &[&dyn Estimator] = &[&ols::Ols];

pub fn by_name(name: &str) -> Option<&'static dyn Estimator> {
    REGISTRY.iter().copied().find(|e| e.name() == name)
}

pub fn names() -> Vec<&'static str> {
    REGISTRY.iter().map(|e| e.name()).collect()
}

#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    #[error("the cases never excite {dof}: {params} cannot be identified. Add CFD cases that move the vehicle in {dof}, or remove {dof} from vehicle.dofs")]
    Unexcited { dof: String, params: String },
    #[error("no samples to fit: the stage received no CFD responses")]
    NoData,
    #[error("the least-squares solution is not finite (the regressor is singular)")]
    Singular,
}
