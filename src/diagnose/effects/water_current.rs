//! `water_current`: a uniform, steady horizontal current in the pool frame; the base plant's
//! drag acts on the velocity relative to the water.

use super::{Axis, Env, Hypothesis, Limits, Needs, Param, State, Term, drag};
use crate::core::dof::Dof;
use crate::core::model::Vec6;
use std::sync::Arc;

pub static EFFECT: Hypothesis = Hypothesis {
    name: "water_current",
    params: &[
        Param {
            name: "current_x_m_s",
            lo: -0.5,
            hi: 0.5,
            unit: "m/s",
            limits: Limits::Search,
        },
        Param {
            name: "current_y_m_s",
            lo: -0.5,
            hi: 0.5,
            unit: "m/s",
            limits: Limits::Search,
        },
    ],
    needs: Needs::Nothing,
    build: |p| {
        Arc::new(WaterCurrent {
            velocity_m_s: [p[0], p[1]],
        })
    },
    main_dof: Dof::Surge,
    acts_in: &[Dof::Surge, Dof::Sway],
    regime: "heading_pool_x",
    axis: Axis {
        label: |_| "heading (deg)".into(),
        value: |r, k, _| r.psi[k].to_degrees(),
    },
};

#[derive(Debug)]
struct WaterCurrent {
    velocity_m_s: [f64; 2],
}

impl Term for WaterCurrent {
    fn needs_pose(&self) -> bool {
        true
    }

    fn add_force(&self, env: &Env, s: &State, f: &mut Vec6) {
        let (cu, cv) = env.to_body(self.velocity_m_s[0], self.velocity_m_s[1]);
        let p = env.plant;
        f[0] += drag(p, 0, s.nu[0] - cu) - drag(p, 0, s.nu[0]);
        f[1] += drag(p, 1, s.nu[1] - cv) - drag(p, 1, s.nu[1]);
    }
}
