//! `tether_drag`: drag of the umbilical, `-c L |v| v` on the horizontal velocity over ground,
//! with L the tether in the water (anchor to vehicle, plus slack) and c in N s^2/m^3.

use super::{Axis, Env, Hypothesis, Limits, Needs, Param, State, Term, add_horizontal_drag};
use crate::core::dof::Dof;
use crate::core::model::Vec6;
use std::sync::Arc;

pub static EFFECT: Hypothesis = Hypothesis {
    name: "tether_drag",
    params: &[
        Param {
            name: "coefficient",
            lo: 0.0,
            hi: 6.0,
            unit: "N s^2/m^3",
            limits: Limits::Search,
        },
        Param {
            name: "slack_m",
            lo: 0.0,
            hi: 30.0,
            unit: "m",
            limits: Limits::PhysicalFloor,
        },
    ],
    needs: Needs::Anchor,
    build: |p| {
        Arc::new(TetherDrag {
            coefficient: p[0],
            slack_m: p[1],
        })
    },
    main_dof: Dof::Surge,
    acts_in: &[Dof::Surge, Dof::Sway],
    regime: "far_from_anchor",
    axis: Axis {
        label: |_| "distance from the tether anchor (m)".into(),
        value: |r, k, _| r.tether_length(k).unwrap_or(f64::NAN),
    },
};

#[derive(Debug)]
struct TetherDrag {
    coefficient: f64,
    slack_m: f64,
}

impl Term for TetherDrag {
    fn needs_pose(&self) -> bool {
        true
    }

    fn add_force(&self, env: &Env, s: &State, f: &mut Vec6) {
        if let Some(length) = env.tether_length {
            add_horizontal_drag(self.coefficient * (length + self.slack_m), s, f);
        }
    }
}
