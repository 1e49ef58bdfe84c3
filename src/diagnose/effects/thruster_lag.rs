//! `thruster_lag`: the delivered force and moment follow the command through a first-order lag
//! with one time constant for every DOF. What lags is either the force itself or a propeller's
//! speed, whose thrust goes with a power of it (a square for a fixed-pitch propeller): the lag
//! holds `sign(F) |F|^(1/n)` and delivers `sign(x) |x|^n`, with the exponent `n` fitted between
//! 1 and 2. Fitted as a force lag, a motor's lag came out 20-25 % long and left structure (a
//! step's thrust rises as the square of the speed's first-order rise, slower at first).

use super::{Hypothesis, Lag, Limits, Needs, Param, SINCE_STEP, Term};
use crate::core::dof::Dof;
use std::sync::Arc;

pub static EFFECT: Hypothesis = Hypothesis {
    name: "thruster_lag",
    params: &[
        Param {
            name: "time_constant_s",
            lo: 0.0,
            hi: 1.5,
            unit: "s",
            limits: Limits::Search,
        },
        Param {
            name: "thrust_law_exponent",
            lo: 1.0,
            hi: 2.0,
            unit: "",
            limits: Limits::Physical,
        },
    ],
    needs: Needs::Nothing,
    build: |p| {
        Arc::new(ThrusterLag(Lag {
            time_constant_s: p[0],
            exponent: p.get(1).copied().unwrap_or(1.0),
        }))
    },
    main_dof: Dof::Surge,
    acts_in: &[],
    regime: "after_command_step",
    axis: SINCE_STEP,
};

/// The thrust law exponents at or below which the force itself lags.
const FORCE_LAW: f64 = 1.25;

/// The fitted thrust law `exponent` in words, for the effect's evidence.
pub fn law_in_words(exponent: f64) -> &'static str {
    if exponent >= 1.75 {
        "the thrusters' speed lags, the thrust going with its square"
    } else if exponent <= FORCE_LAW {
        "the force itself lags"
    } else {
        "a law between a lag of the force and one of a propeller's speed"
    }
}

/// What a lag of the force itself looks like, said beside it (nothing for another law): the
/// two first-order lags commute through a linear vehicle, so only its nonlinearity or another
/// sensor tells them apart.
pub fn alike_in_words(exponent: f64) -> &'static str {
    if exponent <= FORCE_LAW {
        " A lag of the force and a first-order filter on the recorded velocities look alike on a vehicle whose drag is nearly linear; runs fast enough for the quadratic drag to dominate, or a second velocity sensor (position fixes), tell them apart."
    } else {
        ""
    }
}

#[derive(Debug)]
struct ThrusterLag(Lag);

impl Term for ThrusterLag {
    fn lag(&self) -> Option<Lag> {
        Some(self.0)
    }
}
