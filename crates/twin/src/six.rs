//! The 6-DOF twin: a vehicle the size of the JHU ROV (seed 003 section IV: about 240 kg,
//! 1.37 x 0.85 x 0.61 m, six thrusters, actuated in all six DOFs) with a fully coupled truth
//! (full mass matrix, cross quadratic drag, net weight and a righting moment), and a linear
//! roll drag in place of the quadratic one, as seed 003's pilot studies found. Its trials are
//! those of seed 003 Table II: sinusoidal position references tracked under closed-loop
//! control in surge, sway and heave, open-loop sinusoidal moments in roll, pitch and yaw.
//!
//! The simulator here is written apart from `model::dynamics`: Fossen's matrix form
//! (eq. 6.43 for C(nu) with skew matrices, nalgebra), Euler-angle kinematics and its own RK4,
//! so an identification that recovers this truth is not checking the model against itself.

use hydrofit_core::model::{Hydro, Vehicle};
use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

pub mod render;

/// The vehicle as `pipeline.yaml` states it: mass and inertia known, all six DOFs.
pub fn vehicle() -> Vehicle {
    let mut v = Vehicle::reference();
    v.name = "JHU-ROV-sized 6-DOF vehicle (six-DOF twin)".into();
    v.mass_kg = 240.0;
    // A uniform box of 1.37 x 0.85 x 0.61 m: I = m (b^2 + c^2) / 12.
    v.inertia_kg_m2 = hydrofit_core::model::vehicle::Inertia {
        xx: 22.0,
        yy: 45.0,
        zz: 52.0,
    };
    v.dofs = hydrofit_core::dof::Dof::ALL.to_vec();
    v.structure = hydrofit_core::model::Structure::Custom;
    v
}

/// The truth: within seed 003's CUSTOM set (every quadratic term but K_pp, the linear roll
/// drag K_p, the full mass matrix, the net weight and the moment of weight and buoyancy).
pub fn truth() -> Hydro {
    let mut h = Hydro::diagonal(
        [-80.0, -150.0, -200.0, -10.0, -22.0, -15.0],
        [0.0, 0.0, 0.0, -60.0, 0.0, 0.0],
        [-120.0, -250.0, -300.0, 0.0, -70.0, -45.0],
    );
    // Off-diagonal added mass of an open frame with its float on top (kg, kg m).
    for (i, j, v) in [
        (0, 2, -12.0),
        (0, 4, -9.0),
        (1, 3, 7.0),
        (1, 5, -6.0),
        (2, 4, 5.0),
        (3, 5, -1.5),
    ] {
        h.added[i][j] = v;
        h.added[j][i] = v;
    }
    // Cross quadratic drag: every row couples to every velocity, at 3-12 % of the diagonal
    // term of its row (a deterministic pattern, so the truth is the same everywhere).
    let scale = [120.0, 250.0, 300.0, 30.0, 70.0, 45.0];
    for k in 0..6 {
        for (i, row_scale) in scale.iter().enumerate() {
            for j in 0..6 {
                if i == j && j == k {
                    continue;
                }
                let s = ((i * 7 + j * 5 + k * 3) % 10) as f64 / 100.0 + 0.03;
                let sign = if (i + 2 * j + k) % 3 == 0 { 1.0 } else { -1.0 };
                h.quad[k][i][j] = sign * s * row_scale * if i == j { 1.0 } else { 0.5 };
            }
        }
    }
    h.net_weight = 4.0;
    // Centre of gravity 0.15 m below the centre of buoyancy and a little aft and to port.
    let w = 240.0 * hydrofit_core::model::G;
    h.moment = [-0.004 * w, 0.006 * w, 0.15 * w];
    h
}

/// Limits of the thrusters per DOF: two 150 N thrusters per axis, moments of half that arm.
pub const FORCE_LIMIT: [f64; 6] = [300.0, 300.0, 300.0, 150.0, 150.0, 150.0];

/// Integration step and command period, s.
pub const STEP: f64 = 0.01;
pub const COMMAND_EVERY: usize = 5;

fn skew(a: Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// The model in Fossen's matrix form.
pub struct Body {
    m: Matrix6<f64>,
    m_inv: Matrix6<f64>,
    lin: Matrix6<f64>,
    quad: [Matrix6<f64>; 6],
    net_weight: f64,
    moment: Vector3<f64>,
}

impl Body {
    pub fn new(v: &Vehicle, h: &Hydro) -> Body {
        let mrb = v.rigid_mass();
        let mat = |a: &hydrofit_core::model::Mat6| Matrix6::from_fn(|i, j| a[i][j]);
        let m = Matrix6::from_diagonal(&Vector6::from_row_slice(&mrb)) - mat(&h.added);
        Body {
            m_inv: m
                .try_inverse()
                .expect("the twin's mass matrix is invertible"),
            m,
            lin: mat(&h.lin),
            quad: std::array::from_fn(|k| mat(&h.quad[k])),
            net_weight: h.net_weight,
            moment: Vector3::from_row_slice(&h.moment),
        }
    }

    /// nu_dot = M^-1 (tau - C(nu) nu - D(nu) nu - g(eta)), with C from Fossen eq. 6.43,
    /// D(nu) = -(lin + sum_k |nu_k| quad_k) and g the restoring force at roll `phi`, pitch `theta`.
    pub fn accel(
        &self,
        nu: &Vector6<f64>,
        tau: &Vector6<f64>,
        phi: f64,
        theta: f64,
    ) -> Vector6<f64> {
        let (n1, n2) = (
            nu.fixed_rows::<3>(0).into_owned(),
            nu.fixed_rows::<3>(3).into_owned(),
        );
        let a = self.m.fixed_view::<3, 3>(0, 0) * n1 + self.m.fixed_view::<3, 3>(0, 3) * n2;
        let b = self.m.fixed_view::<3, 3>(3, 0) * n1 + self.m.fixed_view::<3, 3>(3, 3) * n2;
        let mut c = Matrix6::zeros();
        c.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-skew(a)));
        c.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-skew(a)));
        c.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-skew(b)));
        let mut d = -self.lin;
        for k in 0..6 {
            d -= self.quad[k] * nu[k].abs();
        }
        let gb = Vector3::new(
            -theta.sin(),
            theta.cos() * phi.sin(),
            theta.cos() * phi.cos(),
        );
        let f = gb * self.net_weight;
        let m = self.moment.cross(&gb);
        let restoring = -Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z);
        self.m_inv * (tau - c * nu - d * nu - restoring)
    }
}

/// Body-to-pool rotation (z-y-x Euler angles, Fossen eq. 2.18).
pub fn rotation(phi: f64, theta: f64, psi: f64) -> Matrix3<f64> {
    nalgebra::Rotation3::from_euler_angles(phi, theta, psi).into_inner()
}

/// The full state: body velocities and the pose (x, y, z, roll, pitch, yaw).
#[derive(Debug, Clone, Copy)]
pub struct State {
    pub nu: Vector6<f64>,
    pub eta: Vector6<f64>,
}

fn derivative(body: &Body, x: &State, tau: &Vector6<f64>) -> State {
    let (phi, theta) = (x.eta[3], x.eta[4]);
    let r = rotation(phi, theta, x.eta[5]);
    let p = r * x.nu.fixed_rows::<3>(0);
    let (sp, cp, ct, tt) = (phi.sin(), phi.cos(), theta.cos(), theta.tan());
    let (pp, q, rr) = (x.nu[3], x.nu[4], x.nu[5]);
    // Fossen eq. 2.29: Euler-angle rates.
    let euler = Vector3::new(
        pp + sp * tt * q + cp * tt * rr,
        cp * q - sp * rr,
        (sp * q + cp * rr) / ct,
    );
    State {
        nu: body.accel(&x.nu, tau, phi, theta),
        eta: Vector6::new(p.x, p.y, p.z, euler.x, euler.y, euler.z),
    }
}

/// One RK4 step with `tau` held.
pub fn step(body: &Body, x: &State, tau: &Vector6<f64>, h: f64) -> State {
    let add = |a: &State, k: &State, s: f64| State {
        nu: a.nu + k.nu * s,
        eta: a.eta + k.eta * s,
    };
    let k1 = derivative(body, x, tau);
    let k2 = derivative(body, &add(x, &k1, h / 2.0), tau);
    let k3 = derivative(body, &add(x, &k2, h / 2.0), tau);
    let k4 = derivative(body, &add(x, &k3, h), tau);
    State {
        nu: x.nu + (k1.nu + k2.nu * 2.0 + k3.nu * 2.0 + k4.nu) * (h / 6.0),
        eta: x.eta + (k1.eta + k2.eta * 2.0 + k3.eta * 2.0 + k4.eta) * (h / 6.0),
    }
}

/// A sum of two sines: `mag1 sin(freq1 t) + mag2 sin(freq2 t + 1)` (seed 003 Table II lists
/// two components for some DOFs).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Sines {
    pub freq: [f64; 2],
    pub mag: [f64; 2],
}

impl Sines {
    pub const fn one(freq: f64, mag: f64) -> Sines {
        Sines {
            freq: [freq, 0.0],
            mag: [mag, 0.0],
        }
    }

    pub fn at(&self, t: f64) -> f64 {
        self.mag[0] * (self.freq[0] * t).sin() + self.mag[1] * (self.freq[1] * t + 1.0).sin()
    }

    pub fn rate(&self, t: f64) -> f64 {
        self.mag[0] * self.freq[0] * (self.freq[0] * t).cos()
            + self.mag[1] * self.freq[1] * (self.freq[1] * t + 1.0).cos()
    }
}

/// One trial: closed-loop position references in x, y, z (m about the start) and open-loop
/// moments in roll, pitch and yaw (N m).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Trial {
    pub name: String,
    pub role: hydrofit_core::run::Role,
    pub duration_s: f64,
    pub position: [Sines; 3],
    pub moment: [Sines; 3],
    /// A concealed first-order lag, s, between the logged command and the force and moment
    /// the body feels (thrusters that spin up); 0: none. The log records the command.
    #[serde(skip_serializing_if = "is_zero")]
    pub lag_s: f64,
    /// A concealed roll moment that grows with the square of the surge speed, N m s^2/m^2
    /// (`K += c |u| u`: a frame whose float sits to one side, so the flow past it as the
    /// vehicle surges rolls it); 0: none. No coupling of the product's models has this form.
    #[serde(skip_serializing_if = "is_zero")]
    pub roll_from_surge: f64,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// Seed 003 Table II for identification (its second v4 row read as pitch), and two
/// cross-validation trials with other frequencies and magnitudes.
pub fn default_trials() -> Vec<Trial> {
    use hydrofit_core::run::Role;
    let table_ii = Trial {
        name: "table_ii".into(),
        role: Role::Train,
        duration_s: 300.0,
        position: [
            Sines::one(0.17, 1.0),
            Sines::one(0.2, 1.0),
            Sines::one(0.35, 1.0),
        ],
        moment: [
            Sines {
                freq: [0.45, 0.35],
                mag: [40.0, 40.0],
            },
            Sines {
                freq: [0.5, 0.3],
                mag: [60.0, 70.0],
            },
            Sines::one(0.35, 70.0),
        ],
        lag_s: 0.0,
        roll_from_surge: 0.0,
    };
    let cross_a = Trial {
        name: "cross_slow".into(),
        role: Role::Validate,
        duration_s: 180.0,
        position: [
            Sines::one(0.12, 1.5),
            Sines::one(0.25, 0.8),
            Sines::one(0.3, 0.6),
        ],
        moment: [
            Sines::one(0.6, 50.0),
            Sines::one(0.4, 80.0),
            Sines {
                freq: [0.25, 0.5],
                mag: [50.0, 30.0],
            },
        ],
        lag_s: 0.0,
        roll_from_surge: 0.0,
    };
    let cross_b = Trial {
        name: "cross_fast".into(),
        role: Role::Validate,
        duration_s: 180.0,
        position: [
            Sines::one(0.3, 0.8),
            Sines::one(0.15, 1.2),
            Sines::one(0.45, 0.5),
        ],
        moment: [
            Sines {
                freq: [0.3, 0.55],
                mag: [30.0, 30.0],
            },
            Sines::one(0.6, 60.0),
            Sines::one(0.45, 90.0),
        ],
        lag_s: 0.0,
        roll_from_surge: 0.0,
    };
    vec![table_ii, cross_a, cross_b]
}

/// The true motion of a trial at every integration step, and the command at each.
#[derive(Debug, Clone, Default)]
pub struct Record {
    pub t: Vec<f64>,
    pub tau: Vec<[f64; 6]>,
    pub nu: Vec<[f64; 6]>,
    pub nu_dot: Vec<[f64; 6]>,
    pub eta: Vec<[f64; 6]>,
}

impl Record {
    /// The trial as a response table sampled at the command times: exact velocities, the
    /// simulator's own accelerations and the attitude (what a perfect sensor suite would give).
    pub fn response(&self) -> hydrofit_core::response::Response {
        use hydrofit_core::response::{Series, Source};
        let idx: Vec<usize> = (0..self.t.len()).step_by(COMMAND_EVERY).collect();
        let mut r = hydrofit_core::response::Response {
            t: idx.iter().map(|&k| self.t[k]).collect(),
            attitude: idx
                .iter()
                .map(|&k| [self.eta[k][3], self.eta[k][4]])
                .collect(),
            ..Default::default()
        };
        for d in hydrofit_core::dof::Dof::ALL {
            let i = d.index();
            let col = |x: &Vec<[f64; 6]>| idx.iter().map(|&k| x[k][i]).collect::<Vec<f64>>();
            let series = Series {
                force: col(&self.tau),
                velocity: col(&self.nu),
                accel: col(&self.nu_dot),
                force_source: Source::Column,
                accel_source: Source::Column,
            };
            r.dofs.insert(d, series);
        }
        r
    }
}

/// Position gains of the closed-loop controller (per unit mass: about 0.6 rad/s, damped 0.9).
const KP: f64 = 0.36;
const KD: f64 = 1.08;

/// The trial flown by `body` from rest at 3 m depth, level. The controller sees the true
/// state (the point is the plant, not the navigation) and knows only the rigid-body mass.
pub fn fly(body: &Body, v: &Vehicle, trial: &Trial) -> Record {
    let steps = (trial.duration_s / STEP).round() as usize;
    let start = Vector3::new(0.0, 0.0, 3.0);
    let mut x = State {
        nu: Vector6::zeros(),
        eta: Vector6::new(0.0, 0.0, 3.0, 0.0, 0.0, 0.0),
    };
    let mut tau = Vector6::zeros();
    // What the body feels: the command through the concealed lag, if any.
    let mut felt = Vector6::zeros();
    let follow = match trial.lag_s > 0.0 {
        true => 1.0 - (-STEP / trial.lag_s).exp(),
        false => 1.0,
    };
    let mut rec = Record::default();
    let arr = |v: &Vector6<f64>| -> [f64; 6] { std::array::from_fn(|i| v[i]) };
    for n in 0..=steps {
        let t = n as f64 * STEP;
        if n % COMMAND_EVERY == 0 {
            tau = command(v, trial, &x, t, start);
        }
        let (phi, theta) = (x.eta[3], x.eta[4]);
        rec.t.push(t);
        rec.tau.push(arr(&tau));
        rec.nu.push(arr(&x.nu));
        felt = match follow < 1.0 {
            true => felt + (tau - felt) * follow,
            false => tau,
        };
        // The concealed roll moment, held through the step as the command is.
        let mut acting = felt;
        acting[3] += trial.roll_from_surge * x.nu[0].abs() * x.nu[0];
        rec.nu_dot
            .push(arr(&body.accel(&x.nu, &acting, phi, theta)));
        rec.eta.push(arr(&x.eta));
        x = step(body, &x, &acting, STEP);
    }
    rec
}

fn command(v: &Vehicle, trial: &Trial, x: &State, t: f64, start: Vector3<f64>) -> Vector6<f64> {
    let r = rotation(x.eta[3], x.eta[4], x.eta[5]);
    let target = start + Vector3::from_fn(|i, _| trial.position[i].at(t));
    let target_rate = Vector3::from_fn(|i, _| trial.position[i].rate(t));
    let pos = x.eta.fixed_rows::<3>(0).into_owned();
    let e = r.transpose() * (target - pos);
    let de = r.transpose() * target_rate - x.nu.fixed_rows::<3>(0);
    let m = v.mass_kg;
    let mut tau = Vector6::zeros();
    for i in 0..3 {
        tau[i] = m * (KP * e[i] + KD * de[i]);
        tau[3 + i] = trial.moment[i].at(t);
    }
    tau.zip_map(&Vector6::from_row_slice(&FORCE_LIMIT), |f, l| {
        f.clamp(-l, l)
    })
}

#[cfg(test)]
mod lanes {
    use hydrofit_core::model::lanes::LANES;
    use hydrofit_core::model::lanes_coupled::*;
    use hydrofit_core::model::{Plant, Vec6};

    /// The core's lane-parallel coupled simulator against its one-plant simulator, on this
    /// twin's coupled truth.
    #[test]
    fn every_lane_follows_its_plant() {
        // The six-DOF twin's coupled truth, scaled differently in each lane, under a varying
        // six-DOF force from a tilted start: each lane against Plant::simulate_from.
        let v = crate::six::vehicle();
        let plants: Vec<Plant> = (0..LANES)
            .map(|l| {
                let mut h = crate::six::truth();
                let f = 1.0 + 0.05 * l as f64;
                h.quad.iter_mut().flatten().flatten().for_each(|x| *x *= f);
                h.moment[2] *= f;
                Plant::new(&v, h)
            })
            .collect();
        let lanes = CoupledLanes::new(&plants);
        let t: Vec<f64> = (0..400).map(|k| k as f64 * 0.05).collect();
        let tau: Vec<Vec6> = t
            .iter()
            .map(|s| {
                [
                    80.0 * s.sin(),
                    40.0,
                    -30.0 * (0.5 * s).cos(),
                    20.0 * s.cos(),
                    -15.0,
                    25.0 * (0.3 * s).sin(),
                ]
            })
            .collect();
        let start = ([0.2, -0.1, 0.05, 0.1, -0.05, 0.2], [0.1, -0.05]);
        let mut got = vec![[[0.0; LANES]; 6]; t.len()];
        lanes.simulate(&t, &tau, start, 0.01, &mut |k, nu| got[k] = *nu);
        for (l, p) in plants.iter().enumerate() {
            let want = p.simulate_from(&t, &tau, start.0, start.1, 0.01);
            for (k, w) in want.iter().enumerate() {
                for i in 0..6 {
                    let e = (got[k][i][l] - w[i]).abs();
                    assert!(
                        e < 1e-7,
                        "lane {l}, sample {k}, DOF {i}: {} vs {}",
                        got[k][i][l],
                        w[i]
                    );
                }
            }
        }
    }
}
