//! A coupled model's state: body velocities and the roll and pitch that turn its buoyancy
//! (Fossen 2011 eq. 2.29 for the Euler-angle rates; yaw does not enter the dynamics).

use super::Plant;
use super::dynamics::{Vec6, gravity_body};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    pub nu: Vec6,
    /// Roll and pitch, rad.
    pub att: [f64; 2],
}

/// Roll and pitch rates from the body rates p, q, r.
pub fn euler_rates(att: [f64; 2], nu: &Vec6) -> [f64; 2] {
    let (sp, cp) = att[0].sin_cos();
    let (p, q, r) = (nu[3], nu[4], nu[5]);
    [p + (q * sp + r * cp) * att[1].tan(), q * cp - r * sp]
}

fn deriv(plant: &Plant, x: &State, tau: &Vec6) -> State {
    State {
        nu: plant.accel_at(&x.nu, tau, &gravity_body(x.att[0], x.att[1])),
        att: euler_rates(x.att, &x.nu),
    }
}

fn step(x: &State, k: &State, s: f64) -> State {
    State {
        nu: std::array::from_fn(|i| x.nu[i] + s * k.nu[i]),
        att: [x.att[0] + s * k.att[0], x.att[1] + s * k.att[1]],
    }
}

/// One RK4 step of length `h` with `tau` held.
pub fn rk4(plant: &Plant, x: &State, tau: &Vec6, h: f64) -> State {
    let k1 = deriv(plant, x, tau);
    let k2 = deriv(plant, &step(x, &k1, h / 2.0), tau);
    let k3 = deriv(plant, &step(x, &k2, h / 2.0), tau);
    let k4 = deriv(plant, &step(x, &k3, h), tau);
    let sum = State {
        nu: std::array::from_fn(|i| k1.nu[i] + 2.0 * k2.nu[i] + 2.0 * k3.nu[i] + k4.nu[i]),
        att: std::array::from_fn(|i| k1.att[i] + 2.0 * k2.att[i] + 2.0 * k3.att[i] + k4.att[i]),
    };
    step(x, &sum, h / 6.0)
}
