//! `thruster_deadband`: commands smaller than a threshold deliver nothing (N for the forces,
//! N m for the moments), and larger ones lose `offset` times the threshold: 0 is a switch that
//! delivers all of a command once it passes the threshold, 1 a dead zone that offsets every
//! command by its width (the usual dead-zone nonlinearity of an ESC or of seal friction).

use super::{COMMAND, Hypothesis, Limits, Needs, Param, Term};
use crate::core::dof::Dof;
use crate::core::model::Vec6;
use std::sync::Arc;

pub static EFFECT: Hypothesis = Hypothesis {
    name: "thruster_deadband",
    params: &[
        Param {
            name: "force_n",
            lo: 0.0,
            hi: 30.0,
            unit: "N",
            limits: Limits::Search,
        },
        Param {
            name: "moment_nm",
            lo: 0.0,
            hi: 3.0,
            unit: "N m",
            limits: Limits::PhysicalFloor,
        },
        Param {
            name: "offset",
            lo: 0.0,
            hi: 1.0,
            unit: "",
            limits: Limits::Physical,
        },
    ],
    needs: Needs::Nothing,
    build: |p| {
        Arc::new(ThrusterDeadband {
            force_n: p[0],
            moment_nm: p[1],
            offset: p[2],
        })
    },
    main_dof: Dof::Surge,
    acts_in: &[],
    regime: "small_command",
    axis: COMMAND,
};

#[derive(Debug)]
struct ThrusterDeadband {
    force_n: f64,
    moment_nm: f64,
    offset: f64,
}

impl Term for ThrusterDeadband {
    fn shape_command(&self, cmd: &mut Vec6) {
        for (i, f) in cmd.iter_mut().enumerate() {
            let d = if i < 3 { self.force_n } else { self.moment_nm };
            *f = if f.abs() < d {
                0.0
            } else {
                *f - self.offset * d * f.signum()
            };
        }
    }
}
