//! `reverse_thrust_loss`: a negative (reverse) surge, sway or heave command delivers only
//! `1 - loss` of itself (a propeller designed for forward thrust); negative loss: reverse is
//! stronger.

use super::{COMMAND, Hypothesis, Limits, Needs, Param, Term};
use crate::core::dof::Dof;
use crate::core::model::Vec6;
use std::sync::Arc;

pub static EFFECT: Hypothesis = Hypothesis {
    name: "reverse_thrust_loss",
    params: &[Param {
        name: "loss",
        lo: -0.5,
        hi: 0.9,
        unit: "",
        limits: Limits::Search,
    }],
    needs: Needs::Nothing,
    build: |p| Arc::new(ReverseThrustLoss { loss: p[0] }),
    main_dof: Dof::Surge,
    acts_in: &[Dof::Surge, Dof::Sway, Dof::Heave],
    regime: "reverse_command",
    axis: COMMAND,
};

#[derive(Debug)]
struct ReverseThrustLoss {
    loss: f64,
}

impl Term for ReverseThrustLoss {
    fn shape_command(&self, cmd: &mut Vec6) {
        for f in cmd.iter_mut().take(3) {
            if *f < 0.0 {
                *f *= 1.0 - self.loss;
            }
        }
    }
}
