//! A coupled model's state: body velocities and the roll and pitch that turn its buoyancy
//! (Fossen 2011 eq. 2.29 for the Euler-angle rates; yaw does not enter the dynamics).

use super::Plant;
use super::dynamics::{Vec6, gravity_body, substeps};

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

// The simulation lives with the state it carries: a coupled model turns its buoyancy with
// its roll and pitch.
impl Plant {
    /// Velocities at the sample times `t`, starting from `nu0` at `t[0]` at level trim, with
    /// `tau[k]` held from `t[k]` to `t[k+1]` (zero-order hold, as a logged command is applied).
    /// Steps are at most `max_step` long: RK4 with h = 0.01 s is stable for the drag of a
    /// ~1 m vehicle at a few m/s (h * d(drag)/d(nu) / m stays far below RK4's limit of ~2.8).
    pub fn simulate(&self, t: &[f64], tau: &[Vec6], nu0: Vec6, max_step: f64) -> Vec<Vec6> {
        self.simulate_from(t, tau, nu0, [0.0; 2], max_step)
    }

    /// [`Plant::simulate`] from roll and pitch `att0` (rad): a coupled model carries its
    /// attitude along, since the buoyancy's moment turns with it.
    pub fn simulate_from(
        &self,
        t: &[f64],
        tau: &[Vec6],
        nu0: Vec6,
        att0: [f64; 2],
        max_step: f64,
    ) -> Vec<Vec6> {
        let mut out = Vec::with_capacity(t.len());
        let mut x = State { nu: nu0, att: att0 };
        for k in 0..t.len() {
            out.push(x.nu);
            if k + 1 == t.len() {
                break;
            }
            let span = t[k + 1] - t[k];
            let n = substeps(span, max_step);
            let h = span / n as f64;
            for _ in 0..n {
                x = match self.is_coupled() {
                    true => rk4(self, &x, &tau[k], h),
                    false => State {
                        nu: self.rk4(&x.nu, &tau[k], h),
                        att: x.att,
                    },
                };
            }
        }
        out
    }
}
