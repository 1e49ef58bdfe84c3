//! Vehicle dynamics about the centre of gravity (seed 001 eq. 1-7; Fossen 2011, eq. 6.43-6.46)
//! and a fixed-step RK4 simulator driven by a sampled force history.

use super::{Hydro, Mat6, Term, Vehicle};

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
    kirchhoff(&std::array::from_fn(|i| m[i] * nu[i]), nu)
}

/// C(nu) nu for a full symmetric mass matrix (seed 003 eq. 3): the same Kirchhoff form with
/// the momenta p = M nu.
pub fn coriolis_full(m: &Mat6, nu: &Vec6) -> Vec6 {
    kirchhoff(&std::array::from_fn(|i| dot(&m[i], nu)), nu)
}

fn dot(a: &Vec6, b: &Vec6) -> f64 {
    (0..6).map(|i| a[i] * b[i]).sum()
}

fn kirchhoff(p: &Vec6, nu: &Vec6) -> Vec6 {
    let v1 = [nu[0], nu[1], nu[2]];
    let v2 = [nu[3], nu[4], nu[5]];
    let p1 = [p[0], p[1], p[2]];
    let p2 = [p[3], p[4], p[5]];
    let f = cross(v2, p1);
    let a = cross(v1, p1);
    let b = cross(v2, p2);
    [f[0], f[1], f[2], a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// The unit gravity vector in the body frame at roll `phi` and pitch `theta` (z down).
pub fn gravity_body(phi: f64, theta: f64) -> [f64; 3] {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    [-st, ct * sp, ct * cp]
}

/// Level trim: gravity along body z.
pub const LEVEL: [f64; 3] = [0.0, 0.0, 1.0];

/// The generalised force of the drag, constant and buoyancy terms of `h` on the body (the
/// side of the thrust): `lin nu + sum_k |nu_k| quad_k nu + constant + [(W-B) g; eta x g]`.
pub fn applied_hydro(h: &Hydro, nu: &Vec6, g: &[f64; 3]) -> Vec6 {
    let m = cross(h.moment, *g);
    std::array::from_fn(|i| {
        let mut f = dot(&h.lin[i], nu) + h.constant[i];
        for (k, q) in h.quad.iter().enumerate() {
            if nu[k] != 0.0 {
                f += nu[k].abs() * dot(&q[i], nu);
            }
        }
        f + if i < 3 { h.net_weight * g[i] } else { m[i - 3] }
    })
}

/// The hydrodynamic side of eq. 2: M_A nu_dot + C_A(nu) nu + D(nu) nu, less the constant
/// generalised force and the buoyancy (which act with the thrust, so they enter this side
/// negated), at level trim. Linear in the coefficients of `h`, which is what makes the
/// equation-error fit a regression.
pub fn hydro_force(h: &Hydro, nu: &Vec6, nu_dot: &Vec6) -> Vec6 {
    hydro_force_at(h, nu, nu_dot, &LEVEL)
}

/// [`hydro_force`] with gravity along `g` in the body frame.
pub fn hydro_force_at(h: &Hydro, nu: &Vec6, nu_dot: &Vec6, g: &[f64; 3]) -> Vec6 {
    let neg_added = h.added.map(|r| r.map(|a| -a));
    let c = coriolis_full(&neg_added, nu);
    let applied = applied_hydro(h, nu, g);
    std::array::from_fn(|i| -dot(&h.added[i], nu_dot) + c[i] - applied[i])
}

/// The column of one term in the regression: [`hydro_force_at`] of a model whose only
/// coefficient is that term, at 1 (the force is linear in every term); for a component of
/// r_g, the moment it takes off the logged force `tau` ([`Hydro::thrust_about_cg`]), which
/// the regression's left side carries negated as it carries the constants.
pub fn term_column(t: Term, nu: &Vec6, nu_dot: &Vec6, g: &[f64; 3], tau: &Vec6) -> Vec6 {
    let mut out = [0.0; 6];
    match t {
        Term::Added(i, j) => {
            let mut e = [[0.0; 6]; 6];
            e[i][j] = -1.0;
            e[j][i] = -1.0;
            out = coriolis_full(&e, nu);
            out[i] -= nu_dot[j];
            if i != j {
                out[j] -= nu_dot[i];
            }
        }
        Term::Linear(i, j) => out[i] = -nu[j],
        Term::Quadratic { row, vel, by } => out[row] = -nu[vel] * nu[by].abs(),
        Term::Constant(i) => out[i] = -1.0,
        Term::NetWeight => (0..3).for_each(|i| out[i] = -g[i]),
        Term::Moment(a) => {
            let mut e = [0.0; 3];
            e[a] = 1.0;
            let m = cross(e, *g);
            (0..3).for_each(|i| out[3 + i] = -m[i]);
        }
        Term::Lever(a) => {
            let mut unit = [0.0; 3];
            unit[a] = 1.0;
            let arm = super::params::lever_moment(unit, [tau[0], tau[1], tau[2]]);
            out[3..].copy_from_slice(&arm);
        }
    }
    out
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
    /// The coefficients the plant was built with; to change them, build a new plant (the
    /// simulators read copies formed by [`Plant::new`]).
    pub hydro: Hydro,
    pub active: [bool; 6],
    /// M_RB - M_A on the diagonal, formed once (the simulators ask for the acceleration
    /// millions of times). A plant is built by [`Plant::new`] and not changed afterwards.
    mass: Vec6,
    /// The diagonal linear and quadratic drag, side by side for the hot loop (the matrices of
    /// `hydro` put them hundreds of bytes apart).
    drag: [Vec6; 2],
    /// The inverse of the full M_RB - M_A over the active DOFs, for a coupled model; `None`
    /// for a diagonal one, whose accelerations are divisions.
    coupled: Option<Box<Coupled>>,
    /// Why the mass matrix cannot be inverted, when it cannot.
    mass_problem: Option<String>,
    /// The first-order lag (s) between a logged command and the force the thrusters give
    /// (0: none), identified with the model from pool runs; applied to a run's logged command
    /// before it is simulated (see [`lagged`]).
    pub command_lag_s: f64,
    /// The force per unit of logged command (1: the command is the force), identified against
    /// CFD cases (`thrust_gain: fit`); applied with the lag (see [`Plant::command`]).
    pub command_gain: f64,
}

impl Plant {
    pub fn new(vehicle: &Vehicle, hydro: Hydro) -> Plant {
        let mrb = vehicle.rigid_mass();
        let active = vehicle.active();
        let mass: Vec6 = std::array::from_fn(|i| mrb[i] - hydro.added[i][i]);
        let (coupled, mass_problem) = match hydro.is_diagonal() {
            true => (None, diagonal_mass_problem(&mass, &active)),
            false => {
                let total = total_mass(&mrb, &hydro, &active);
                let (inverse, problem) = match super::spd::inverse(&total, &active) {
                    Ok(inv) => (inv, None),
                    Err(e) => ([[0.0; 6]; 6], Some(e)),
                };
                (Some(Box::new(Coupled { total, inverse })), problem)
            }
        };
        Plant {
            mrb,
            mass,
            drag: [hydro.lin_diag(), hydro.quad_diag()],
            hydro,
            active,
            coupled,
            mass_problem,
            command_lag_s: 0.0,
            command_gain: 1.0,
        }
    }

    /// The force a run's logged command `tau` (at times `t`) gives this model's vehicle:
    /// through its command lag, times its command gain, its moments taken about the centre
    /// of gravity ([`Hydro::thrust_about_cg`]).
    pub fn command(&self, t: &[f64], tau: &[Vec6]) -> Vec<Vec6> {
        let mut out = lagged(t, tau, self.command_lag_s);
        for x in &mut out {
            if self.command_gain != 1.0 {
                x.iter_mut().for_each(|f| *f *= self.command_gain);
            }
            *x = self.hydro.thrust_about_cg(x);
        }
        out
    }

    /// Whether [`Plant::command`] changes a logged command: a lag, a gain or a lever.
    pub fn shapes_command(&self) -> bool {
        let lag = !(self.command_lag_s.is_nan() || self.command_lag_s <= 0.0);
        lag || self.command_gain != 1.0 || self.hydro.lever != [0.0; 3]
    }

    /// The diagonal of M_RB - M_A.
    pub fn mass(&self) -> &Vec6 {
        &self.mass
    }

    /// The mass matrix M_RB - M_A and its inverse over the free DOFs (zero rows and columns
    /// elsewhere, and a zero inverse when the matrix is not positive definite).
    pub fn mass_matrix(&self) -> (Mat6, Mat6) {
        match &self.coupled {
            Some(c) => (c.total, c.inverse),
            None => {
                let m = &self.mass;
                let on = |i: usize| self.active[i] && m[i] > 0.0;
                let diag = |f: &dyn Fn(usize) -> f64| -> Mat6 {
                    std::array::from_fn(|i| {
                        std::array::from_fn(|j| if i == j && on(i) { f(i) } else { 0.0 })
                    })
                };
                (diag(&|i| m[i]), diag(&|i| 1.0 / m[i]))
            }
        }
    }

    /// Whether the model couples DOFs (and needs the full mass matrix and the attitude).
    pub fn is_coupled(&self) -> bool {
        self.coupled.is_some()
    }

    /// Why this model cannot be simulated: a mass matrix M_RB - M_A that is not positive
    /// definite over the vehicle's DOFs (negative or zero inertia in some direction).
    pub fn mass_problem(&self) -> Option<&str> {
        self.mass_problem.as_deref()
    }

    /// The rigid-body side that does not depend on the unknowns: M_RB nu_dot + C_RB(nu) nu.
    pub fn rigid_force(&self, nu: &Vec6, nu_dot: &Vec6) -> Vec6 {
        let c = coriolis(&self.mrb, nu);
        std::array::from_fn(|i| self.mrb[i] * nu_dot[i] + c[i])
    }

    /// nu_dot from eq. 2 solved for the acceleration at level trim; inactive DOFs stay at rest.
    pub fn accel(&self, nu: &Vec6, tau: &Vec6) -> Vec6 {
        match &self.coupled {
            Some(c) => self.accel_coupled(c, nu, tau, &LEVEL),
            None => self.accel_diagonal(nu, tau),
        }
    }

    /// nu_dot with gravity along `g` in the body frame (it matters only to the buoyancy).
    pub fn accel_at(&self, nu: &Vec6, tau: &Vec6, g: &[f64; 3]) -> Vec6 {
        match &self.coupled {
            Some(c) => self.accel_coupled(c, nu, tau, g),
            None => self.accel_diagonal(nu, tau),
        }
    }

    /// The diagonal linear plus quadratic drag force in DOF `i` at velocity `x`.
    #[inline]
    pub fn diagonal_drag(&self, i: usize, x: f64) -> f64 {
        (self.drag[0][i] + self.drag[1][i] * x.abs()) * x
    }

    /// The diagonal model's acceleration: divisions, no matrix (gravity does not enter it).
    #[inline(always)]
    fn accel_diagonal(&self, nu: &Vec6, tau: &Vec6) -> Vec6 {
        let m = &self.mass;
        let c = coriolis(m, nu);
        let [lin, quad] = &self.drag;
        let constant = &self.hydro.constant;
        std::array::from_fn(|i| {
            if !self.active[i] || m[i] <= 0.0 {
                return 0.0;
            }
            let drag = (lin[i] + quad[i] * nu[i].abs()) * nu[i];
            (tau[i] + constant[i] - c[i] + drag) / m[i]
        })
    }

    fn accel_coupled(&self, m: &Coupled, nu: &Vec6, tau: &Vec6, g: &[f64; 3]) -> Vec6 {
        let c = coriolis_full(&m.total, nu);
        let applied = applied_hydro(&self.hydro, nu, g);
        let rhs: Vec6 = std::array::from_fn(|i| {
            if self.active[i] {
                tau[i] + applied[i] - c[i]
            } else {
                0.0
            }
        });
        std::array::from_fn(|i| dot(&m.inverse[i], &rhs))
    }

    /// One RK4 step of length `h` at level trim with `tau` held.
    pub(super) fn rk4(&self, nu: &Vec6, tau: &Vec6, h: f64) -> Vec6 {
        let add = |a: &Vec6, k: &Vec6, s: f64| -> Vec6 { std::array::from_fn(|i| a[i] + s * k[i]) };
        let k1 = self.accel(nu, tau);
        let k2 = self.accel(&add(nu, &k1, h / 2.0), tau);
        let k3 = self.accel(&add(nu, &k2, h / 2.0), tau);
        let k4 = self.accel(&add(nu, &k3, h), tau);
        std::array::from_fn(|i| nu[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
    }
}

/// The full mass matrix of a coupled model and its inverse (over the active DOFs).
#[derive(Debug, Clone)]
struct Coupled {
    total: Mat6,
    inverse: Mat6,
}

/// M_RB - M_A over the active DOFs (inactive rows and columns zero).
fn total_mass(mrb: &Vec6, h: &Hydro, active: &[bool; 6]) -> Mat6 {
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            if !(active[i] && active[j]) {
                return 0.0;
            }
            f64::from(u8::from(i == j)) * mrb[i] - h.added[i][j]
        })
    })
}

fn diagonal_mass_problem(m: &Vec6, active: &[bool; 6]) -> Option<String> {
    let bad: Vec<String> = (0..6)
        .filter(|&i| active[i] && m[i] <= 0.0)
        .map(|i| format!("{} ({:.4})", crate::dof::Dof::ALL[i], m[i]))
        .collect();
    (!bad.is_empty()).then(|| {
        format!(
            "the mass matrix M_RB - M_A is not positive definite: its diagonal is not positive in {}",
            bad.join(", ")
        )
    })
}

/// The command as a first-order lag of time constant `lag_s` passes it on: per sample
/// interval, the mean of the lag's output while the logged command `tau[k]` is held from
/// `t[k]` to `t[k+1]` (exact for a zero-order-held command). The lag starts at the first
/// command, as a vehicle at rest with its thrusters settled.
pub fn lagged(t: &[f64], tau: &[Vec6], lag_s: f64) -> Vec<Vec6> {
    if lag_s.is_nan() || lag_s <= 0.0 || tau.is_empty() {
        return tau.to_vec();
    }
    let mut u = tau[0];
    let mut out = Vec::with_capacity(tau.len());
    for k in 0..tau.len() {
        let dt = if k + 1 < t.len() {
            t[k + 1] - t[k]
        } else {
            0.0
        };
        let e = (-dt / lag_s).exp();
        // The mean over the interval of tau + (u - tau) exp(-s / T).
        let mean_factor = if dt > 0.0 {
            lag_s / dt * (1.0 - e)
        } else {
            1.0
        };
        out.push(std::array::from_fn(|i| {
            tau[k][i] + (u[i] - tau[k][i]) * mean_factor
        }));
        u = std::array::from_fn(|i| tau[k][i] + (u[i] - tau[k][i]) * e);
    }
    out
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
                    lin: Default::default(),
                    quad: Default::default(),
                    ..h
                },
                &nu,
                &zero,
            );
            std::array::from_fn::<f64, 6, _>(|i| r[i] + a[i])
        };
        let m = 35.2;
        let (u, vv, r) = (nu[0], nu[1], nu[5]);
        assert!((total[0] - (-m * vv * r + h.added[1][1] * vv * r)).abs() < 1e-12);
        assert!((total[1] - (m * u * r - h.added[0][0] * u * r)).abs() < 1e-12);
        assert!((total[5] - (h.added[0][0] - h.added[1][1]) * u * vv).abs() < 1e-12);
    }

    #[test]
    fn the_diagonal_model_is_the_coupled_one_without_couplings() {
        // A coupling of 1e-200 sends the plant down the coupled path (full mass matrix,
        // Kirchhoff Coriolis, attitude) without changing any number that matters: the two
        // paths must give the same accelerations and trajectories.
        let mut v = Vehicle::reference();
        v.dofs = crate::dof::Dof::ALL.to_vec();
        v.inertia_kg_m2.xx = 0.9;
        v.inertia_kg_m2.yy = 1.1;
        let mut h = Hydro::reference();
        for i in [3, 4] {
            h.added[i][i] = -0.3;
            h.lin[i][i] = -2.0;
            h.quad[i][i][i] = -1.5;
        }
        let diag = Plant::new(&v, h);
        h.quad[0][1][5] = 1e-200;
        let coupled = Plant::new(&v, h);
        assert!(!diag.is_coupled() && coupled.is_coupled());
        let nu = [0.7, -0.3, 0.2, 0.1, -0.2, 0.4];
        let tau = [40.0, -10.0, 5.0, 1.0, -2.0, 3.0];
        let (a, b) = (diag.accel(&nu, &tau), coupled.accel(&nu, &tau));
        for i in 0..6 {
            assert!(
                (a[i] - b[i]).abs() < 1e-12 * (1.0 + a[i].abs()),
                "{i}: {} vs {}",
                a[i],
                b[i]
            );
        }
        let t: Vec<f64> = (0..200).map(|k| k as f64 * 0.05).collect();
        let taus = vec![tau; t.len()];
        let (x, y) = (
            diag.simulate(&t, &taus, nu, 0.01),
            coupled.simulate(&t, &taus, nu, 0.01),
        );
        let worst = x
            .iter()
            .zip(&y)
            .flat_map(|(p, q)| (0..6).map(move |i| (p[i] - q[i]).abs()));
        assert!(worst.fold(0.0, f64::max) < 1e-9);
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
        let (a, b) = (-h.quad[0][0][0], -h.lin[0][0]);
        let u_ss = (-b + (b * b + 4.0 * a * f).sqrt()) / (2.0 * a);
        assert!(
            (nu.last().unwrap()[0] - u_ss).abs() < 1e-6,
            "{} vs {u_ss}",
            nu.last().unwrap()[0]
        );
        assert!(nu.iter().all(|n| n[1] == 0.0 && n[5] == 0.0));
    }
}
