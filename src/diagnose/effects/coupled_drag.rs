//! `coupled_drag`: cross-flow drag between surge and sway, `X += -c |v| u`, `Y += -c |u| v`,
//! c in N s^2/m^2.

use super::{Axis, Env, Hypothesis, Limits, Needs, Param, State, Term};
use crate::core::dof::Dof;
use crate::core::model::Vec6;
use std::sync::Arc;

pub static EFFECT: Hypothesis = Hypothesis {
    name: "coupled_drag",
    params: &[Param {
        name: "coefficient",
        lo: -100.0,
        hi: 300.0,
        unit: "N s^2/m^2",
        limits: Limits::Search,
    }],
    needs: Needs::Nothing,
    build: |p| Arc::new(CoupledDrag { coefficient: p[0] }),
    main_dof: Dof::Sway,
    acts_in: &[Dof::Surge, Dof::Sway],
    regime: "cross_flow",
    axis: Axis {
        label: |_| "|u| |v| (m^2/s^2)".into(),
        value: |r, k, _| (r.vel[0][k] * r.vel[1][k]).abs(),
    },
};

#[derive(Debug)]
struct CoupledDrag {
    coefficient: f64,
}

impl Term for CoupledDrag {
    fn add_force(&self, _env: &Env, s: &State, f: &mut Vec6) {
        f[0] -= self.coefficient * s.nu[1].abs() * s.nu[0];
        f[1] -= self.coefficient * s.nu[0].abs() * s.nu[1];
    }
}
