//! `wall_effect`: extra horizontal drag near the side walls, `-c exp(-d / decay) |v| v` on the
//! velocity over ground, d the distance to the nearest wall.

use super::{Axis, Env, Hypothesis, Limits, Needs, Param, State, Term, add_horizontal_drag};
use crate::core::dof::Dof;
use crate::core::model::Vec6;
use std::sync::Arc;

pub static EFFECT: Hypothesis = Hypothesis {
    name: "wall_effect",
    params: &[
        Param {
            name: "coefficient",
            lo: 0.0,
            hi: 1500.0,
            unit: "N s^2/m^2",
            limits: Limits::Search,
        },
        Param {
            name: "decay_m",
            lo: 0.1,
            hi: 3.0,
            unit: "m",
            limits: Limits::Search,
        },
    ],
    needs: Needs::Pool,
    build: |p| {
        Arc::new(WallEffect {
            coefficient: p[0],
            decay_m: p[1],
        })
    },
    main_dof: Dof::Surge,
    acts_in: &[Dof::Surge, Dof::Sway],
    regime: "near_wall",
    axis: Axis {
        label: |_| "distance to the nearest wall (m)".into(),
        value: |r, k, _| r.wall_distance(k).unwrap_or(f64::NAN),
    },
};

#[derive(Debug)]
struct WallEffect {
    coefficient: f64,
    decay_m: f64,
}

impl Term for WallEffect {
    fn needs_pose(&self) -> bool {
        true
    }

    fn add_force(&self, env: &Env, s: &State, f: &mut Vec6) {
        if let Some(d) = env.wall_distance {
            let d = d.max(0.0);
            add_horizontal_drag(self.coefficient * (-d / self.decay_m).exp(), s, f);
        }
    }
}
