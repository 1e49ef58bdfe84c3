//! Vehicle dynamics about the centre of gravity (seed 001 eq. 1-7; Fossen 2011, eq. 6.43-6.46)
//! and a fixed-step RK4 simulator driven by a sampled force history.

use super::{Hydro, Vehicle};

pub type Vec6 = [f64; 6];

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// C(nu) nu for a diagonal mass matrix `m` (Kirchhoff form, Fossen eq. 6.43):
/// with momenta p1 = M11 nu1 and p2 = M22 nu2, C nu = [nu2 x p1; nu1 x p1 + nu2 x p2].
/// With M_RB this is seed 001 eq. 6; with M_A = -diag(X_udot ..) it is eq. 7.
pub fn coriolis(m: &Vec6, nu: &Vec6) -> Vec6 {
    let v1 = [nu[0], nu[1], nu[2]];
    let v2 = [nu[3], nu[4], nu[5]];
    let p1 = [m[0] * nu[0], m[1] * nu[1], m[2] * nu[2]];
    let p2 = [m[3] * nu[3], m[4] * nu[4], m[5] * nu[5]];
    let f = cross(v2, p1);
    let a = cross(v1, p1);
    let b = cross(v2, p2);
    [f[0], f[1], f[2], a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// The hydrodynamic side of eq. 2: M_A nu_dot + C_A(nu) nu + D(nu) nu, less the constant
/// generalised force (which acts with the thrust, so it enters this side negated).
/// Linear in the coefficients of `h`, which is what makes the equation-error fit a regression.
pub fn hydro_force(h: &Hydro, nu: &Vec6, nu_dot: &Vec6) -> Vec6 {
    let neg_added = h.added.map(|a| -a);
    let c = coriolis(&neg_added, nu);
    std::array::from_fn(|i| {
        -h.added[i] * nu_dot[i] + c[i]
            - (h.lin[i] + h.quad[i] * nu[i].abs()) * nu[i]
            - h.constant[i]
    })
}

/// Integration steps over a sample interval `span` with steps of at most `max_step` (at least
/// one): every simulator here holds the input over a sample and divides it evenly.
pub fn substeps(span: f64, max_step: f64) -> usize {
    (span / max_step).ceil().max(1.0) as usize
}

/// A vehicle with known rigid-body properties and a hydrodynamic model.
#[derive(Debug, Clone)]
pub struct Plant {
    pub mrb: Vec6,
    pub hydro: Hydro,
    pub active: [bool; 6],
    /// M_RB - M_A on the diagonal, formed once (the simulators ask for the acceleration
    /// millions of times). A plant is built by [`Plant::new`] and not changed afterwards.
    mass: Vec6,
}

impl Plant {
    pub fn new(vehicle: &Vehicle, hydro: Hydro) -> Plant {
        let mrb = vehicle.rigid_mass();
        Plant {
            mrb,
            mass: std::array::from_fn(|i| mrb[i] - hydro.added[i]),
            hydro,
            active: vehicle.active(),
        }
    }

    /// The diagonal of M_RB - M_A.
    pub fn mass(&self) -> &Vec6 {
        &self.mass
    }

    /// The rigid-body side that does not depend on the unknowns: M_RB nu_dot + C_RB(nu) nu.
    pub fn rigid_force(&self, nu: &Vec6, nu_dot: &Vec6) -> Vec6 {
        let c = coriolis(&self.mrb, nu);
        std::array::from_fn(|i| self.mrb[i] * nu_dot[i] + c[i])
    }

    /// nu_dot from eq. 2 solved for the acceleration; inactive DOFs stay at rest.
    pub fn accel(&self, nu: &Vec6, tau: &Vec6) -> Vec6 {
        let m = &self.mass;
        let c = coriolis(m, nu);
        std::array::from_fn(|i| {
            if !self.active[i] || m[i] <= 0.0 {
                return 0.0;
            }
            let drag = (self.hydro.lin[i] + self.hydro.quad[i] * nu[i].abs()) * nu[i];
            (tau[i] + self.hydro.constant[i] - c[i] + drag) / m[i]
        })
    }

    fn rk4(&self, nu: &Vec6, tau: &Vec6, h: f64) -> Vec6 {
        let add = |a: &Vec6, k: &Vec6, s: f64| -> Vec6 { std::array::from_fn(|i| a[i] + s * k[i]) };
        let k1 = self.accel(nu, tau);
        let k2 = self.accel(&add(nu, &k1, h / 2.0), tau);
        let k3 = self.accel(&add(nu, &k2, h / 2.0), tau);
        let k4 = self.accel(&add(nu, &k3, h), tau);
        std::array::from_fn(|i| nu[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
    }

    /// Velocities at the sample times `t`, starting from `nu0` at `t[0]`, with `tau[k]` held
    /// from `t[k]` to `t[k+1]` (zero-order hold, as a logged command is applied).
    /// Steps are at most `max_step` long: RK4 with h = 0.01 s is stable for the drag of a
    /// ~1 m vehicle at a few m/s (h * d(drag)/d(nu) / m stays far below RK4's limit of ~2.8).
    pub fn simulate(&self, t: &[f64], tau: &[Vec6], nu0: Vec6, max_step: f64) -> Vec<Vec6> {
        let mut out = Vec::with_capacity(t.len());
        let mut nu = nu0;
        for k in 0..t.len() {
            out.push(nu);
            if k + 1 == t.len() {
                break;
            }
            let span = t[k + 1] - t[k];
            let n = substeps(span, max_step);
            let h = span / n as f64;
            for _ in 0..n {
                nu = self.rk4(&nu, &tau[k], h);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Vehicle;

    #[test]
    fn coriolis_matches_seed_001_eq_6_7() {
        // 4-DOF horizontal motion: X row -m v r + Y_vdot v r, Y row m u r - X_udot u r,
        // N row (X_udot - Y_vdot) u v (the Munk moment; C_RB contributes nothing to N).
        let v = Vehicle::reference();
        let h = Hydro::reference();
        let p = Plant::new(&v, h);
        let nu = [0.7, -0.3, 0.0, 0.0, 0.0, 0.4];
        let zero = [0.0; 6];
        let total = {
            let r = p.rigid_force(&nu, &zero);
            let a = hydro_force(
                &Hydro {
                    lin: [0.0; 6],
                    quad: [0.0; 6],
                    ..h
                },
                &nu,
                &zero,
            );
            std::array::from_fn::<f64, 6, _>(|i| r[i] + a[i])
        };
        let m = 35.2;
        let (u, vv, r) = (nu[0], nu[1], nu[5]);
        assert!((total[0] - (-m * vv * r + h.added[1] * vv * r)).abs() < 1e-12);
        assert!((total[1] - (m * u * r - h.added[0] * u * r)).abs() < 1e-12);
        assert!((total[5] - (h.added[0] - h.added[1]) * u * vv).abs() < 1e-12);
    }

    #[test]
    fn surge_reaches_closed_form_terminal_speed() {
        // Under a constant force F, X_u u + X_uu u^2 = -F at steady state.
        let v = Vehicle::reference();
        let h = Hydro::reference();
        let p = Plant::new(&v, h);
        let f = 100.0;
        let t: Vec<f64> = (0..3000).map(|k| k as f64 * 0.02).collect();
        let tau = vec![[f, 0.0, 0.0, 0.0, 0.0, 0.0]; t.len()];
        let nu = p.simulate(&t, &tau, [0.0; 6], 0.01);
        let (a, b) = (-h.quad[0], -h.lin[0]);
        let u_ss = (-b + (b * b + 4.0 * a * f).sqrt()) / (2.0 * a);
        assert!(
            (nu.last().unwrap()[0] - u_ss).abs() < 1e-6,
            "{} vs {u_ss}",
            nu.last().unwrap()[0]
        );
        assert!(nu.iter().all(|n| n[1] == 0.0 && n[5] == 0.0));
    }
}
