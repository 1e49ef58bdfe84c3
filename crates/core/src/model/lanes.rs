//! A population of candidate plants simulated together, one per SIMD lane. The output-error
//! objective (seed 001 eq. 9) simulates every candidate of a population under the same forces
//! on the same time grid, so one pass over a case advances [`LANES`] candidates: the case's
//! samples are read once, and every multiply-add runs on a whole vector of candidates.
//!
//! The arithmetic is [`Plant::accel`] and [`Plant::simulate`]'s (RK4, the force held between
//! samples, steps of at most `max_step`), with two changes that keep the vector units busy and
//! move a trajectory by rounding only (tested against [`Plant::simulate`]): the mass is
//! inverted once per candidate instead of divided by at every stage, and products are fused
//! into multiply-adds. Roll and pitch are skipped when neither is free (a 4-DOF vehicle): they
//! stay at rest, and every term they enter is zero.
//!
//! The mass stays diagonal, but a linear drag may couple two DOFs, one term per DOF (a yaw
//! moment from the sway velocity, N_v; a sway force from the yaw rate, Y_r): so a model with
//! the sway-yaw couplings runs here rather than through the coupled kernel's mass-matrix
//! solve (nine times slower on 16 four-DOF runs).

// Numeric kernels index several arrays with one loop variable; iterators would hide that.
#![allow(clippy::needless_range_loop)]

use super::{Plant, Vec6};

/// Candidates per pass: eight doubles fill an AVX-512 register, or two AVX2 registers (two
/// independent chains, which also hides the latency of each multiply-add).
pub const LANES: usize = 8;

type Lanes = [f64; LANES];

/// The DOFs a kernel integrates: all six, or surge, sway, heave and yaw.
#[inline(always)]
fn dofs<const SIX: bool>() -> &'static [usize] {
    if SIX {
        &[0, 1, 2, 3, 4, 5]
    } else {
        &[0, 1, 2, 5]
    }
}

/// `LANES` plants of one vehicle, coefficients stored DOF by DOF, lane by lane.
#[derive(Debug, Clone)]
pub struct LanePlants {
    /// Diagonal mass M_RB - M_A.
    mass: [Lanes; 6],
    /// 1 / mass where the DOF moves (free, positive mass), 0 where it stays at rest.
    inv_mass: [Lanes; 6],
    lin: [Lanes; 6],
    quad: [Lanes; 6],
    constant: [Lanes; 6],
    /// Linear drag across DOFs, at most one term per DOF: the force in DOF `i` is
    /// `cross[i]` times the velocity in DOF `cross_from[i]` (zero and itself where none).
    cross: [Lanes; 6],
    cross_from: [usize; 6],
    /// Whether any lane has a cross term.
    any_cross: bool,
    /// Whether roll or pitch is free (else the 4-DOF kernel runs).
    six: bool,
    /// Plants in the population: one runs a one-lane kernel, whose lanes past the first hold
    /// no meaning (a single model simulated in every lane would cost a whole population).
    size: usize,
}

/// Floating-point operations of one RK4 step of one candidate, as the kernel executes them (a
/// multiply-add counts two): four accelerations, three stage states and the weighted sum.
pub fn flops_per_step(six: bool) -> usize {
    // Per DOF: the acceleration 6 (two multiply-adds, a difference, a product), a stage
    // state 2 (one multiply-add) three times, the weighted sum 6 (two sums, two multiply-adds).
    if six {
        // Coriolis: momenta 6, three cross products 27, sums 3.
        4 * (36 + 6 * 6) + 3 * 6 * 2 + 6 * 6
    } else {
        // Coriolis: -m_v v r 2, m_u u r 2, (m_v - m_u) u v 3.
        4 * (7 + 4 * 6) + 3 * 4 * 2 + 4 * 6
    }
}

/// Whether the six-DOF kernel is needed for a vehicle free in `active`: roll or pitch is free.
pub fn needs_six_dof(active: &[bool; 6]) -> bool {
    active[3] || active[4]
}

impl LanePlants {
    /// The plants of a population; fewer than [`LANES`] fill the other lanes with the last.
    pub fn new(plants: &[Plant]) -> LanePlants {
        assert!(!plants.is_empty() && plants.len() <= LANES);
        let at = |l: usize| &plants[l.min(plants.len() - 1)];
        let by = |f: &dyn Fn(&Plant, usize) -> f64| -> [Lanes; 6] {
            std::array::from_fn(|i| std::array::from_fn(|l| f(at(l), i)))
        };
        let mass = by(&|p, i| p.mass()[i]);
        let inv_mass = by(&|p, i| {
            let m = p.mass()[i];
            if p.active[i] && m > 0.0 { 1.0 / m } else { 0.0 }
        });
        let cross_from: [usize; 6] = std::array::from_fn(|i| {
            let from =
                (0..6).filter(|&j| j != i && plants.iter().any(|p| p.hydro.lin[i][j] != 0.0));
            let from: Vec<usize> = from.collect();
            assert!(
                from.len() <= 1,
                "the lane kernel takes one cross drag term per DOF"
            );
            from.first().copied().unwrap_or(i)
        });
        LanePlants {
            mass,
            inv_mass,
            cross: by(&|p, i| match cross_from[i] {
                j if j != i => p.hydro.lin[i][j],
                _ => 0.0,
            }),
            any_cross: (0..6).any(|i| cross_from[i] != i),
            cross_from,
            lin: by(&|p, i| p.hydro.lin[i][i]),
            quad: by(&|p, i| p.hydro.quad[i][i][i]),
            constant: by(&|p, i| p.hydro.constant[i]),
            six: needs_six_dof(&plants[0].active),
            size: plants.len(),
        }
    }

    pub fn six_dof(&self) -> bool {
        self.six
    }

    /// Velocities at the sample times `t` for every lane, from `nu0` at `t[0]`, with `tau[k]`
    /// held from `t[k]` to `t[k+1]`: `on_sample(k, nu)` sees each sample's state. Lanes past
    /// the population's size hold no meaning.
    pub fn simulate(
        &self,
        t: &[f64],
        tau: &[Vec6],
        nu0: Vec6,
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: the CPU has just been checked for the features the function uses.
                return unsafe { self.simulate_avx512(t, tau, nu0, max_step, on_sample) };
            }
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: as above.
                return unsafe { self.simulate_avx2(t, tau, nu0, max_step, on_sample) };
            }
        }
        self.simulate_generic(t, tau, nu0, max_step, on_sample)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,fma")]
    fn simulate_avx512(
        &self,
        t: &[f64],
        tau: &[Vec6],
        nu0: Vec6,
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        self.simulate_generic(t, tau, nu0, max_step, on_sample)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn simulate_avx2(
        &self,
        t: &[f64],
        tau: &[Vec6],
        nu0: Vec6,
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        self.simulate_generic(t, tau, nu0, max_step, on_sample)
    }

    #[inline(always)]
    fn simulate_generic(
        &self,
        t: &[f64],
        tau: &[Vec6],
        nu0: Vec6,
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        // Roll and pitch at rest (neither free, neither moving at the start) add nothing; a
        // model without cross drag runs the loop without it.
        let six = self.six || nu0[3] != 0.0 || nu0[4] != 0.0;
        match (six, self.any_cross) {
            (true, false) => self.width::<true, false>(t, tau, nu0, max_step, on_sample),
            (true, true) => self.width::<true, true>(t, tau, nu0, max_step, on_sample),
            (false, false) => self.width::<false, false>(t, tau, nu0, max_step, on_sample),
            (false, true) => self.width::<false, true>(t, tau, nu0, max_step, on_sample),
        }
    }

    /// [`LanePlants::run`] one lane wide for a single plant, else [`LANES`] wide.
    #[inline(always)]
    fn width<const SIX: bool, const CROSS: bool>(
        &self,
        t: &[f64],
        tau: &[Vec6],
        nu0: Vec6,
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        match self.size {
            1 => self.run::<SIX, CROSS, 1>(t, tau, nu0, max_step, on_sample),
            _ => self.run::<SIX, CROSS, LANES>(t, tau, nu0, max_step, on_sample),
        }
    }

    #[inline(always)]
    fn run<const SIX: bool, const CROSS: bool, const L: usize>(
        &self,
        t: &[f64],
        tau: &[Vec6],
        nu0: Vec6,
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        let mut nu: [[f64; L]; 6] = std::array::from_fn(|i| [nu0[i]; L]);
        let mut seen: [Lanes; 6] = std::array::from_fn(|i| [nu0[i]; LANES]);
        for k in 0..t.len() {
            for i in 0..6 {
                seen[i][..L].copy_from_slice(&nu[i]);
            }
            on_sample(k, &seen);
            if k + 1 == t.len() {
                break;
            }
            let span = t[k + 1] - t[k];
            let n = super::dynamics::substeps(span, max_step);
            let h = span / n as f64;
            // The force and constant term are held over the sample: summed once.
            let push: [[f64; L]; 6] =
                std::array::from_fn(|i| std::array::from_fn(|l| tau[k][i] + self.constant[i][l]));
            for _ in 0..n {
                nu = self.rk4::<SIX, CROSS, L>(&nu, &push, h);
            }
        }
    }

    #[inline(always)]
    fn rk4<const SIX: bool, const CROSS: bool, const L: usize>(
        &self,
        nu: &[[f64; L]; 6],
        push: &[[f64; L]; 6],
        h: f64,
    ) -> [[f64; L]; 6] {
        let stage = |k: &[[f64; L]; 6], s: f64| -> [[f64; L]; 6] {
            let mut x = *nu;
            for &i in dofs::<SIX>() {
                for l in 0..L {
                    x[i][l] = k[i][l].mul_add(s, nu[i][l]);
                }
            }
            x
        };
        let k1 = self.accel::<SIX, CROSS, L>(nu, push);
        let k2 = self.accel::<SIX, CROSS, L>(&stage(&k1, 0.5 * h), push);
        let k3 = self.accel::<SIX, CROSS, L>(&stage(&k2, 0.5 * h), push);
        let k4 = self.accel::<SIX, CROSS, L>(&stage(&k3, h), push);
        let w = h / 6.0;
        let mut out = *nu;
        for &i in dofs::<SIX>() {
            for l in 0..L {
                let sum = 2.0f64.mul_add(k2[i][l] + k3[i][l], k1[i][l] + k4[i][l]);
                out[i][l] = sum.mul_add(w, nu[i][l]);
            }
        }
        out
    }

    /// nu_dot of eq. 2 for every lane: (tau + constant - C(nu) nu + D(nu) nu) / m, D's cross
    /// terms linear (read only when `CROSS`).
    #[inline(always)]
    fn accel<const SIX: bool, const CROSS: bool, const L: usize>(
        &self,
        nu: &[[f64; L]; 6],
        push: &[[f64; L]; 6],
    ) -> [[f64; L]; 6] {
        let c = if SIX {
            self.coriolis6(nu)
        } else {
            self.coriolis4(nu)
        };
        let mut a = [[0.0; L]; 6];
        for &i in dofs::<SIX>() {
            let from = &nu[self.cross_from[i]];
            for l in 0..L {
                let x = nu[i][l];
                let drag = self.quad[i][l].mul_add(x.abs(), self.lin[i][l]);
                let f = match CROSS {
                    true => self.cross[i][l].mul_add(from[l], push[i][l] - c[i][l]),
                    false => push[i][l] - c[i][l],
                };
                a[i][l] = drag.mul_add(x, f) * self.inv_mass[i][l];
            }
        }
        a
    }

    /// C(nu) nu of [`super::dynamics::coriolis`] with roll and pitch at rest: X -m_v v r,
    /// Y m_u u r, Z 0, N (m_v - m_u) u v.
    #[inline(always)]
    fn coriolis4<const L: usize>(&self, nu: &[[f64; L]; 6]) -> [[f64; L]; 6] {
        let m = &self.mass;
        let mut c = [[0.0; L]; 6];
        for l in 0..L {
            let (u, v, r) = (nu[0][l], nu[1][l], nu[5][l]);
            c[0][l] = -(r * m[1][l] * v);
            c[1][l] = r * m[0][l] * u;
            c[5][l] = (m[1][l] - m[0][l]) * (u * v);
        }
        c
    }

    /// C(nu) nu of [`super::dynamics::coriolis`] (Kirchhoff form) in all six DOFs.
    #[inline(always)]
    fn coriolis6<const L: usize>(&self, nu: &[[f64; L]; 6]) -> [[f64; L]; 6] {
        let m = &self.mass;
        let mut c = [[0.0; L]; 6];
        for l in 0..L {
            let v1 = [nu[0][l], nu[1][l], nu[2][l]];
            let v2 = [nu[3][l], nu[4][l], nu[5][l]];
            let p1 = [m[0][l] * v1[0], m[1][l] * v1[1], m[2][l] * v1[2]];
            let p2 = [m[3][l] * v2[0], m[4][l] * v2[1], m[5][l] * v2[2]];
            let cross = |a: [f64; 3], b: [f64; 3]| {
                [
                    a[1] * b[2] - a[2] * b[1],
                    a[2] * b[0] - a[0] * b[2],
                    a[0] * b[1] - a[1] * b[0],
                ]
            };
            let (f, a, b) = (cross(v2, p1), cross(v1, p1), cross(v2, p2));
            c[0][l] = f[0];
            c[1][l] = f[1];
            c[2][l] = f[2];
            c[3][l] = a[0] + b[0];
            c[4][l] = a[1] + b[1];
            c[5][l] = a[2] + b[2];
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Hydro, Vehicle};

    /// Plants around the reference vehicle, each coefficient moved by up to +-40 %.
    fn population(vehicle: &Vehicle, n: usize) -> Vec<Plant> {
        let h0 = Hydro::reference();
        (0..n)
            .map(|j| {
                let f = |i: usize, g: usize| {
                    1.0 + 0.4 * (((j * 7 + i * 3 + g) % 11) as f64 / 5.0 - 1.0)
                };
                let mut h = h0;
                for i in 0..6 {
                    h.added[i][i] *= f(i, 0);
                    h.lin[i][i] *= f(i, 1);
                    h.quad[i][i][i] *= f(i, 2);
                    h.constant[i] = 3.0 * (f(i, 3) - 1.0);
                }
                Plant::new(vehicle, h)
            })
            .collect()
    }

    fn check(vehicle: &Vehicle, lanes: usize) {
        check_plants(&population(vehicle, lanes));
    }

    /// Each lane of `plants`, simulated together, against the plant's own simulation.
    fn check_plants(plants: &[Plant]) {
        let t: Vec<f64> = (0..400).map(|k| k as f64 * 0.025).collect();
        let tau: Vec<Vec6> = t
            .iter()
            .map(|&x| {
                let s = (0.7 * x).sin();
                [
                    60.0 * s,
                    25.0 * (1.3 * x).cos(),
                    -30.0 * s,
                    4.0 * s,
                    -3.0 * s,
                    8.0 * (0.9 * x).sin(),
                ]
            })
            .collect();
        let nu0 = [0.2, -0.1, 0.05, 0.0, 0.0, 0.1];
        let lp = LanePlants::new(plants);
        let mut got = vec![[[0.0; LANES]; 6]; t.len()];
        lp.simulate(&t, &tau, nu0, 0.01, &mut |k, nu| got[k] = *nu);
        for (l, p) in plants.iter().enumerate() {
            let want = p.simulate(&t, &tau, nu0, 0.01);
            for k in 0..t.len() {
                for i in 0..6 {
                    let (a, b) = (got[k][i][l], want[k][i]);
                    assert!(
                        (a - b).abs() <= 1e-11 * (1.0 + b.abs()),
                        "lane {l}, sample {k}, DOF {i}: {a} vs {b}"
                    );
                }
            }
            assert!(
                want.last().unwrap().iter().any(|x| x.abs() > 0.05),
                "the plant moves"
            );
        }
    }

    #[test]
    fn every_lane_follows_its_own_plant_in_four_dof() {
        check(&Vehicle::reference(), LANES);
        check(&Vehicle::reference(), 3);
    }

    /// A single plant runs one lane wide, to the bit what it gives beside seven others.
    #[test]
    fn a_single_plant_runs_alone_as_it_runs_in_a_population() {
        let v = Vehicle::reference();
        let plants = population(&v, LANES);
        check_plants(&plants[..1]);
        let t: Vec<f64> = (0..300).map(|k| k as f64 * 0.05).collect();
        let tau: Vec<Vec6> = (t.iter())
            .map(|&x| {
                [
                    40.0 * x.sin(),
                    20.0,
                    -10.0 * x.cos(),
                    0.0,
                    0.0,
                    6.0 * x.sin(),
                ]
            })
            .collect();
        let run = |lp: &LanePlants| {
            let mut out = Vec::new();
            lp.simulate(
                &t,
                &tau,
                [0.1, 0.0, 0.0, 0.0, 0.0, 0.0],
                0.02,
                &mut |_, nu| out.push(std::array::from_fn::<f64, 6, _>(|i| nu[i][0])),
            );
            out
        };
        assert_eq!(
            run(&LanePlants::new(&plants[..1])),
            run(&LanePlants::new(&plants))
        );
    }

    /// A sway-yaw linear coupling (N_v, Y_r) runs in the lane kernel as the plant's own
    /// coupled solve runs it.
    #[test]
    fn every_lane_follows_its_own_plant_with_cross_drag() {
        let v = Vehicle::reference();
        let plants: Vec<Plant> = (population(&v, LANES).into_iter().enumerate())
            .map(|(l, p)| {
                let mut h = p.hydro;
                h.lin[5][1] = 0.5 + 0.3 * l as f64;
                h.lin[1][5] = if l % 2 == 0 { -2.0 } else { 0.0 };
                Plant::new(&v, h)
            })
            .collect();
        assert!(plants[0].is_coupled(), "the reference simulates it coupled");
        assert!(LanePlants::new(&plants).any_cross);
        check_plants(&plants);
    }

    #[test]
    fn every_lane_follows_its_own_plant_in_six_dof() {
        let mut v = Vehicle::reference();
        v.dofs = crate::dof::Dof::ALL.to_vec();
        v.inertia_kg_m2.xx = 1.2;
        v.inertia_kg_m2.yy = 1.5;
        assert!(LanePlants::new(&population(&v, 1)).six_dof());
        check(&v, LANES);
    }
}
