//! Effect-free runs flown closed-loop by a pilot, written by an integrator of their own (not
//! the twin's, not the diagnosis's): the data for the test that an unstable model on piloted
//! runs is not read as missing physics.

/// Twenty RK4 substeps of the true plant over `dt` under `tau`; the pose [x, y, z, psi] by
/// Euler on the same substeps.
fn advance(
    plant: &crate::core::model::Plant,
    tau: &[f64; 6],
    dt: f64,
    nu: &mut [f64; 6],
    pose: &mut [f64; 4],
) {
    let [x, y, z, psi] = pose;
    // Twenty RK4 substeps of the true plant, the pose by Euler on the same substeps.
    for _ in 0..20 {
        let h = dt / 20.0;
        let f = |v: &[f64; 6]| plant.accel(v, tau);
        let add = |a: &[f64; 6], b: &[f64; 6], s: f64| -> [f64; 6] {
            std::array::from_fn(|q| a[q] + s * b[q])
        };
        let k1 = f(nu);
        let k2 = f(&add(nu, &k1, h / 2.0));
        let k3 = f(&add(nu, &k2, h / 2.0));
        let k4 = f(&add(nu, &k3, h));
        let (c, s) = (psi.cos(), psi.sin());
        *x += h * (c * nu[0] - s * nu[1]);
        *y += h * (s * nu[0] + c * nu[1]);
        *z += h * nu[2];
        *psi += h * nu[5];
        *nu =
            std::array::from_fn(|q| nu[q] + h / 6.0 * (k1[q] + 2.0 * k2[q] + 2.0 * k3[q] + k4[q]));
    }
}

/// The metadata of straight run `i`: runs 4 and 5 held out, in a 400 m basin with a tether.
fn straight_meta(i: usize) -> crate::pool::fusion::run::RunMeta {
    let role = if i >= 4 {
        crate::pool::import::Role::Validate
    } else {
        crate::pool::import::Role::Train
    };
    let mut meta = crate::pool::fusion::run::RunMeta::bare(&format!("straight_{i}"), role);
    meta.pool = Some(crate::core::model::Pool {
        length_m: 400.0,
        width_m: 40.0,
        depth_m: 10.0,
    });
    meta.tether_anchor_m = Some([0.0, 20.0, 0.0]);
    meta
}

/// Fast straight runs of the reference vehicle flown by a pilot who holds heading and speed
/// (closed loop on the true state), with no left-out physics at all, written by an integrator
/// and pilot of this test's own. At 1.1-1.4 m/s the model's sway-yaw pair is unstable (Munk
/// moment over yaw damping), so an open-loop simulation of the logged command drifts apart
/// from the recording whatever the model. Re-anchored over windows the true model must be
/// found sufficient: nothing named, nothing unexplained.
pub(super) fn piloted_fast_runs(seed: u64) -> Vec<crate::pool::fusion::run::FusedRun> {
    use crate::core::model::{Hydro, Plant, Vehicle};
    let plant = Plant::new(&Vehicle::reference(), Hydro::reference());
    let mut rng = crate::core::rng::Rng::new(seed);
    let (dt, n) = (0.05, 1200);
    let mut out = Vec::new();
    for (i, speed) in [1.2, 1.3, 1.1, 1.4, 1.25, 1.35].into_iter().enumerate() {
        let mut nu = [0.0f64; 6];
        let (mut x, mut y, mut z, mut psi) = (5.0, 20.0, 1.5, 0.2 * rng.normal());
        let mut fused = crate::pool::fusion::Fused {
            t: vec![],
            vel: Default::default(),
            std: Default::default(),
            x: vec![],
            y: vec![],
            z: vec![],
            psi: vec![],
            roll_pitch: Default::default(),
            tracked: Default::default(),
            stats: Default::default(),
        };
        let (mut vel, mut thrust) = ([vec![], vec![], vec![], vec![]], vec![]);
        let mut gust = [0.0f64; 4];
        for k in 0..n {
            let t = k as f64 * dt;
            // The pilot: speed by feed-forward and a P term, heading and depth held by PD,
            // plus the unsteadiness of a human hand (a slowly wandering extra command).
            let target = if t < 5.0 { speed * t / 5.0 } else { speed };
            for (g, s) in gust.iter_mut().zip([6.0, 4.0, 4.0, 0.3]) {
                *g = 0.98 * *g + 0.2 * s * rng.normal();
            }
            let tau = [
                2.41 * target + 44.17 * target * target + 60.0 * (target - nu[0]) + gust[0],
                -25.0 * nu[1] + gust[1],
                40.0 * (1.5 - z) - 30.0 * nu[2] + gust[2],
                0.0,
                0.0,
                -8.0 * psi - 4.0 * nu[5] + gust[3],
            ];
            thrust.push([tau[0], tau[1], tau[2], tau[5]]);
            fused.t.push(t);
            fused.x.push(x);
            fused.y.push(y);
            fused.z.push(z);
            fused.psi.push(psi);
            for (j, &q) in [0usize, 1, 2, 5].iter().enumerate() {
                vel[j].push(nu[q] + if j == 3 { 0.004 } else { 0.008 } * rng.normal());
            }
            let mut pose = [x, y, z, psi];
            advance(&plant, &tau, dt, &mut nu, &mut pose);
            [x, y, z, psi] = pose;
        }
        for (j, v) in vel.iter_mut().enumerate() {
            let sigma = if j == 3 { 0.004 } else { 0.008 };
            fused.std[j] = Some(vec![sigma; n]);
            fused.vel[j] = Some(std::mem::take(v));
        }
        let meta = straight_meta(i);
        out.push(crate::pool::fusion::run::FusedRun {
            meta,
            thrust,
            moments: Vec::new(),
            fused,
            without_sonar: None,
            actuators: Vec::new(),
        });
    }
    out
}
