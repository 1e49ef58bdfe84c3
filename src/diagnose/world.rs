//! The model the diagnosis simulates: the base plant plus the effects under test
//! ([`super::effects`]), in the pool frame, with the thruster state a lag needs.

use super::effects::{Env, Lag, State, Term};
use crate::core::model::motion::rk4;
use crate::core::model::pool::tether_length;
use crate::core::model::{Plant, Pool, Vec6};
use std::sync::Arc;

/// Base plant plus effects, in a pool.
#[derive(Debug, Clone)]
pub struct World {
    pub plant: Plant,
    terms: Vec<Arc<dyn Term>>,
    /// The thruster lag, if an effect has one (looked up once: the derivative is evaluated
    /// four times a step).
    lag: Option<Lag>,
    pub pool: Option<Pool>,
    pub tether_anchor: Option<[f64; 3]>,
    /// Whether position and heading are integrated. A caller that sets them from a recording
    /// at every sample, with no effect that depends on them, turns this off and saves the
    /// trigonometry; the velocities are the same to the bit.
    pub track_pose: bool,
    /// Gravity's direction in the body frame (level: [0, 0, 1]), held over a step as the pose
    /// is: a model that rolls and pitches turns its restoring moments with it. The caller sets
    /// it: from the attitude a simulation carries, or the recorded one for equation error.
    pub gravity: [f64; 3],
}

impl World {
    pub fn new(plant: Plant, terms: Vec<Arc<dyn Term>>) -> World {
        let lag = terms
            .iter()
            .find_map(|t| t.lag().filter(|l| l.time_constant_s > 0.0));
        World {
            plant,
            terms,
            lag,
            pool: None,
            tether_anchor: None,
            track_pose: true,
            gravity: crate::core::model::dynamics::LEVEL,
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

    /// What the effects read besides the velocity, at the pose `s` holds: the heading and the
    /// run's geometry (tether length, wall distance), once a step.
    fn env_at(&self, s: &State) -> Env<'_> {
        if !self.track_pose {
            // No effect reads the pose (the caller checked): heading and geometry unused.
            return Env {
                plant: &self.plant,
                cos_psi: 0.0,
                sin_psi: 0.0,
                tether_length: None,
                wall_distance: None,
            };
        }
        let (sin_psi, cos_psi) = s.psi.sin_cos();
        Env {
            plant: &self.plant,
            cos_psi,
            sin_psi,
            tether_length: self.tether_anchor.map(|a| tether_length(a, s.pos)),
            wall_distance: self.pool.map(|p| p.wall_distance(s.pos[0], s.pos[1])),
        }
    }

    /// The derivative of velocity and thrust, with the thrusters driven towards `goal` (the
    /// shaped command as the thrusters' state holds it, [`World::goal`]) and the effects
    /// reading `env`. The pose is held within a step
    /// ([`World::step`] advances it): over one step (at most 0.025 s) it moves by millimetres,
    /// which no effect's force can tell apart, so the heading's sine and cosine and the
    /// geometry are computed once a step, not four times.
    fn deriv(&self, s: &State, goal: &Vec6, env: &Env, external: &Vec6) -> State {
        let (thrust, thrust_dot) = match self.lag {
            Some(l) => (
                s.thrust.map(|x| l.force_of(x)),
                std::array::from_fn(|i| (goal[i] - s.thrust[i]) / l.time_constant_s),
            ),
            None => (*goal, [0.0; 6]),
        };
        let mut tau: Vec6 = std::array::from_fn(|i| thrust[i] + external[i]);
        for t in &self.terms {
            t.add_force(env, s, &mut tau);
        }
        State {
            nu: self.plant.accel_at(&s.nu, &tau, &self.gravity),
            pos: [0.0; 3],
            psi: 0.0,
            thrust: thrust_dot,
        }
    }

    /// The force and moment the thrusters deliver in state `s` under `cmd`: the lagged thrust
    /// the state holds, or without a lag the shaped command.
    pub fn delivered(&self, s: &State, cmd: &Vec6) -> Vec6 {
        match self.lag {
            Some(l) => s.thrust.map(|x| l.force_of(x)),
            None => self.shape_command(cmd),
        }
    }

    /// The thruster lag, if an effect has one.
    pub fn lag(&self) -> Option<Lag> {
        self.lag
    }

    /// The thrusters' state when `cmd` has been held long enough: what [`State::thrust`]
    /// holds (the lag's state, or without a lag the shaped command).
    pub fn settled_thrust(&self, cmd: &Vec6) -> Vec6 {
        self.goal(self.shape_command(cmd))
    }

    /// The thrusters' state that delivers the force `target` (computed once a step: the
    /// derivative reads it four times).
    fn goal(&self, target: Vec6) -> Vec6 {
        match self.lag {
            Some(l) => target.map(|f| l.state_of(f)),
            None => target,
        }
    }

    /// The acceleration at state `s` under `cmd` (the thrusters' state as `s` holds it).
    pub fn accel(&self, s: &State, cmd: &Vec6) -> Vec6 {
        let goal = self.settled_thrust(cmd);
        let env = self.env_at(s);
        self.deriv(s, &goal, &env, &[0.0; 6]).nu
    }

    /// One RK4 step of length `h` with the command held. The pose (when tracked) advances by
    /// the step's mean body velocity (trapezoid), turned into the pool frame at the step's
    /// starting heading.
    pub fn step(&self, s: &State, cmd: &Vec6, h: f64) -> State {
        self.step_with(s, cmd, h, &[0.0; 6])
    }

    /// [`World::step`] with an `external` generalised force added (a discovered term's, held
    /// over the step).
    pub fn step_with(&self, s: &State, cmd: &Vec6, h: f64, external: &Vec6) -> State {
        let target = self.shape_command(cmd);
        let goal = self.goal(target);
        let env = self.env_at(s);
        let mut out = rk4(s, h, |x| self.deriv(x, &goal, &env, external));
        if self.track_pose {
            let (c, sn) = (env.cos_psi, env.sin_psi);
            let mean = |i: usize| 0.5 * (s.nu[i] + out.nu[i]);
            let (u, v) = (mean(0), mean(1));
            out.pos = [
                s.pos[0] + h * (c * u - sn * v),
                s.pos[1] + h * (sn * u + c * v),
                s.pos[2] + h * mean(2),
            ];
            out.psi = s.psi + h * mean(5);
        }
        if self.lag.is_none() {
            out.thrust = target;
        }
        out
    }
}
