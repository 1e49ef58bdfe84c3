//! `sensor_delay`: the position, attitude and depth sensors lag the command log by a constant
//! time and may smooth what they record: the recording at t + d is what the vehicle did at t,
//! seen through a first-order low-pass of time constant `filter_s` (a navigation filter, a
//! sensor's own averaging). Changes how the recording is read, not the plant.
//!
//! Fitted as a pure delay, a filtered one came out at about the delay plus the filter and left
//! the filter's rounding of every step, which a lag of the force then took: a filtered delay of
//! 0.5 s and 0.25 s was named as a delay of 0.52 s and a thruster lag of 0.20 s. Through a
//! linear vehicle a low-pass on the record and a lag of the force give the same record; they
//! differ where the simulation starts again from the record (the filter's state is the
//! record's, a lag's is the thrusters') and where the drag is not linear.

use super::{Hypothesis, Limits, Needs, Param, SINCE_STEP, Term};
use crate::core::dof::Dof;
use std::sync::Arc;

pub static EFFECT: Hypothesis = Hypothesis {
    name: "sensor_delay",
    params: &[
        Param {
            name: "delay_s",
            lo: 0.0,
            hi: 1.0,
            unit: "s",
            limits: Limits::Search,
        },
        Param {
            name: "filter_s",
            lo: 0.0,
            hi: 1.0,
            unit: "s",
            limits: Limits::PhysicalFloor,
        },
    ],
    needs: Needs::Nothing,
    build: |p| {
        Arc::new(SensorDelay {
            delay_s: p[0],
            filter_s: p.get(1).copied().unwrap_or(0.0),
        })
    },
    main_dof: Dof::Surge,
    acts_in: &[],
    regime: "after_command_step",
    axis: SINCE_STEP,
};

#[derive(Debug)]
struct SensorDelay {
    delay_s: f64,
    filter_s: f64,
}

impl Term for SensorDelay {
    fn delay_s(&self) -> f64 {
        self.delay_s
    }

    fn sensor_filter_s(&self) -> f64 {
        self.filter_s
    }

    fn acts_on_plant(&self) -> bool {
        false
    }
}
