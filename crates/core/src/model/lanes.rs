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
//! The mass stays diagonal, but a linear drag may couple two DOFs, up to two terms per DOF
//! (a yaw moment from the sway velocity, N_v; a sway force from the yaw rate, Y_r; a pitch
//! moment from surge and from heave, M_u and M_w): so a model with such couplings runs here
//! rather than through the coupled kernel's mass-matrix solve (nine times slower on 16
//! four-DOF runs; a six-DOF BlueROV2 Heavy fit with M_u and M_w took 62 s there, 16 s here).
//!
//! Weight and buoyancy (the net weight and the moment of buoyancy about the centre of gravity,
//! seed 003 eq. 8) run here too: the gravity direction in the body frame is carried as three
//! more states, integrated as g' = g x omega as [`super::lanes_coupled`] does. A six-DOF model
//! of a vehicle that rolls and pitches thus runs here, not through the coupled kernel's
//! full matrices (five to seven times slower per step: `hydrofit bench --objective six-dof`,
//! 59-92 ns against 12 ns per candidate).

// Numeric kernels index several arrays with one loop variable; iterators would hide that.
#![allow(clippy::needless_range_loop)]

use super::params::MAX_CROSS;
use super::{Plant, Vec6};

/// Candidates per pass: eight doubles fill an AVX-512 register, or two AVX2 registers (two
/// independent chains, which also hides the latency of each multiply-add).
pub const LANES: usize = 8;

type Lanes = [f64; LANES];

/// A simulation's inputs: sample times, forces, start (velocities, roll and pitch), longest
/// step and the callback of each sample.
type Go<'a, 'b> = (
    &'a [f64],
    &'a [Vec6],
    (Vec6, [f64; 2]),
    f64,
    &'b mut dyn FnMut(usize, &[Lanes; 6]),
);

/// A kernel's state per lane: the six body velocities, then, where the model has weight and
/// buoyancy (`N` = [`WITH_ATTITUDE`]), the gravity direction in the body frame. A model
/// without them carries six states, so its loop is the same as before they were added.
type State<const L: usize, const N: usize> = [[f64; L]; N];

/// The number of states with the gravity direction.
const WITH_ATTITUDE: usize = 9;

/// The states a kernel integrates: all six DOFs, or surge, sway, heave and yaw; with the
/// attitude (always six DOFs) the gravity direction as well.
#[inline(always)]
fn states<const SIX: bool, const N: usize>() -> &'static [usize] {
    match (SIX, N == WITH_ATTITUDE) {
        (_, true) => &[0, 1, 2, 3, 4, 5, 6, 7, 8],
        (true, false) => &[0, 1, 2, 3, 4, 5],
        (false, false) => &[0, 1, 2, 5],
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
    /// Linear drag across DOFs, at most [`MAX_CROSS`] terms per DOF: the force in DOF `i`
    /// is `cross[i][c]` times the velocity in DOF `cross_from[i][c]` (zero and itself where
    /// none).
    cross: [[Lanes; MAX_CROSS]; 6],
    cross_from: [[usize; MAX_CROSS]; 6],
    /// The most cross terms of any DOF (the kernel reads that many per DOF).
    crosses: usize,
    /// The net weight W - B along the gravity direction, and the moment of buoyancy r_B B
    /// (crossed with it), as in [`super::dynamics`].
    net_weight: Lanes,
    moment: [Lanes; 3],
    /// The centre of gravity from the point the logged moments are about ([`held`]).
    lever: [Lanes; 3],
    /// Whether any lane has weight and buoyancy.
    att: bool,
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

/// Per lane, the logged force `tau` held over a sample as it acts about the lane's centre of
/// gravity ([`super::Hydro::thrust_about_cg`], the moment less `lever x F`), plus the lane's
/// constant force.
pub(super) fn held<const L: usize>(
    tau: &Vec6,
    constant: &[Lanes; 6],
    lever: &[Lanes; 3],
) -> [[f64; L]; 6] {
    let f = [tau[0], tau[1], tau[2]];
    let arms: [[f64; 3]; L] = std::array::from_fn(|l| {
        super::params::lever_moment([lever[0][l], lever[1][l], lever[2][l]], f)
    });
    std::array::from_fn(|i| {
        std::array::from_fn(|l| {
            let arm = if i < 3 { 0.0 } else { arms[l][i - 3] };
            tau[i] + constant[i][l] - arm
        })
    })
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
        let from: [Vec<usize>; 6] = std::array::from_fn(|i| {
            let from =
                (0..6).filter(|&j| j != i && plants.iter().any(|p| p.hydro.lin[i][j] != 0.0));
            let from: Vec<usize> = from.collect();
            assert!(
                from.len() <= MAX_CROSS,
                "the lane kernel takes {MAX_CROSS} cross drag terms per DOF"
            );
            from
        });
        let cross_from: [[usize; MAX_CROSS]; 6] =
            std::array::from_fn(|i| std::array::from_fn(|c| from[i].get(c).copied().unwrap_or(i)));
        LanePlants {
            mass,
            inv_mass,
            cross: std::array::from_fn(|i| {
                std::array::from_fn(|c| match cross_from[i][c] {
                    j if j != i => std::array::from_fn(|l| at(l).hydro.lin[i][j]),
                    _ => [0.0; LANES],
                })
            }),
            crosses: from.iter().map(Vec::len).max().unwrap_or(0),
            cross_from,
            lin: by(&|p, i| p.hydro.lin[i][i]),
            quad: by(&|p, i| p.hydro.quad[i][i][i]),
            constant: by(&|p, i| p.hydro.constant[i]),
            net_weight: std::array::from_fn(|l| at(l).hydro.net_weight),
            moment: std::array::from_fn(|a| std::array::from_fn(|l| at(l).hydro.moment[a])),
            lever: std::array::from_fn(|a| std::array::from_fn(|l| at(l).hydro.lever[a])),
            att: plants
                .iter()
                .any(|p| p.hydro.net_weight != 0.0 || p.hydro.moment != [0.0; 3]),
            six: needs_six_dof(&plants[0].active),
            size: plants.len(),
        }
    }

    pub fn six_dof(&self) -> bool {
        self.six
    }

    /// Velocities at the sample times `t` for every lane, from `nu0` and roll and pitch `att0`
    /// at `t[0]` (the attitude matters only with weight and buoyancy), with `tau[k]` held from
    /// `t[k]` to `t[k+1]`: `on_sample(k, nu)` sees each sample's state. Lanes past the
    /// population's size hold no meaning.
    pub fn simulate(
        &self,
        t: &[f64],
        tau: &[Vec6],
        start: (Vec6, [f64; 2]),
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: the CPU has just been checked for the features the function uses.
                return unsafe { self.simulate_avx512(t, tau, start, max_step, on_sample) };
            }
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: as above.
                return unsafe { self.simulate_avx2(t, tau, start, max_step, on_sample) };
            }
        }
        self.simulate_generic(t, tau, start, max_step, on_sample)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,fma")]
    fn simulate_avx512(
        &self,
        t: &[f64],
        tau: &[Vec6],
        start: (Vec6, [f64; 2]),
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        self.simulate_generic(t, tau, start, max_step, on_sample)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn simulate_avx2(
        &self,
        t: &[f64],
        tau: &[Vec6],
        start: (Vec6, [f64; 2]),
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        self.simulate_generic(t, tau, start, max_step, on_sample)
    }

    #[inline(always)]
    fn simulate_generic(
        &self,
        t: &[f64],
        tau: &[Vec6],
        start: (Vec6, [f64; 2]),
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        // Roll and pitch at rest (neither free, neither moving at the start) add nothing; a
        // model runs the loop with as many cross drag terms as its DOFs have, and without the
        // attitude where it has no weight and buoyancy (with them, it needs all six DOFs).
        let nu0 = start.0;
        let six = self.six || nu0[3] != 0.0 || nu0[4] != 0.0 || self.att;
        let go = (t, tau, start, max_step, on_sample);
        match (six, self.att) {
            (false, _) => self.crossed::<false, 6>(go),
            (true, false) => self.crossed::<true, 6>(go),
            (true, true) => self.crossed::<true, WITH_ATTITUDE>(go),
        }
    }

    /// [`LanePlants::width`] with the model's number of cross drag terms per DOF.
    #[inline(always)]
    fn crossed<const SIX: bool, const N: usize>(&self, go: Go<'_, '_>) {
        match self.crosses {
            0 => self.width::<SIX, 0, N>(go),
            1 => self.width::<SIX, 1, N>(go),
            _ => self.width::<SIX, MAX_CROSS, N>(go),
        }
    }

    /// [`LanePlants::run`] one lane wide for a single plant, else [`LANES`] wide.
    #[inline(always)]
    fn width<const SIX: bool, const CROSS: usize, const N: usize>(&self, go: Go<'_, '_>) {
        match self.size {
            1 => self.run::<SIX, CROSS, N, 1>(go),
            _ => self.run::<SIX, CROSS, N, LANES>(go),
        }
    }

    #[inline(always)]
    fn run<const SIX: bool, const CROSS: usize, const N: usize, const L: usize>(
        &self,
        (t, tau, (nu0, att0), max_step, on_sample): Go<'_, '_>,
    ) {
        let g0 = super::dynamics::gravity_body(att0[0], att0[1]);
        let mut x: State<L, N> = std::array::from_fn(|i| match i {
            0..6 => [nu0[i]; L],
            _ => [g0[i - 6]; L],
        });
        let mut seen: [Lanes; 6] = std::array::from_fn(|i| [nu0[i]; LANES]);
        for k in 0..t.len() {
            for i in 0..6 {
                seen[i][..L].copy_from_slice(&x[i]);
            }
            on_sample(k, &seen);
            if k + 1 == t.len() {
                break;
            }
            let span = t[k + 1] - t[k];
            let n = super::dynamics::substeps(span, max_step);
            let h = span / n as f64;
            // The force and constant term are held over the sample: summed once.
            let push: [[f64; L]; 6] = held(&tau[k], &self.constant, &self.lever);
            for _ in 0..n {
                x = self.rk4::<SIX, CROSS, N, L>(&x, &push, h);
            }
        }
    }

    #[inline(always)]
    fn rk4<const SIX: bool, const CROSS: usize, const N: usize, const L: usize>(
        &self,
        x0: &State<L, N>,
        push: &[[f64; L]; 6],
        h: f64,
    ) -> State<L, N> {
        let stage = |k: &State<L, N>, s: f64| -> State<L, N> {
            let mut x = *x0;
            for &i in states::<SIX, N>() {
                for l in 0..L {
                    x[i][l] = k[i][l].mul_add(s, x0[i][l]);
                }
            }
            x
        };
        let k1 = self.accel::<SIX, CROSS, N, L>(x0, push);
        let k2 = self.accel::<SIX, CROSS, N, L>(&stage(&k1, 0.5 * h), push);
        let k3 = self.accel::<SIX, CROSS, N, L>(&stage(&k2, 0.5 * h), push);
        let k4 = self.accel::<SIX, CROSS, N, L>(&stage(&k3, h), push);
        let w = h / 6.0;
        let mut out = *x0;
        for &i in states::<SIX, N>() {
            for l in 0..L {
                let sum = 2.0f64.mul_add(k2[i][l] + k3[i][l], k1[i][l] + k4[i][l]);
                out[i][l] = sum.mul_add(w, x0[i][l]);
            }
        }
        out
    }

    /// nu_dot of eq. 2 for every lane: (tau + constant - C(nu) nu + D(nu) nu + g(eta)) / m,
    /// D's cross terms linear (`CROSS` of them per DOF), the weight and buoyancy g(eta) and
    /// the gravity direction's rate only with the attitude.
    #[inline(always)]
    fn accel<const SIX: bool, const CROSS: usize, const N: usize, const L: usize>(
        &self,
        x: &State<L, N>,
        push: &[[f64; L]; 6],
    ) -> State<L, N> {
        let c = if SIX {
            self.coriolis6(x)
        } else {
            self.coriolis4(x)
        };
        let att = N == WITH_ATTITUDE;
        let mut a = [[0.0; L]; N];
        let w = if att {
            self.restoring(x, &mut a)
        } else {
            [[0.0; L]; 6]
        };
        // The DOFs' own rows (the gravity direction's rate is written by `restoring`).
        for &i in states::<SIX, 6>() {
            let from = self.cross_from[i].map(|j| &x[j]);
            for l in 0..L {
                let v = x[i][l];
                let drag = self.quad[i][l].mul_add(v.abs(), self.lin[i][l]);
                let mut f = push[i][l] - c[i][l];
                if att {
                    f += w[i][l];
                }
                for k in 0..CROSS {
                    f = self.cross[i][k][l].mul_add(from[k][l], f);
                }
                a[i][l] = drag.mul_add(v, f) * self.inv_mass[i][l];
            }
        }
        a
    }

    /// The weight and buoyancy in each DOF at the gravity direction of `x` (W - B along it,
    /// r_B B crossed with it), and that direction's rate g x omega written into `rate`.
    #[inline(always)]
    fn restoring<const L: usize, const N: usize>(
        &self,
        x: &State<L, N>,
        rate: &mut State<L, N>,
    ) -> [[f64; L]; 6] {
        let mut w = [[0.0; L]; 6];
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        for l in 0..L {
            let g = [x[6][l], x[7][l], x[8][l]];
            let m = cross([self.moment[0][l], self.moment[1][l], self.moment[2][l]], g);
            let dg = cross(g, [x[3][l], x[4][l], x[5][l]]);
            for i in 0..3 {
                w[i][l] = self.net_weight[l] * g[i];
                w[3 + i][l] = m[i];
                rate[6 + i][l] = dg[i];
            }
        }
        w
    }
    /// C(nu) nu of [`super::dynamics::coriolis`] with roll and pitch at rest: X -m_v v r,
    /// Y m_u u r, Z 0, N (m_v - m_u) u v.
    #[inline(always)]
    fn coriolis4<const L: usize, const N: usize>(&self, nu: &State<L, N>) -> [[f64; L]; 6] {
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
    fn coriolis6<const L: usize, const N: usize>(&self, nu: &State<L, N>) -> [[f64; L]; 6] {
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
mod tests;
