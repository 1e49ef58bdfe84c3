//! `net_buoyancy`: weight minus buoyancy, a constant force along pool z that the CFD set to
//! zero (positive: the vehicle sinks). Taken along body z: pool runs are level.

use super::{Axis, Env, Hypothesis, Limits, Needs, Param, State, Term};
use crate::core::dof::Dof;
use crate::core::model::Vec6;
use std::sync::Arc;

pub static EFFECT: Hypothesis = Hypothesis {
    name: "net_buoyancy",
    params: &[Param {
        name: "force_n",
        lo: -60.0,
        hi: 60.0,
        unit: "N",
        limits: Limits::Search,
    }],
    needs: Needs::Nothing,
    build: |p| Arc::new(NetBuoyancy { force_n: p[0] }),
    main_dof: Dof::Heave,
    acts_in: &[Dof::Heave],
    regime: "heave",
    axis: Axis {
        label: |_| "depth (m)".into(),
        value: |r, k, _| r.pos[2][k],
    },
};

#[derive(Debug)]
struct NetBuoyancy {
    force_n: f64,
}

impl Term for NetBuoyancy {
    fn add_force(&self, _env: &Env, _s: &State, f: &mut Vec6) {
        f[2] += self.force_n;
    }
}
