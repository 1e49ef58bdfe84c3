//! The state a pool-frame simulation carries (velocity, pose, delivered thrust) and one
//! classical Runge-Kutta step of it: the integrator the twin's world and the diagnosis's
//! world share (each with forces of its own).

use super::Vec6;

/// Position in the pool frame, heading, and the force the thrusters deliver.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct State {
    pub nu: Vec6,
    /// Position in the pool frame, m.
    pub pos: [f64; 3],
    /// Heading, rad.
    pub psi: f64,
    /// Delivered generalised force (differs from the command under thruster lag).
    pub thrust: Vec6,
}

/// One RK4 step of length `h` of `ds/dt = deriv(s)`.
pub fn rk4(s: &State, h: f64, deriv: impl Fn(&State) -> State) -> State {
    let add = |a: &State, k: &State, w: f64| State {
        nu: std::array::from_fn(|i| a.nu[i] + w * k.nu[i]),
        pos: std::array::from_fn(|i| a.pos[i] + w * k.pos[i]),
        psi: a.psi + w * k.psi,
        thrust: std::array::from_fn(|i| a.thrust[i] + w * k.thrust[i]),
    };
    let k1 = deriv(s);
    let k2 = deriv(&add(s, &k1, h / 2.0));
    let k3 = deriv(&add(s, &k2, h / 2.0));
    let k4 = deriv(&add(s, &k3, h));
    let mut out = *s;
    for i in 0..6 {
        out.nu[i] += h / 6.0 * (k1.nu[i] + 2.0 * k2.nu[i] + 2.0 * k3.nu[i] + k4.nu[i]);
        out.thrust[i] +=
            h / 6.0 * (k1.thrust[i] + 2.0 * k2.thrust[i] + 2.0 * k3.thrust[i] + k4.thrust[i]);
    }
    for i in 0..3 {
        out.pos[i] += h / 6.0 * (k1.pos[i] + 2.0 * k2.pos[i] + 2.0 * k3.pos[i] + k4.pos[i]);
    }
    out.psi += h / 6.0 * (k1.psi + 2.0 * k2.psi + 2.0 * k3.psi + k4.psi);
    out
}
