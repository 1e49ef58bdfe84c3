//! A MATLAB function in the style of Fossen's Marine Systems Simulator (MSS, MIT licence):
//! the matrices of `M nu_dot + C(nu) nu + D(nu) nu + g(eta) = tau` in MSS's own conventions,
//! body frame x forward, y starboard, z down (MSS's FRD), with M_A and D positive:
//!
//! - `MRB` (rigid body, about the centre of gravity), `MA = -[added]` (positive definite);
//! - `D = -lin` (positive linear damping) and `Dq(:,:,k) = -quad_k`, the damping per |nu(k)|:
//!   D(nu) = D + sum_k |nu(k)| Dq(:,:,k);
//! - `C_A(nu)` from MA as MSS's `m2c(MA, nu)` forms it (Fossen 2021 eq. 6.43);
//! - `W - B` (`WminusB`, N) and the moment of weight and buoyancy `eta` (N m), the restoring
//!   force g = -[(W-B) g_b; eta x g_b] with g_b the unit gravity in the body frame;
//! - `tau0`, a constant generalised force on the body (buoyancy, a tether, an offset);
//! - `T_cmd`, the command lag (s).
//!
//! The function also returns `tau_hyd = @(nu, nu_dot, g_b)`, the hydrodynamic force on the
//! body, for checking.

use super::{Model, num};
use crate::core::model::{Hydro, Mat6};

fn matrix(name: &str, a: &Mat6) -> String {
    let rows: Vec<String> = a
        .iter()
        .map(|r| r.iter().map(|x| num(*x)).collect::<Vec<_>>().join(" "))
        .collect();
    format!("vehicle.{name} = [{}];\n", rows.join("; "))
}

pub fn write(m: &Model) -> (String, Vec<String>) {
    let h = &m.hydro;
    let fname = format!(
        "hydrofit_{}",
        m.provenance
            .stage
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect::<String>()
    );
    let mut t = format!("function vehicle = {fname}()\n");
    for l in super::header(m, "MSS") {
        t += &format!("% {l}\n");
    }
    t += "% M nu_dot + C_A(nu) nu + (D + sum_k |nu(k)| Dq(:,:,k)) nu + g = tau + tau0 (rigid-body C_RB is MSS's own)\n";
    let rigid = m.rigid();
    let mrb: Mat6 =
        std::array::from_fn(|i| std::array::from_fn(|j| if i == j { rigid[i] } else { 0.0 }));
    t += &matrix("MRB", &mrb);
    t += &matrix("MA", &h.added.map(|r| r.map(|x| -x)));
    t += &matrix("D", &h.lin.map(|r| r.map(|x| -x)));
    t += "vehicle.Dq = zeros(6, 6, 6);\n";
    for (k, q) in h.quad.iter().enumerate() {
        if q.iter().flatten().any(|x| *x != 0.0) {
            let rows: Vec<String> = q
                .iter()
                .map(|r| r.iter().map(|x| num(-x)).collect::<Vec<_>>().join(" "))
                .collect();
            t += &format!("vehicle.Dq(:,:,{}) = [{}];\n", k + 1, rows.join("; "));
        }
    }
    t += &format!("vehicle.WminusB = {};\n", num(h.net_weight));
    t += &format!("vehicle.eta = [{}];\n", h.moment.map(num).join(" "));
    t += &format!("vehicle.tau0 = [{}];\n", h.constant.map(num).join(" "));
    t += &format!("vehicle.T_cmd = {};\n", num(m.command_lag_s));
    // The thrusters' wrench is logged about their layout's origin; the model's moments are
    // about the centre of gravity, r_g from that origin.
    t += &format!("vehicle.r_g = [{}];\n", h.lever.map(num).join(" "));
    t += "vehicle.tau_cg = @(tau) [tau(1:3); tau(4:6) - cross(vehicle.r_g(:), tau(1:3))];\n";
    t += "S = @(a) [0 -a(3) a(2); a(3) 0 -a(1); -a(2) a(1) 0];\n";
    t += "m2c = @(M, nu) [zeros(3) -S(M(1:3,:)*nu); -S(M(1:3,:)*nu) -S(M(4:6,:)*nu)];\n";
    t += "Dnu = @(nu) vehicle.D + sum(reshape(abs(nu), 1, 1, 6) .* vehicle.Dq, 3);\n";
    t += "g = @(gb) -[vehicle.WminusB * gb; cross(vehicle.eta(:), gb)];\n";
    t += "vehicle.tau_hyd = @(nu, nu_dot, gb) -vehicle.MA * nu_dot - m2c(vehicle.MA, nu) * nu - Dnu(nu) * nu - g(gb) + vehicle.tau0(:);\n";
    t += "end\n";
    (t, Vec::new())
}

/// The numbers of `vehicle.<name> = [..];` (rows separated by `;`).
fn numbers(text: &str, name: &str) -> Option<Vec<f64>> {
    let key = format!("vehicle.{name} = ");
    let line = text.lines().find(|l| l.starts_with(&key))?;
    let body = line[key.len()..].trim_end_matches(';').trim();
    let body = body.trim_start_matches('[').trim_end_matches(']');
    body.split([' ', ';'])
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().ok())
        .collect()
}

fn mat(v: &[f64]) -> Option<Mat6> {
    (v.len() == 36).then(|| std::array::from_fn(|i| std::array::from_fn(|j| v[6 * i + j])))
}

pub fn read(text: &str) -> Result<Model, String> {
    let get = |n: &str| numbers(text, n).ok_or(format!("no readable `vehicle.{n} = [...]` line"));
    let m6 = |n: &str| get(n).and_then(|v| mat(&v).ok_or(format!("vehicle.{n} is not 6x6")));
    let mrb = m6("MRB")?;
    let mut h = Hydro {
        added: m6("MA")?.map(|r| r.map(|x| -x)),
        lin: m6("D")?.map(|r| r.map(|x| -x)),
        ..Hydro::default()
    };
    for k in 0..6 {
        if let Some(v) = numbers(text, &format!("Dq(:,:,{})", k + 1)) {
            h.quad[k] = mat(&v)
                .ok_or("a Dq slice is not 6x6")?
                .map(|r| r.map(|x| -x));
        }
    }
    h.net_weight = get("WminusB")?.first().copied().unwrap_or(0.0);
    let eta = get("eta")?;
    let tau0 = get("tau0")?;
    h.moment = std::array::from_fn(|i| eta.get(i).copied().unwrap_or(0.0));
    h.constant = std::array::from_fn(|i| tau0.get(i).copied().unwrap_or(0.0));
    if let Some(r) = numbers(text, "r_g") {
        h.lever = std::array::from_fn(|i| r.get(i).copied().unwrap_or(0.0));
    }
    let lag = numbers(text, "T_cmd")
        .and_then(|v| v.first().copied())
        .unwrap_or(0.0);
    Ok(Model {
        name: "MSS model".into(),
        mass_kg: mrb[0][0],
        inertia_kg_m2: [mrb[3][3], mrb[4][4], mrb[5][5]],
        dofs: crate::core::dof::Dof::ALL.to_vec(),
        hydro: h,
        command_lag_s: lag,
        provenance: Default::default(),
    })
}
