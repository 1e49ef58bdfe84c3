//! `design.json`: what `hydrofit design` proposed and predicted. Copied into the run folder
//! with the run's logs, it travels with the run through the pool stage, and the report holds
//! the flown run to its promise.

use crate::core::model::Pool;
use serde::{Deserialize, Serialize};

/// `design.json`.
#[derive(Debug, Serialize, Deserialize)]
pub struct Written {
    pub model: String,
    pub method: String,
    pub profile: super::signal::Profile,
    pub description: String,
    pub duration_s: f64,
    /// x, y, z (m, pool frame, z down) and heading (deg) the run starts from.
    pub start: [f64; 4],
    pub pool: Pool,
    pub margin_m: f64,
    pub clearance_m: f64,
    pub prbs_clearance_m: f64,
    /// Largest command per DOF: X, Y, Z (N), N (N m).
    pub limits: [f64; 4],
    pub limits_from: String,
    pub parameters: Vec<Row>,
    /// Parameters the design would be for but cannot reach: in roll or pitch, which it does
    /// not command (it designs X, Y, Z and N).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_designed: Vec<String>,
    /// The training runs the prediction starts from.
    pub runs: Vec<String>,
    /// What the design optimised: `D-optimal`, `A-optimal` or `separation`.
    #[serde(default)]
    pub criterion: String,
    /// When the diagnosis could not tell two effects apart: how far the run tells them apart.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub separates: Option<Separation>,
    /// The per-thruster commands (`thrusters.csv`), where the vehicle describes its thrusters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thrusters: Option<super::thrusters::ThrusterPlan>,
}

/// How far the predicted recordings with either look-alike effect differ, as multiples of the
/// noise floor; the diagnosis tells two effects apart on held-out runs when their costs differ
/// by more than `margin` of it.
#[derive(Debug, Serialize, Deserialize)]
pub struct Separation {
    pub kept: String,
    pub alike: String,
    /// When the question was whether this effect is beside `kept` (the diagnosis listed it as
    /// possibly beside it), rather than which of two look-alikes it is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beside: Option<String>,
    /// The largest over the recorded runs.
    pub recorded: f64,
    pub designed: f64,
    pub prbs: f64,
    pub margin: f64,
}

#[derive(Debug, Serialize, Deserialize)]
pub struct Row {
    pub name: String,
    pub value: f64,
    /// The value the plan was flown with: the fit's, or for a coefficient the runs did not
    /// determine, the mean of the same kind of term in the DOFs they did.
    #[serde(default)]
    pub planning_value: f64,
    pub unit: String,
    pub target: bool,
    pub stderr_now: f64,
    pub predicted_after: f64,
    pub predicted_after_prbs: f64,
}
