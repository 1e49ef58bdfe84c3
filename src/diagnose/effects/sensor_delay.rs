//! `sensor_delay`: the position, attitude and depth sensors lag the command log by a constant
//! time; the recording at t + d is what the vehicle did at t. Changes how the recording is
//! read, not the plant.

use super::{Hypothesis, Limits, Needs, Param, SINCE_STEP, Term};
use crate::core::dof::Dof;
use std::sync::Arc;

pub static EFFECT: Hypothesis = Hypothesis {
    name: "sensor_delay",
    params: &[Param {
        name: "delay_s",
        lo: 0.0,
        hi: 1.0,
        unit: "s",
        limits: Limits::Search,
    }],
    needs: Needs::Nothing,
    build: |p| Arc::new(SensorDelay { delay_s: p[0] }),
    main_dof: Dof::Surge,
    acts_in: &[],
    regime: "after_command_step",
    axis: SINCE_STEP,
};

#[derive(Debug)]
struct SensorDelay {
    delay_s: f64,
}

impl Term for SensorDelay {
    fn delay_s(&self) -> f64 {
        self.delay_s
    }

    fn acts_on_plant(&self) -> bool {
        false
    }
}
