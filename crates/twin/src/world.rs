//! The seed-001 twin's world: the reference plant plus the left-out effects it conceals in its
//! pool runs (docs/formats.md, "Left-out effects"), simulated in the pool frame with what they
//! need: position, heading and thruster state.
//!
//! This is the twin's own code, written apart from the diagnosis's effect models
//! (hydrofit's `diagnose::effects`), and with other functional forms: the thrusters' lag is in the
//! motor's speed with thrust quadratic in it, reverse thrust fades in smoothly, the dead zone
//! is an offset, the tether's length is the cable paid out, the current varies along the pool,
//! the wall's drag falls off algebraically, coupled drag is quadratic drag on the resultant
//! speed, and late sensors are also low-passed. The diagnosis fits its own simpler forms, so it
//! can only find these effects by what they do to the recordings; tests compare its parameters
//! with the equivalents these forms imply (`src/diagnose/tests.rs`).

pub use crate::effect::{Effect, NAMES, OUTSIDE};
pub use hydrofit_core::model::motion::State;
use hydrofit_core::model::motion::rk4;
use hydrofit_core::model::pool::Pool;
use hydrofit_core::model::{Plant, Vec6};

/// Base plant plus effects, in a pool.
#[derive(Debug, Clone)]
pub struct WorldPlant {
    pub plant: Plant,
    pub effects: Vec<Effect>,
    pub pool: Option<Pool>,
    pub tether_anchor: Option<[f64; 3]>,
    /// Whether position and heading are integrated. A caller that sets them from a recording
    /// at every sample, with no effect that depends on them, turns this off and saves the
    /// trigonometry; the velocities are the same to the bit.
    pub track_pose: bool,
}

fn drag(p: &Plant, i: usize, x: f64) -> f64 {
    (p.hydro.lin[i][i] + p.hydro.quad[i][i][i] * x.abs()) * x
}

/// Cable paid out from an anchor at the surface to the vehicle: the horizontal run plus the
/// depth below the anchor (the cable hangs down and trails behind), m, without slack.
fn paid_out(anchor: [f64; 3], pos: [f64; 3]) -> f64 {
    (pos[0] - anchor[0]).hypot(pos[1] - anchor[1]) + (pos[2] - anchor[2]).abs()
}

/// Width of the fade between forward and reverse propeller efficiency, N.
const REVERSE_FADE_N: f64 = 2.0;
/// Amplitude of the current's variation along the pool (fraction of its value at the middle).
const CURRENT_VARIATION: f64 = 0.3;

/// ln(1 + e^z) without overflow.
fn softplus(z: f64) -> f64 {
    z.max(0.0) + (-z.abs()).exp().ln_1p()
}

/// Force delivered at signed propeller speed `n`, in sqrt(N): n |n|.
fn thrust_at_speed(n: f64) -> f64 {
    n * n.abs()
}

/// Signed propeller speed, in sqrt(N), that delivers `force` in steady state.
fn speed_for(force: f64) -> f64 {
    force.signum() * force.abs().sqrt()
}

impl WorldPlant {
    pub fn new(plant: Plant) -> WorldPlant {
        WorldPlant {
            plant,
            effects: Vec::new(),
            pool: None,
            tether_anchor: None,
            track_pose: true,
        }
    }

    /// Whether any effect depends on the vehicle's position or heading.
    pub fn effects_need_pose(&self) -> bool {
        self.effects.iter().any(|e| {
            matches!(
                e,
                Effect::TetherDrag { .. }
                    | Effect::WaterCurrent { .. }
                    | Effect::WallEffect { .. }
                    | Effect::SurfaceDrag { .. }
                    | Effect::TetherTorsion { .. }
                    | Effect::DepthBuoyancy { .. }
                    | Effect::TetherSpring { .. }
            )
        })
    }

    /// The thrusters' lag: its time constant, and whether it is the motors' speed that lags
    /// (the force going as its square) rather than the force.
    pub fn lag(&self) -> Option<(f64, bool)> {
        self.effects.iter().find_map(|e| match e {
            Effect::ThrusterLag { time_constant_s } if *time_constant_s > 0.0 => {
                Some((*time_constant_s, true))
            }
            Effect::ForceLag { time_constant_s } if *time_constant_s > 0.0 => {
                Some((*time_constant_s, false))
            }
            _ => None,
        })
    }

    /// The force the thrusters would deliver in steady state for a command.
    pub fn shape_command(&self, cmd: &Vec6) -> Vec6 {
        let mut out = *cmd;
        for e in &self.effects {
            match e {
                Effect::ThrusterDeadband { force_n, moment_nm } => {
                    for (i, f) in out.iter_mut().enumerate() {
                        let d = if i < 3 { *force_n } else { *moment_nm };
                        if d > 0.0 {
                            let knee = |x: f64| 0.1 * d * softplus((x - d) / (0.1 * d));
                            *f = f.signum() * (knee(f.abs()) - knee(0.0));
                        }
                    }
                }
                Effect::ThrustSaturation { force_n, moment_nm } => {
                    for (i, f) in out.iter_mut().enumerate() {
                        let m = if i < 3 { *force_n } else { *moment_nm };
                        *f = f.clamp(-m, m);
                    }
                }
                Effect::ReverseThrustLoss { loss } => {
                    for f in out.iter_mut().take(3) {
                        *f *= 1.0 - loss / (1.0 + (*f / REVERSE_FADE_N).exp());
                    }
                }
                _ => {}
            }
        }
        out
    }

    /// Forces of the environmental effects on the vehicle at time `t`, body frame.
    pub fn extra_force(&self, s: &State, t: f64) -> Vec6 {
        self.extra_force_at(s, s.psi.cos(), s.psi.sin(), t)
    }

    /// [`Self::extra_force`] with the heading's cosine and sine already computed.
    fn extra_force_at(&self, s: &State, c: f64, sn: f64, t: f64) -> Vec6 {
        let mut f = [0.0; 6];
        if self.effects.is_empty() {
            return f;
        }
        let to_body = |fx: f64, fy: f64| to_body((c, sn), fx, fy);
        // Pool-frame velocity and speed, for the effects that act on motion over ground.
        let ground = || {
            let vw = [c * s.nu[0] - sn * s.nu[1], sn * s.nu[0] + c * s.nu[1]];
            (vw, (vw[0] * vw[0] + vw[1] * vw[1]).sqrt())
        };
        for e in &self.effects {
            match e {
                Effect::NetBuoyancy { force_n } => f[2] += force_n,
                Effect::TetherDrag {
                    coefficient,
                    slack_m,
                } => {
                    let a = self.tether_anchor.unwrap_or([0.0, 0.0, 0.0]);
                    let l = paid_out(a, s.pos) + slack_m;
                    let (vw, speed) = ground();
                    let (bx, by) = to_body(
                        -coefficient * l * speed * vw[0],
                        -coefficient * l * speed * vw[1],
                    );
                    f[0] += bx;
                    f[1] += by;
                }
                Effect::WaterCurrent { velocity_m_s: cw } => {
                    self.add_current(s, (c, sn), cw, &mut f)
                }
                Effect::WallEffect {
                    coefficient,
                    decay_m,
                } => {
                    if let Some(pool) = self.pool {
                        let d = pool.wall_distance(s.pos[0], s.pos[1]).max(0.0);
                        let (vw, speed) = ground();
                        let k = coefficient / (1.0 + (d / decay_m).powi(2)) * speed;
                        let (bx, by) = to_body(-k * vw[0], -k * vw[1]);
                        f[0] += bx;
                        f[1] += by;
                    }
                }
                Effect::CoupledDrag { coefficient } => {
                    let speed = s.nu[0].hypot(s.nu[1]);
                    f[0] -= coefficient * (speed - s.nu[0].abs()) * s.nu[0];
                    f[1] -= coefficient * (speed - s.nu[1].abs()) * s.nu[1];
                }
                Effect::Wave {
                    force_n,
                    frequency_hz,
                    phase_rad,
                } => {
                    f[2] += force_n * (std::f64::consts::TAU * frequency_hz * t + phase_rad).sin();
                }
                Effect::SurfaceDrag {
                    coefficient,
                    depth_m,
                } => {
                    let near = (-(s.pos[2].max(0.0) / depth_m).powi(2)).exp();
                    f[0] -= coefficient * near * s.nu[0].abs() * s.nu[0];
                    f[1] -= coefficient * near * s.nu[1].abs() * s.nu[1];
                }
                Effect::TetherTorsion {
                    stiffness_nm_per_rad,
                } => f[5] -= stiffness_nm_per_rad * s.psi,
                Effect::AsymmetricDrag { coefficient } => {
                    f[0] -= coefficient * s.nu[0].min(0.0).abs() * s.nu[0];
                }
                _ => self.add_hull_force(e, s, (c, sn), &mut f),
            }
        }
        f
    }

    /// The forces of the hull's and the tether's effects outside the diagnosis's table that
    /// act through the state alone (no thrust), added to `f` (body frame).
    fn add_hull_force(&self, e: &Effect, s: &State, (c, sn): (f64, f64), f: &mut Vec6) {
        match e {
            Effect::MunkMoment { coefficient } => f[5] += coefficient * s.nu[0] * s.nu[1],
            Effect::DepthBuoyancy { n_per_m } => f[2] += n_per_m * s.pos[2].max(0.0),
            Effect::ForwardLift { coefficient } => f[2] += coefficient * s.nu[0] * s.nu[0],
            Effect::YawBias { moment_nm } => f[5] += moment_nm,
            Effect::TetherSpring { stiffness_n_per_m } => {
                let a = self.tether_anchor.unwrap_or([0.0, 0.0, 0.0]);
                let (bx, by) = to_body(
                    (c, sn),
                    -stiffness_n_per_m * (s.pos[0] - a[0]),
                    -stiffness_n_per_m * (s.pos[1] - a[1]),
                );
                f[0] += bx;
                f[1] += by;
            }
            _ => {}
        }
    }

    /// The force of the current `cw` (pool frame, m/s at the pool's middle) on the vehicle in
    /// state `s` heading at (cos, sin) `(c, sn)`, added to `f` (body frame).
    fn add_current(&self, s: &State, (c, sn): (f64, f64), cw: &[f64; 2], f: &mut Vec6) {
        let to_body = |fx: f64, fy: f64| to_body((c, sn), fx, fy);
        let tau = std::f64::consts::TAU;
        // The current's scale at the vehicle and its rate of change along x.
        let (scale, slope) = self.pool.map_or((1.0, 0.0), |pool| {
            let along = (s.pos[0] - pool.length_m / 2.0) / pool.length_m;
            (
                1.0 + CURRENT_VARIATION * (tau * along).sin(),
                CURRENT_VARIATION * tau / pool.length_m * (tau * along).cos(),
            )
        });
        let (cu, cv) = to_body(scale * cw[0], scale * cw[1]);
        let p = &self.plant;
        f[0] += drag(p, 0, s.nu[0] - cu) - drag(p, 0, s.nu[0]);
        f[1] += drag(p, 1, s.nu[1] - cv) - drag(p, 1, s.nu[1]);
        // The added mass moves with the water too (relative-velocity form):
        // its centripetal forces and Munk moment on the relative velocity, and
        // the force to follow the water's velocity as seen from the body, which
        // turns with the yaw rate and changes as the vehicle crosses the pool.
        let (au, av) = (-p.hydro.added[0][0], -p.hydro.added[1][1]);
        let (u, v, r) = (s.nu[0], s.nu[1], s.nu[5]);
        let x_rate = c * u - sn * v;
        let (gu, gv) = to_body(slope * x_rate * cw[0], slope * x_rate * cw[1]);
        let (water_u, water_v) = (r * cv + gu, -r * cu + gv);
        f[0] += -av * r * cv + au * water_u;
        f[1] += au * r * cu + av * water_v;
        f[5] += (av - au) * (u * v - (u - cu) * (v - cv));
    }

    /// The askew surge thruster's yaw moment for the surge thrust delivered.
    fn skew_moment(&self, thrust: &Vec6) -> f64 {
        self.effects
            .iter()
            .map(|e| match e {
                Effect::SkewedThruster { arm_m } => arm_m * thrust[0],
                _ => 0.0,
            })
            .sum()
    }

    /// The thrust delivered at body velocity `nu`: what the inflow along each push takes off,
    /// and what the cross flow takes off the lateral thrusters.
    fn inflow(&self, nu: &Vec6, thrust: Vec6) -> Vec6 {
        let mut out = thrust;
        for e in &self.effects {
            if let Effect::CrossflowLoss { speed_m_s } = e {
                let share = (1.0 - nu[0].abs() / speed_m_s).max(0.0);
                out[1] *= share;
                out[5] *= share;
            }
            if let Effect::InflowLoss { speed_m_s } = e {
                for (f, v) in out.iter_mut().zip(nu).take(3) {
                    let along = (f.signum() * v).max(0.0);
                    *f *= (1.0 - along / speed_m_s).max(0.0);
                }
            }
        }
        out
    }

    /// The share of its force a thruster delivers at time `t` (a battery's sag).
    fn supply(&self, t: f64) -> f64 {
        self.effects.iter().fold(1.0, |acc, e| match e {
            Effect::BatterySag { loss_per_minute } => acc * (1.0 - loss_per_minute * t / 60.0),
            _ => acc,
        })
    }

    fn deriv(&self, s: &State, cmd: &Vec6, t: f64) -> State {
        let target = self.shape_command(cmd);
        // With a motor lag, the state's `thrust` holds the motors' signed speeds, in sqrt(N);
        // with a force lag, the force.
        let (thrust, thrust_dot) = match self.lag() {
            Some((tc, true)) => (
                s.thrust.map(thrust_at_speed),
                std::array::from_fn(|i| (speed_for(target[i]) - s.thrust[i]) / tc),
            ),
            Some((tc, false)) => (
                s.thrust,
                std::array::from_fn(|i| (target[i] - s.thrust[i]) / tc),
            ),
            None => (target, [0.0; 6]),
        };
        let supply = self.supply(t);
        let thrust = self.inflow(&s.nu, thrust.map(|f| supply * f));
        if !self.track_pose {
            // No effect reads the pose (the caller checked): heading unused, pose held.
            let extra = self.extra_force_at(s, 0.0, 0.0, t);
            let mut tau: Vec6 = std::array::from_fn(|i| thrust[i] + extra[i]);
            tau[5] += self.skew_moment(&thrust);
            return State {
                nu: self.plant.accel(&s.nu, &tau),
                pos: [0.0; 3],
                psi: 0.0,
                thrust: thrust_dot,
            };
        }
        let (c, sn) = (s.psi.cos(), s.psi.sin());
        let extra = self.extra_force_at(s, c, sn, t);
        let mut tau: Vec6 = std::array::from_fn(|i| thrust[i] + extra[i]);
        tau[5] += self.skew_moment(&thrust);
        let nu_dot = self.plant.accel(&s.nu, &tau);
        State {
            nu: nu_dot,
            pos: [
                c * s.nu[0] - sn * s.nu[1],
                sn * s.nu[0] + c * s.nu[1],
                s.nu[2],
            ],
            psi: s.nu[5],
            thrust: thrust_dot,
        }
    }

    /// The body-frame acceleration at a state under a command at time `t` (what an IMU would
    /// sense, less gravity).
    pub fn accel(&self, s: &State, cmd: &Vec6, t: f64) -> Vec6 {
        self.deriv(s, cmd, t).nu
    }

    /// The force and moment the thrusters deliver in a state (body frame).
    pub fn delivered(&self, s: &State, cmd: &Vec6) -> Vec6 {
        match self.lag() {
            Some((_, true)) => s.thrust.map(thrust_at_speed),
            Some((_, false)) => s.thrust,
            None => self.shape_command(cmd),
        }
    }

    /// One RK4 step of length `h` from time `t` with the command held (a time-dependent
    /// force is taken at the step's middle).
    pub fn step(&self, s: &State, cmd: &Vec6, h: f64, t: f64) -> State {
        let mid = t + 0.5 * h;
        let mut out = rk4(s, h, |x| self.deriv(x, cmd, mid));
        if self.lag().is_none() {
            out.thrust = self.shape_command(cmd);
        }
        out
    }

    /// States at the times `t`, from `s0` at `t[0]`, with `cmd[k]` held over [t[k], t[k+1]).
    pub fn simulate(&self, t: &[f64], cmd: &[Vec6], s0: State, max_step: f64) -> Vec<State> {
        let mut out = Vec::with_capacity(t.len());
        let mut s = s0;
        for k in 0..t.len() {
            out.push(s);
            if k + 1 == t.len() {
                break;
            }
            let span = t[k + 1] - t[k];
            let n = hydrofit_core::model::dynamics::substeps(span, max_step);
            for q in 0..n {
                let h = span / n as f64;
                s = self.step(&s, &cmd[k], h, t[k] + q as f64 * h);
            }
        }
        out
    }
}

/// A pool-frame horizontal force `(fx, fy)` in body axes, heading at (cos, sin) `(c, sn)`.
fn to_body((c, sn): (f64, f64), fx: f64, fy: f64) -> (f64, f64) {
    (c * fx + sn * fy, -sn * fx + c * fy)
}

#[cfg(test)]
mod tests {
    use super::*;
    use hydrofit_core::model::{Hydro, Vehicle};

    fn world(effects: Vec<Effect>) -> WorldPlant {
        let mut w = WorldPlant::new(Plant::new(&Vehicle::reference(), Hydro::reference()));
        w.effects = effects;
        w
    }

    #[test]
    fn without_effects_it_is_the_base_plant() {
        let w = world(vec![]);
        let t: Vec<f64> = (0..500).map(|k| k as f64 * 0.02).collect();
        let cmd: Vec<Vec6> = t
            .iter()
            .map(|&x| [40.0 * (x * 0.7).sin(), 10.0, -20.0, 0.0, 0.0, 2.0])
            .collect();
        let a = w.simulate(&t, &cmd, State::default(), 0.01);
        let b = w.plant.simulate(&t, &cmd, [0.0; 6], 0.01);
        for (x, y) in a.iter().zip(&b) {
            assert!(x.nu.iter().zip(y).all(|(p, q)| (p - q).abs() < 1e-12));
        }
    }

    #[test]
    fn lag_and_buoyancy_have_their_closed_forms() {
        // The motor's speed reaches 1 - e^-1 of its step after one time constant, so the
        // force, quadratic in it, reaches (1 - e^-1)^2 of a step from rest.
        let w = world(vec![Effect::ThrusterLag {
            time_constant_s: 0.5,
        }]);
        let t: Vec<f64> = (0..=50).map(|k| k as f64 * 0.01).collect();
        let cmd = [10.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let s = w.simulate(&t, &vec![cmd; t.len()], State::default(), 0.01);
        let delivered = w.delivered(&s[50], &cmd)[0];
        assert!((delivered - 10.0 * (1.0 - (-1.0f64).exp()).powi(2)).abs() < 1e-6);
        // Net buoyancy alone: heave settles where drag balances it.
        let w = world(vec![Effect::NetBuoyancy { force_n: 5.0 }]);
        let t: Vec<f64> = (0..3000).map(|k| k as f64 * 0.02).collect();
        let s = w.simulate(&t, &vec![[0.0; 6]; t.len()], State::default(), 0.01);
        let (a, b) = (121.30, 21.75);
        let w_ss = (-b + (b * b + 4.0 * a * 5.0f64).sqrt()) / (2.0 * a);
        assert!((s.last().unwrap().nu[2] - w_ss).abs() < 1e-6);
        assert!(s.last().unwrap().pos[2] > 0.0, "sinks, z down");
    }

    #[test]
    fn current_drifts_a_passive_vehicle_with_the_water() {
        let w = world(vec![Effect::WaterCurrent {
            velocity_m_s: [0.2, -0.1],
        }]);
        // Linear drag alone lets the relative velocity decay with (m - X_udot) / -X_u ~ 21 s.
        let t: Vec<f64> = (0..12000).map(|k| k as f64 * 0.02).collect();
        let s0 = State {
            psi: 0.6,
            ..State::default()
        };
        let s = w.simulate(&t, &vec![[0.0; 6]; t.len()], s0, 0.01);
        let end = s.last().unwrap();
        let (c, sn) = (end.psi.cos(), end.psi.sin());
        let vx = c * end.nu[0] - sn * end.nu[1];
        let vy = sn * end.nu[0] + c * end.nu[1];
        assert!(
            (vx - 0.2).abs() < 1e-3 && (vy + 0.1).abs() < 1e-3,
            "{vx} {vy}"
        );
    }

    #[test]
    fn effect_arguments_parse_and_misspellings_are_helped() {
        assert_eq!(
            Effect::from_arg("thruster_lag=0.3").unwrap(),
            Effect::ThrusterLag {
                time_constant_s: 0.3
            }
        );
        let e = Effect::from_arg("tether_darg=1").unwrap_err();
        assert!(e.contains("did you mean `tether_drag`"), "{e}");
        for n in NAMES {
            assert_eq!(Effect::from_arg(&format!("{n}=0.5")).unwrap().name(), n);
        }
    }
}
