//! What the `adaptive` stage stores in its result's `detail`.

use super::aid::Excitation;
use serde::{Deserialize, Serialize};

/// The excitation of one run: per window, and over the whole run with the weak combinations
/// named.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunExcitation {
    pub run: String,
    pub windows: Vec<Excitation>,
    pub whole: Excitation,
}

/// One forward simulation's mean absolute error per DOF (u v w in m/s, p q r in rad/s).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Validation {
    pub trained_on: String,
    pub run: String,
    pub role: String,
    /// None when the simulation diverged.
    pub initial: Option<[f64; 6]>,
    pub identified: Option<[f64; 6]>,
}

/// Measured velocities and the simulations with the initial and identified parameters (seed
/// 004 Fig. 4 in form), thinned.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Simulation {
    pub run: String,
    pub t: Vec<f64>,
    pub measured: Vec<[f64; 6]>,
    pub initial: Vec<[f64; 6]>,
    pub identified: Vec<[f64; 6]>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Detail {
    pub names: Vec<String>,
    pub initial: Vec<f64>,
    /// The final estimate as identified (any positive multiple of the truth fits the data).
    pub raw: Vec<f64>,
    /// The final estimate scaled so that `scale_by` takes its known value.
    pub scaled: Vec<f64>,
    pub scale_by: String,
    pub known_value: f64,
    /// The scaled estimate through the identification (thinned), time from the start of the
    /// first training run, runs one after the other.
    pub trace_t: Vec<f64>,
    pub trace: Vec<Vec<f64>>,
    pub velocity_error_rms: [f64; 6],
    pub excitation: Vec<RunExcitation>,
    pub threshold: f64,
    pub validation: Vec<Validation>,
    pub simulations: Vec<Simulation>,
}
