//! Adaptive identification of plant and actuator parameters (seed 004): a 6-DOF model with a
//! diagonal mass matrix (added mass included), Coriolis terms derived from it (Kirchhoff),
//! diagonal quadratic drag, net weight and buoyancy moment, a ducted thruster `T = k_T |n| n`
//! and fins whose lift and drag are polynomials in the angle of attack of the flow projected
//! onto each fin's plane. The model is linear in its 20 parameters `theta`:
//! `R(nu, a, g, xi) theta = 0` where `R theta = M a + C(nu) nu + D|nu|nu - g(eta) - tau`.
//! Since it is homogeneous, any positive multiple of the true `theta` satisfies it: the data
//! give the parameters up to a scale, fixed afterwards by one known parameter (seed 004
//! section 4.5).
//!
//! Fin convention: a fin at `at` (body frame, from the centre of gravity) with unit span axis
//! `span` pointing away from the hull; its chord at zero angle is body x; a positive angle
//! rotates the chord right-handedly about `span`. The angle of attack is the angle from the
//! fin's direction of motion through the water (projected onto the fin's plane) to its chord,
//! right-handed about `span`; lift acts along `span x d`, drag against the motion `d`.

pub mod aid;
pub mod report;
pub mod result;
pub mod stage;
#[cfg(test)]
mod twin_tests;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

pub use crate::core::model::finned::NAMES;
pub const P: usize = NAMES.len();
/// Index of the first actuator parameter.
pub const ACTUATOR: usize = 15;

/// One fin: its actuator column, position and outward span axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fin {
    pub name: String,
    pub at: [f64; 3],
    pub span: [f64; 3],
}

/// What the identifier knows of the vehicle's actuators.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Actuators {
    pub fins: Vec<Fin>,
    /// The propeller speed's actuator column (rad/s after import, e.g. `prop_rpm`).
    pub thruster: String,
}

/// The regressor row block: 6 rows (X Y Z K M N) by `P` columns.
pub type Regressor = [[f64; P]; 6];

/// One sample of what the regressor needs: body velocity, acceleration (measured, or the
/// identifier's own), the unit down vector in the body frame, fin angles (rad) and the
/// propeller speed (rad/s).
pub struct Sample<'a> {
    pub nu: [f64; 6],
    pub acc: [f64; 6],
    pub down: [f64; 3],
    pub fins: &'a [f64],
    pub prop: f64,
}

/// The unit down vector (pool z) in body axes at roll `phi`, pitch `theta`.
pub fn down(phi: f64, theta: f64) -> [f64; 3] {
    [
        -theta.sin(),
        phi.sin() * theta.cos(),
        phi.cos() * theta.cos(),
    ]
}

fn add(col: &mut Regressor, j: usize, f: Vector3<f64>, m: Vector3<f64>) {
    for i in 0..3 {
        col[i][j] += f[i];
        col[3 + i][j] += m[i];
    }
}

/// `R` at one sample: `R theta = M a + C(nu) nu + D|nu|nu - g - tau`.
pub fn regressor(act: &Actuators, s: &Sample) -> Regressor {
    let mut r = [[0.0; P]; 6];
    let v = Vector3::new(s.nu[0], s.nu[1], s.nu[2]);
    let w = Vector3::new(s.nu[3], s.nu[4], s.nu[5]);
    // Inertia and Coriolis (Kirchhoff, diagonal M): f = M_v a + w x M_v v,
    // m = M_w alpha + w x M_w w + v x M_v v.
    for k in 0..6 {
        r[k][k] += s.acc[k];
        let mut e = Vector3::zeros();
        if k < 3 {
            e[k] = s.nu[k];
            add(&mut r, k, w.cross(&e), v.cross(&e));
        } else {
            e[k - 3] = s.nu[k];
            add(&mut r, k, Vector3::zeros(), w.cross(&e));
        }
        r[k][6 + k] += s.nu[k].abs() * s.nu[k];
    }
    // Weight minus buoyancy along the down vector; the buoyancy moment about the centre of
    // gravity, -B r_B x g, enters R with the opposite sign.
    let g = Vector3::from(s.down);
    add(&mut r, 12, -g, Vector3::zeros());
    add(&mut r, 13, Vector3::zeros(), Vector3::x().cross(&g));
    add(&mut r, 14, Vector3::zeros(), Vector3::z().cross(&g));
    r[0][15] -= s.prop.abs() * s.prop;
    for (fin, delta) in act.fins.iter().zip(s.fins) {
        let Some(f) = fin_flow(fin, &v, &w, *delta) else {
            continue;
        };
        let pos = Vector3::from(fin.at);
        let terms = [
            (16, -f.q * f.alpha * f.lift),
            (17, -f.q * f.alpha.powi(3) * f.lift),
            (18, f.q * f.d),
            (19, f.q * f.alpha * f.alpha * f.d),
        ];
        for (j, force) in terms {
            add(&mut r, j, force, pos.cross(&force));
        }
    }
    r
}

/// The flow at a fin: its squared projected speed, angle of attack, direction of motion and
/// lift direction.
pub struct FinFlow {
    pub q: f64,
    pub alpha: f64,
    pub d: Vector3<f64>,
    pub lift: Vector3<f64>,
}

/// None when the fin hardly moves through the water (no defined angle of attack).
pub fn fin_flow(fin: &Fin, v: &Vector3<f64>, w: &Vector3<f64>, delta: f64) -> Option<FinFlow> {
    let s = Vector3::from(fin.span).normalize();
    let vf = v + w.cross(&Vector3::from(fin.at));
    let up = vf - s * vf.dot(&s);
    let q = up.norm_squared();
    if q < 1e-8 {
        return None;
    }
    let d = up / q.sqrt();
    let c0 = Vector3::x();
    let chord = c0 * delta.cos() + s.cross(&c0) * delta.sin();
    let alpha = d.cross(&chord).dot(&s).atan2(d.dot(&chord));
    Some(FinFlow {
        q,
        alpha,
        d,
        lift: s.cross(&d),
    })
}

/// `R theta` for the rows' sum with `theta`.
pub fn apply(r: &Regressor, theta: &[f64]) -> [f64; 6] {
    std::array::from_fn(|i| r[i].iter().zip(theta).map(|(a, b)| a * b).sum())
}
