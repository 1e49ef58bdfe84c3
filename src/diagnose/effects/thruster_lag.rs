//! `thruster_lag`: the delivered force and moment follow the command through a first-order lag
//! with one time constant for every DOF.

use super::{Hypothesis, Limits, Needs, Param, SINCE_STEP, Term};
use crate::core::dof::Dof;
use std::sync::Arc;

pub static EFFECT: Hypothesis = Hypothesis {
    name: "thruster_lag",
    params: &[Param {
        name: "time_constant_s",
        lo: 0.0,
        hi: 1.5,
        unit: "s",
        limits: Limits::Search,
    }],
    needs: Needs::Nothing,
    build: |p| {
        Arc::new(ThrusterLag {
            time_constant_s: p[0],
        })
    },
    main_dof: Dof::Surge,
    acts_in: &[],
    regime: "after_command_step",
    axis: SINCE_STEP,
};

#[derive(Debug)]
struct ThrusterLag {
    time_constant_s: f64,
}

impl Term for ThrusterLag {
    fn lag_s(&self) -> Option<f64> {
        Some(self.time_constant_s)
    }
}
