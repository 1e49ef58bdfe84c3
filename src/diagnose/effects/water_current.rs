//! `water_current`: a uniform, steady horizontal current in the pool frame. The base plant's
//! drag acts on the velocity relative to the water, and so does the added mass (Fossen 2011
//! sect. 10.3: M_RB nu' + C_RB(nu) nu + M_A nu_r' + C_A(nu_r) nu_r + D(nu_r) nu_r = tau, with
//! nu_r = nu - nu_c): its Coriolis and centripetal force (the Munk moment
//! (Y_vdot - X_udot) u_r v_r in yaw) on the relative velocity, and the force it takes to follow
//! the water's velocity as it turns in the body frame while the vehicle yaws
//! (nu_c' = [r v_c, -r u_c, 0]). With the drag alone, a current beside the added mass left a
//! yaw moment no effect explained.

use super::{Axis, Env, Hypothesis, Limits, Needs, Param, State, Term, drag};
use crate::core::dof::Dof;
use crate::core::model::Vec6;
use crate::core::model::dynamics::coriolis_full;
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
        // M_A is -added (the added mass's coefficients are negative), and C(nu) nu is linear in
        // the mass: C_A(nu) nu - C_A(nu_r) nu_r is C(nu_r) nu_r - C(nu) nu taken with `added`.
        let added = &p.hydro.added;
        let mut rel = s.nu;
        rel[0] -= cu;
        rel[1] -= cv;
        let (absolute, relative) = (coriolis_full(added, &s.nu), coriolis_full(added, &rel));
        let r = s.nu[5];
        // The water's velocity in the body frame turns as the vehicle yaws:
        // nu_c' = [r v_c, -r u_c, 0, ...], followed with M_A nu_c'.
        let (wu, wv) = (r * cv, -r * cu);
        for (i, fi) in f.iter_mut().enumerate() {
            if p.active[i] {
                let follow = -(added[i][0] * wu + added[i][1] * wv);
                *fi += relative[i] - absolute[i] + follow;
            }
        }
    }
}
