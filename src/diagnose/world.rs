//! The model the diagnosis simulates: the base plant plus the effects under test
//! ([`super::effects`]), in the pool frame, with the thruster state a lag needs.

use super::effects::{Env, State, Term};
use crate::model::motion::rk4;
use crate::model::{Plant, Pool, Vec6};
use std::sync::Arc;

/// Base plant plus effects, in a pool.
#[derive(Debug, Clone)]
pub struct World {
    pub plant: Plant,
    terms: Vec<Arc<dyn Term>>,
    /// The thruster lag's time constant, if an effect has one (looked up once: the
    /// derivative is evaluated four times a step).
    lag_s: Option<f64>,
    pub pool: Option<Pool>,
    pub tether_anchor: Option<[f64; 3]>,
    /// Whether position and heading are integrated. A caller that sets them from a recording
    /// at every sample, with no effect that depends on them, turns this off and saves the
    /// trigonometry; the velocities are the same to the bit.
    pub track_pose: bool,
}

impl World {
    pub fn new(plant: Plant, terms: Vec<Arc<dyn Term>>) -> World {
        let lag_s = terms.iter().find_map(|t| t.lag_s().filter(|&tc| tc > 0.0));
        World {
            plant,
            terms,
            lag_s,
            pool: None,
            tether_anchor: None,
            track_pose: true,
        }
    }

    /// Whether any effect depends on the vehicle's position or heading.
    pub fn effects_need_pose(&self) -> bool {
        self.terms.iter().any(|t| t.needs_pose())
    }

    /// The force the thrusters would deliver in steady state for a command.
    pub fn shape_command(&self, cmd: &Vec6) -> Vec6 {
        let mut out = *cmd;
        for t in &self.terms {
            t.shape_command(&mut out);
        }
        out
    }

    /// Forces of the effects on the vehicle, body frame, with the heading's cosine and sine.
    fn extra_force_at(&self, s: &State, cos_psi: f64, sin_psi: f64) -> Vec6 {
        let mut f = [0.0; 6];
        if self.terms.is_empty() {
            return f;
        }
        let env = Env {
            plant: &self.plant,
            pool: self.pool,
            anchor: self.tether_anchor,
            cos_psi,
            sin_psi,
        };
        for t in &self.terms {
            t.add_force(&env, s, &mut f);
        }
        f
    }

    /// The state's derivative with the thrusters driven towards `target` (the shaped command).
    fn deriv(&self, s: &State, target: &Vec6) -> State {
        let (thrust, thrust_dot) = match self.lag_s {
            Some(tc) => (
                s.thrust,
                std::array::from_fn(|i| (target[i] - s.thrust[i]) / tc),
            ),
            None => (*target, [0.0; 6]),
        };
        if !self.track_pose {
            // No effect reads the pose (the caller checked): heading unused, pose held.
            let extra = self.extra_force_at(s, 0.0, 0.0);
            let tau: Vec6 = std::array::from_fn(|i| thrust[i] + extra[i]);
            return State {
                nu: self.plant.accel(&s.nu, &tau),
                pos: [0.0; 3],
                psi: 0.0,
                thrust: thrust_dot,
            };
        }
        let (c, sn) = (s.psi.cos(), s.psi.sin());
        let extra = self.extra_force_at(s, c, sn);
        let tau: Vec6 = std::array::from_fn(|i| thrust[i] + extra[i]);
        State {
            nu: self.plant.accel(&s.nu, &tau),
            pos: [
                c * s.nu[0] - sn * s.nu[1],
                sn * s.nu[0] + c * s.nu[1],
                s.nu[2],
            ],
            psi: s.nu[5],
            thrust: thrust_dot,
        }
    }

    /// One RK4 step of length `h` with the command held.
    pub fn step(&self, s: &State, cmd: &Vec6, h: f64) -> State {
        let target = self.shape_command(cmd);
        let mut out = rk4(s, h, |x| self.deriv(x, &target));
        if self.lag_s.is_none() {
            out.thrust = target;
        }
        out
    }
}
