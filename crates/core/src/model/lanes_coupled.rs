//! Coupled models (full mass matrix, cross drag, buoyancy that turns with the attitude, seed
//! 003 eq. 1-9) simulated one per SIMD lane, as [`super::lanes`] does for diagonal ones: the
//! output-error objective of a coupled structure advances [`LANES`] candidates per pass.
//!
//! The arithmetic is [`Plant::accel_at`]'s with the inverse mass matrix applied once per
//! stage. The attitude is carried as the gravity direction in the body frame, integrated as
//! g' = g x omega, where [`Plant::simulate_from`] integrates roll and pitch: the same motion
//! without a sine per stage, so the two agree to the integration error (tested).

#![allow(clippy::needless_range_loop)]

use super::dynamics::gravity_body;
use super::lanes::LANES;
use super::{Plant, Vec6};

type Lanes = [f64; LANES];
type Mat = [[Lanes; 6]; 6];

/// [`LANES`] coupled plants of one vehicle, coefficients lane by lane.
#[derive(Debug, Clone)]
pub struct CoupledLanes {
    mass: Mat,
    /// The inverse mass matrix over the free DOFs (zero rows and columns elsewhere).
    inverse: Mat,
    lin: Mat,
    /// `quad[k][i][j]`: force in DOF i per `nu_j |nu_k|`.
    quad: [Mat; 6],
    constant: [Lanes; 6],
    net_weight: Lanes,
    moment: [Lanes; 3],
    lever: [Lanes; 3],
}

/// Body velocities and the gravity direction in the body frame, per lane.
#[derive(Clone, Copy)]
struct State {
    nu: [Lanes; 6],
    g: [Lanes; 3],
}

/// Floating-point operations of one RK4 step of one candidate, as the kernel executes them:
/// per stage the momenta 72, the Kirchhoff crosses 27, the drag matrix 432 and its product
/// 72, the buoyancy 24, the inverse mass 72 and the sums 12, the gravity rates 9; then three
/// stage states and the weighted sum over the nine states.
pub const FLOPS_PER_STEP: usize = 4 * (72 + 27 + 432 + 72 + 24 + 72 + 12 + 9) + 3 * 9 * 2 + 9 * 6;

impl CoupledLanes {
    /// The plants of a population; fewer than [`LANES`] fill the other lanes with the last.
    pub fn new(plants: &[Plant]) -> CoupledLanes {
        assert!(!plants.is_empty() && plants.len() <= LANES);
        let at = |l: usize| &plants[l.min(plants.len() - 1)];
        let lanes = |f: &dyn Fn(&Plant) -> f64| -> Lanes { std::array::from_fn(|l| f(at(l))) };
        let mat = |f: &dyn Fn(&Plant, usize, usize) -> f64| -> Mat {
            std::array::from_fn(|i| std::array::from_fn(|j| lanes(&|p| f(p, i, j))))
        };
        CoupledLanes {
            mass: mat(&|p, i, j| p.mass_matrix().0[i][j]),
            inverse: mat(&|p, i, j| p.mass_matrix().1[i][j]),
            lin: mat(&|p, i, j| p.hydro.lin[i][j]),
            quad: std::array::from_fn(|k| mat(&|p, i, j| p.hydro.quad[k][i][j])),
            constant: std::array::from_fn(|i| lanes(&|p| p.hydro.constant[i])),
            net_weight: lanes(&|p| p.hydro.net_weight),
            moment: std::array::from_fn(|a| lanes(&|p| p.hydro.moment[a])),
            lever: std::array::from_fn(|a| lanes(&|p| p.hydro.lever[a])),
        }
    }

    /// Velocities at the sample times `t` for every lane, from `nu0` and roll and pitch
    /// `att0` at `t[0]`, with `tau[k]` held from `t[k]` to `t[k+1]`.
    pub fn simulate(
        &self,
        t: &[f64],
        tau: &[Vec6],
        (nu0, att0): (Vec6, [f64; 2]),
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: the CPU has just been checked for the features the function uses.
                return unsafe { self.run_avx512(t, tau, (nu0, att0), max_step, on_sample) };
            }
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: as above.
                return unsafe { self.run_avx2(t, tau, (nu0, att0), max_step, on_sample) };
            }
        }
        self.run(t, tau, (nu0, att0), max_step, on_sample)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,fma")]
    fn run_avx512(
        &self,
        t: &[f64],
        tau: &[Vec6],
        start: (Vec6, [f64; 2]),
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        self.run(t, tau, start, max_step, on_sample)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn run_avx2(
        &self,
        t: &[f64],
        tau: &[Vec6],
        start: (Vec6, [f64; 2]),
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        self.run(t, tau, start, max_step, on_sample)
    }

    #[inline(always)]
    fn run(
        &self,
        t: &[f64],
        tau: &[Vec6],
        (nu0, att0): (Vec6, [f64; 2]),
        max_step: f64,
        on_sample: &mut dyn FnMut(usize, &[Lanes; 6]),
    ) {
        let g0 = gravity_body(att0[0], att0[1]);
        let mut x = State {
            nu: std::array::from_fn(|i| [nu0[i]; LANES]),
            g: std::array::from_fn(|i| [g0[i]; LANES]),
        };
        for k in 0..t.len() {
            on_sample(k, &x.nu);
            if k + 1 == t.len() {
                break;
            }
            let span = t[k + 1] - t[k];
            let n = super::dynamics::substeps(span, max_step);
            let h = span / n as f64;
            let push: [Lanes; 6] = super::lanes::held(&tau[k], &self.constant, &self.lever);
            for _ in 0..n {
                x = self.rk4(&x, &push, h);
            }
        }
    }

    #[inline(always)]
    fn rk4(&self, x: &State, push: &[Lanes; 6], h: f64) -> State {
        let stage = |k: &State, s: f64| -> State {
            let mut y = *x;
            for i in 0..6 {
                for l in 0..LANES {
                    y.nu[i][l] = k.nu[i][l].mul_add(s, x.nu[i][l]);
                }
            }
            for i in 0..3 {
                for l in 0..LANES {
                    y.g[i][l] = k.g[i][l].mul_add(s, x.g[i][l]);
                }
            }
            y
        };
        let k1 = self.deriv(x, push);
        let k2 = self.deriv(&stage(&k1, 0.5 * h), push);
        let k3 = self.deriv(&stage(&k2, 0.5 * h), push);
        let k4 = self.deriv(&stage(&k3, h), push);
        let w = h / 6.0;
        let mut out = *x;
        let sum = |a: &Lanes, b: &Lanes, c: &Lanes, d: &Lanes, x: &Lanes| -> Lanes {
            std::array::from_fn(|l| 2.0f64.mul_add(b[l] + c[l], a[l] + d[l]).mul_add(w, x[l]))
        };
        for i in 0..6 {
            out.nu[i] = sum(&k1.nu[i], &k2.nu[i], &k3.nu[i], &k4.nu[i], &x.nu[i]);
        }
        for i in 0..3 {
            out.g[i] = sum(&k1.g[i], &k2.g[i], &k3.g[i], &k4.g[i], &x.g[i]);
        }
        out
    }

    /// nu_dot = M^-1 (tau + constant + D(nu) nu + buoyancy - C(nu) nu), and g' = g x omega.
    #[inline(always)]
    fn deriv(&self, x: &State, push: &[Lanes; 6]) -> State {
        let nu = &x.nu;
        let mut rhs = *push;
        // The drag matrix lin + sum_k |nu_k| quad_k, then its product with nu.
        let abs: [Lanes; 6] = std::array::from_fn(|k| nu[k].map(f64::abs));
        for i in 0..6 {
            for j in 0..6 {
                let mut d = self.lin[i][j];
                for k in 0..6 {
                    for l in 0..LANES {
                        d[l] = self.quad[k][i][j][l].mul_add(abs[k][l], d[l]);
                    }
                }
                for l in 0..LANES {
                    rhs[i][l] = d[l].mul_add(nu[j][l], rhs[i][l]);
                }
            }
        }
        // Coriolis (Kirchhoff form) from the momenta p = M nu.
        let mut p = [[0.0; LANES]; 6];
        for i in 0..6 {
            for j in 0..6 {
                for l in 0..LANES {
                    p[i][l] = self.mass[i][j][l].mul_add(nu[j][l], p[i][l]);
                }
            }
        }
        let g = &x.g;
        let mut dg = [[0.0; LANES]; 3];
        for l in 0..LANES {
            let cross = |a: [f64; 3], b: [f64; 3]| {
                [
                    a[1] * b[2] - a[2] * b[1],
                    a[2] * b[0] - a[0] * b[2],
                    a[0] * b[1] - a[1] * b[0],
                ]
            };
            let (v, w) = (
                [nu[0][l], nu[1][l], nu[2][l]],
                [nu[3][l], nu[4][l], nu[5][l]],
            );
            let (pt, pr) = ([p[0][l], p[1][l], p[2][l]], [p[3][l], p[4][l], p[5][l]]);
            let (f, a, b) = (cross(w, pt), cross(v, pt), cross(w, pr));
            let gl = [g[0][l], g[1][l], g[2][l]];
            let m = cross(
                [self.moment[0][l], self.moment[1][l], self.moment[2][l]],
                gl,
            );
            for i in 0..3 {
                rhs[i][l] += self.net_weight[l].mul_add(gl[i], -f[i]);
                rhs[3 + i][l] += m[i] - a[i] - b[i];
            }
            let rate = cross(gl, w);
            for i in 0..3 {
                dg[i][l] = rate[i];
            }
        }
        let mut a = [[0.0; LANES]; 6];
        for i in 0..6 {
            for j in 0..6 {
                for l in 0..LANES {
                    a[i][l] = self.inverse[i][j][l].mul_add(rhs[j][l], a[i][l]);
                }
            }
        }
        State { nu: a, g: dg }
    }
}
