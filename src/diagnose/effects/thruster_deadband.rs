//! `thruster_deadband`: commands smaller than a threshold deliver nothing (N for the forces,
//! N m for the moments).

use super::{COMMAND, Hypothesis, Needs, Param, Term};
use crate::model::Vec6;
use std::sync::Arc;

pub static EFFECT: Hypothesis = Hypothesis {
    name: "thruster_deadband",
    params: &[
        Param {
            name: "force_n",
            lo: 0.0,
            hi: 30.0,
            unit: "N",
        },
        Param {
            name: "moment_nm",
            lo: 0.0,
            hi: 3.0,
            unit: "N m",
        },
    ],
    needs: Needs::Nothing,
    build: |p| {
        Arc::new(ThrusterDeadband {
            force_n: p[0],
            moment_nm: p[1],
        })
    },
    main_dof: 0,
    regime: "small_command",
    axis: COMMAND,
};

#[derive(Debug)]
struct ThrusterDeadband {
    force_n: f64,
    moment_nm: f64,
}

impl Term for ThrusterDeadband {
    fn shape_command(&self, cmd: &mut Vec6) {
        for (i, f) in cmd.iter_mut().enumerate() {
            let d = if i < 3 { self.force_n } else { self.moment_nm };
            if f.abs() < d {
                *f = 0.0;
            }
        }
    }
}
