//! The AUV twin of seed 004: an Iver3-sized torpedo vehicle (2 m, 30 kg, four tail fins in a
//! plus-shaped configuration, one ducted thruster) on dives of about 1000 s under its own closed-loop
//! depth and heading controller (a zig-zag heading and a depth undulating between 1 and 5 m,
//! as the paper's dives 86 and 88), plus a dive at constant depth and heading that excites
//! little. Its 6-DOF dynamics are written in Fossen's matrix form (skew-symmetric Coriolis
//! matrix, fin forces through each fin's rotation matrices: seed 004 appendix A) and
//! integrated with its own RK4; the identifier never sees this code. Logs: `actuators.csv`
//! (four fin angles and the propeller speed at 20 Hz), `nav.csv` (DVL u v w at 5 Hz), `imu.csv`
//! (AHRS attitude and rates at 20 Hz), `depth.csv`.

use hydrofit_core::rng::Rng;
use nalgebra::{Matrix3, Vector3, Vector6};
use serde::Serialize;

/// The true coefficients, in the identifier's order (`field::adaptive::NAMES`).
pub const TRUTH: [f64; 20] = [
    31.0, 60.0, 60.0, 0.1, 12.0, 12.0, // mass with added mass
    3.5, 100.0, 100.0, 0.02, 15.0, 15.0, // quadratic drag
    -2.0, 0.0, -3.55,  // W-B, B x_B, B z_B
    2.8e-4, // thruster
    25.0, -12.0, 0.2, 4.0, // fin lift and drag polynomials
];

/// The fins: name, position (m, from the centre of gravity), outward span axis.
pub const FINS: [(&str, [f64; 3], [f64; 3]); 4] = [
    ("fin_top", [-0.85, 0.0, -0.1], [0.0, 0.0, -1.0]),
    ("fin_bottom", [-0.85, 0.0, 0.1], [0.0, 0.0, 1.0]),
    ("fin_port", [-0.85, -0.1, 0.0], [0.0, -1.0, 0.0]),
    ("fin_starboard", [-0.85, 0.1, 0.0], [0.0, 1.0, 0.0]),
];

fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// Body-frame generalised force of the fins and thruster at velocity `nu`.
fn actuation(nu: &Vector6<f64>, fins: &[f64; 4], n: f64) -> Vector6<f64> {
    let t = &TRUTH;
    let v = nu.fixed_rows::<3>(0).into_owned();
    let w = nu.fixed_rows::<3>(3).into_owned();
    let mut f = Vector6::new(t[15] * n.abs() * n, 0.0, 0.0, 0.0, 0.0, 0.0);
    for ((_, at, span), delta) in FINS.iter().zip(fins) {
        let (r, s) = (Vector3::from(*at), Vector3::from(*span));
        // Fin frame at zero angle: x along the chord, y the span, z = x cross y; then the
        // deflection, a rotation about the fin's y.
        let x0 = Vector3::x();
        let r_vf0 = Matrix3::from_columns(&[x0, s, x0.cross(&s)]);
        let (c, sn) = (delta.cos(), delta.sin());
        let r_f0f = Matrix3::new(c, 0.0, sn, 0.0, 1.0, 0.0, -sn, 0.0, c);
        let r_vf = r_vf0 * r_f0f;
        let mut u = r_vf.transpose() * (v + w.cross(&r));
        u.y = 0.0; // spanwise flow makes no lift or drag
        let q = u.norm_squared();
        if q < 1e-10 {
            continue;
        }
        let alpha = u.z.atan2(u.x);
        let d = u / q.sqrt();
        let lift_dir = Vector3::new(d.z, 0.0, -d.x);
        let cl = t[16] * alpha + t[17] * alpha.powi(3);
        let cd = t[18] + t[19] * alpha * alpha;
        let force = r_vf * (q * (cl * lift_dir - cd * d));
        let moment = r.cross(&force);
        for i in 0..3 {
            f[i] += force[i];
            f[3 + i] += moment[i];
        }
    }
    f
}

/// State: nu (6), roll, pitch, yaw, depth.
pub type State = [f64; 10];

/// The state's derivative under fin angles `fins` and propeller speed `n`: Fossen's matrices
/// with the true coefficients.
pub fn deriv(x: &State, fins: &[f64; 4], n: f64) -> State {
    let t = &TRUTH;
    let nu = Vector6::from_column_slice(&x[..6]);
    let v = nu.fixed_rows::<3>(0).into_owned();
    let w = nu.fixed_rows::<3>(3).into_owned();
    let mv = Matrix3::from_diagonal(&Vector3::new(t[0], t[1], t[2]));
    let mw = Matrix3::from_diagonal(&Vector3::new(t[3], t[4], t[5]));
    // Fossen's C(nu) for a diagonal mass matrix: [[0, -S(Mv v)], [-S(Mv v), -S(Mw w)]].
    let a = skew(&(mv * v));
    let b = skew(&(mw * w));
    let cor_f = -a * w;
    let cor_m = -a * v - b * w;
    let (phi, th, psi) = (x[6], x[7], x[8]);
    let down = Vector3::new(-th.sin(), phi.sin() * th.cos(), phi.cos() * th.cos());
    let rb = Vector3::new(t[13], 0.0, t[14]); // B x_B, B z_B
    let grav_f = t[12] * down;
    let grav_m = -rb.cross(&down);
    let tau = actuation(&nu, fins, n);
    let mut out = [0.0; 10];
    for i in 0..3 {
        let drag_f = t[6 + i] * v[i].abs() * v[i];
        let drag_m = t[9 + i] * w[i].abs() * w[i];
        out[i] = (tau[i] + grav_f[i] - cor_f[i] - drag_f) / t[i];
        out[3 + i] = (tau[3 + i] + grav_m[i] - cor_m[i] - drag_m) / t[3 + i];
    }
    let (p, q, r) = (w.x, w.y, w.z);
    out[6] = p + (q * phi.sin() + r * phi.cos()) * th.tan();
    out[7] = q * phi.cos() - r * phi.sin();
    out[8] = (q * phi.sin() + r * phi.cos()) / th.cos();
    // Depth rate: the down component of the body velocity.
    let _ = psi;
    out[9] = down.dot(&v);
    out
}

/// One dive: seed, length, role, and whether it manoeuvres.
#[derive(Debug, Clone, Serialize)]
pub struct Dive {
    pub name: String,
    pub role: &'static str,
    pub seed: u64,
    pub duration_s: f64,
    pub manoeuvres: bool,
}

pub fn default_dives() -> Vec<Dive> {
    let d = |name: &str, role, seed, manoeuvres| Dive {
        name: name.into(),
        role,
        seed,
        duration_s: 1000.0,
        manoeuvres,
    };
    vec![
        d("dive_86", "train", 86, true),
        d("dive_88", "validate", 88, true),
        d("dive_87", "validate", 87, false),
    ]
}

/// The true record at 20 Hz: time, state, fin angles, propeller speed.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Record {
    pub t: Vec<f64>,
    pub x: Vec<State>,
    pub fins: Vec<[f64; 4]>,
    pub prop: Vec<f64>,
}

const DT: f64 = 0.01;
const LIMIT: f64 = 0.35;

/// The controller at 20 Hz: heading and depth set-points of the dive, fins by PD laws with a
/// small dither, the propeller stepping between 1200 and 1600 rpm every 100 s.
fn command(d: &Dive, t: f64, x: &State, rng: &mut Rng, dither: &mut [f64; 2]) -> ([f64; 4], f64) {
    let (heading, depth) = if d.manoeuvres {
        let leg = (t / 70.0).floor() as i64;
        let psi = if leg % 2 == 0 { 0.45 } else { -0.45 };
        let phase = (t / 200.0).fract();
        let z = 1.0 + 4.0 * (1.0 - (2.0 * phase - 1.0).abs());
        (psi, z)
    } else {
        (0.0, 3.0)
    };
    if d.manoeuvres && rng.uniform() < 0.1 {
        *dither = [
            0.035 * (2.0 * rng.uniform() - 1.0),
            0.035 * (2.0 * rng.uniform() - 1.0),
        ];
    }
    let pitch_ref = (-0.5 * (depth - x[9])).clamp(-0.35, 0.35);
    let elevator = (1.2 * (x[7] - pitch_ref) + 0.8 * x[4] + dither[0]).clamp(-LIMIT, LIMIT);
    let mut e_psi = x[8] - heading;
    e_psi = (e_psi + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI)
        - std::f64::consts::PI;
    let rudder = (1.0 * e_psi + 0.8 * x[5] + dither[1]).clamp(-LIMIT, LIMIT);
    let roll = (0.3 * x[6] + 0.2 * x[3]).clamp(-0.1, 0.1);
    let rpm = if d.manoeuvres && ((t / 100.0).floor() as i64) % 2 == 1 {
        1200.0
    } else {
        1600.0
    };
    let fins = [
        -rudder + roll,
        rudder + roll,
        -elevator + roll,
        elevator + roll,
    ];
    (fins, rpm * std::f64::consts::PI / 30.0)
}

pub fn fly(d: &Dive) -> Record {
    let mut rng = Rng::derive(d.seed, "auv-controller");
    let mut x: State = [1.4, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 3.0];
    let mut rec = Record::default();
    let mut dither = [0.0; 2];
    let (mut fins, mut n) = ([0.0; 4], 0.0);
    let steps = (d.duration_s / DT).round() as usize;
    for k in 0..=steps {
        let t = k as f64 * DT;
        if k % 5 == 0 {
            (fins, n) = command(d, t, &x, &mut rng, &mut dither);
            rec.t.push(t);
            rec.x.push(x);
            rec.fins.push(fins);
            rec.prop.push(n);
        }
        let add =
            |a: &State, b: &State, s: f64| -> State { std::array::from_fn(|i| a[i] + s * b[i]) };
        let k1 = deriv(&x, &fins, n);
        let k2 = deriv(&add(&x, &k1, DT / 2.0), &fins, n);
        let k3 = deriv(&add(&x, &k2, DT / 2.0), &fins, n);
        let k4 = deriv(&add(&x, &k3, DT), &fins, n);
        x = std::array::from_fn(|i| x[i] + DT / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
    }
    rec
}

/// The dive's files with sensor noise: DVL 3 mm/s at 5 Hz, AHRS 0.05 deg and 0.03 deg/s at
/// 20 Hz, depth 1 cm at 5 Hz, commands at 20 Hz.
pub fn files(d: &Dive, rec: &Record, seed: u64) -> Vec<(&'static str, String)> {
    let mut rng = Rng::derive(seed ^ d.seed, "auv-noise");
    let mut act =
        String::from("t,fin_top_deg,fin_bottom_deg,fin_port_deg,fin_starboard_deg,prop_rpm\n");
    let mut nav = String::from("t,u_m_s,v_m_s,w_m_s\n");
    let mut imu = String::from("t,roll_deg,pitch_deg,yaw_deg,p_dps,q_dps,r_dps\n");
    let mut depth = String::from("t,depth_m\n");
    for (k, t) in rec.t.iter().enumerate() {
        let x = &rec.x[k];
        let f = rec.fins[k].map(f64::to_degrees);
        act += &format!(
            "{t:.2},{:.3},{:.3},{:.3},{:.3},{:.1}\n",
            f[0],
            f[1],
            f[2],
            f[3],
            rec.prop[k] * 30.0 / std::f64::consts::PI
        );
        let mut deg = |v: f64, s: f64| v.to_degrees() + s * rng.normal();
        let (roll, pitch, yaw) = (deg(x[6], 0.05), deg(x[7], 0.05), deg(x[8], 0.05));
        let (p, q, r) = (deg(x[3], 0.03), deg(x[4], 0.03), deg(x[5], 0.03));
        imu += &format!("{t:.2},{roll:.4},{pitch:.4},{yaw:.4},{p:.4},{q:.4},{r:.4}\n");
        if k % 4 == 0 {
            let n = |rng: &mut Rng| 0.003 * rng.normal();
            nav += &format!(
                "{t:.2},{:.4},{:.4},{:.4}\n",
                x[0] + n(&mut rng),
                x[1] + n(&mut rng),
                x[2] + n(&mut rng)
            );
            depth += &format!("{t:.2},{:.3}\n", x[9] + 0.01 * rng.normal());
        }
    }
    let what = if d.manoeuvres {
        "zig-zag heading, depth undulating 1-5 m, fin dither"
    } else {
        "constant depth 3 m and heading, constant propeller speed"
    };
    let meta = format!(
        "role: {}\ndescription: \"AUV twin (synthetic): {what}, seed {}\"\n",
        d.role, d.seed
    );
    vec![
        ("run.yaml", meta),
        ("actuators.csv", act),
        ("nav.csv", nav),
        ("imu.csv", imu),
        ("depth.csv", depth),
    ]
}

/// `truth/parameters.csv` in the identifier's names.
pub fn truth_csv() -> String {
    let mut s = String::from("name,value\n");
    for ((n, _), v) in hydrofit_core::model::finned::NAMES.iter().zip(TRUTH) {
        s += &format!("{n},{v}\n");
    }
    s
}

pub fn write_runs(
    cases_dir: &std::path::Path,
    truth_dir: &std::path::Path,
    seed: u64,
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    let mut out = Vec::new();
    for d in default_dives() {
        let rec = fly(&d);
        let mut csv = String::from("t,u,v,w,p,q,r,roll_rad,pitch_rad,yaw_rad,depth_m\n");
        // The true motion at 10 Hz, to 1e-6: what the report's fusion accuracy reads.
        for (k, t) in rec.t.iter().enumerate().step_by(2) {
            csv += &format!("{t:.2}");
            for v in rec.x[k] {
                csv += &format!(",{v:.6}");
            }
            csv.push('\n');
        }
        out.push(super::write_run(
            cases_dir,
            truth_dir,
            &d.name,
            &files(&d, &rec, seed),
            &csv,
            &d,
        )?);
    }
    hydrofit_core::fsutil::write_atomic(
        &truth_dir.join("coefficients.csv"),
        truth_csv().as_bytes(),
    )?;
    Ok(out)
}
