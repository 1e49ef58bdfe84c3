//! uuv_simulator's `fossen` hydrodynamic model (its `UnderwaterObjectPlugin`, Apache-2.0), as
//! the Gazebo block of a URDF/xacro with the base link's inertial:
//!
//! - `added_mass`: 36 numbers, row-major, positive (M_A = -[X_udot ..]);
//! - `linear_damping`: 36 numbers, row-major, negative (hydrofit's linear drag as it is);
//! - `quadratic_damping`: 6 numbers, negative: uuv_simulator uses only the diagonal, D(i,i)
//!   += q_i |nu_i| (its other quadratic terms are listed as left out);
//! - uuv_simulator turns the link's velocity from FLU into FRD itself (its `ToNED` flips y and
//!   z), so the coefficients are written in hydrofit's frame, unchanged; its
//!   `center_of_buoyancy` is not turned, so it is written in the link's FLU frame;
//! - buoyancy: `volume` V with rho V g = W - (W - B) (rho of `fluid_density`, 1000 here, a
//!   pool), at the centre of buoyancy r_B = -eta / B (the centre of gravity at the link's
//!   origin); `neutrally_buoyant` when the model has neither.
//!
//! Its force (HydrodynamicModel.cc, HMFossen): tau = -M_A nu_dot - C_A(nu) nu + (L +
//! diag(q) |nu|) nu, Fossen 2011 eq. 6.43 for C_A.

use super::{Model, num};
use crate::core::model::{Hydro, Mat6};

/// Standard gravity, and the water's density the buoyancy is written for.
const G: f64 = 9.80665;
const RHO: f64 = 1000.0;

fn row_major(a: &Mat6) -> String {
    a.iter()
        .flatten()
        .map(|x| num(*x))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The buoyancy's volume and centre (FLU), when the model has weight and buoyancy terms.
pub fn buoyancy(m: &Model) -> Option<(f64, [f64; 3])> {
    let h = &m.hydro;
    if h.net_weight == 0.0 && h.moment.iter().all(|x| *x == 0.0) {
        return None;
    }
    let b = m.mass_kg * G - h.net_weight;
    let r_b = h.moment.map(|x| -x / b);
    Some((b / (RHO * G), [r_b[0], -r_b[1], -r_b[2]]))
}

pub fn write(m: &Model) -> (String, Vec<String>) {
    let h = &m.hydro;
    let mut t = String::from("<?xml version=\"1.0\"?>\n<!--\n");
    for l in super::header(m, "uuv_simulator") {
        t += &format!("  {}\n", l.replace("--", "- -"));
    }
    let left = super::left_out(m, false, true);
    for l in &left {
        t += &format!("  left out: {}\n", l.replace("--", "- -"));
    }
    t += "-->\n<robot xmlns:xacro=\"http://www.ros.org/wiki/xacro\" name=\"hydrofit_model\">\n";
    let [ixx, iyy, izz] = m.inertia_kg_m2;
    t += &format!(
        "  <link name=\"base_link\">\n    <inertial>\n      <mass value=\"{}\"/>\n      <inertia ixx=\"{}\" ixy=\"0\" ixz=\"0\" iyy=\"{}\" iyz=\"0\" izz=\"{}\"/>\n    </inertial>\n  </link>\n",
        num(m.mass_kg),
        num(ixx),
        num(iyy),
        num(izz)
    );
    t += "  <gazebo>\n    <plugin name=\"uuv_plugin\" filename=\"libuuv_underwater_object_ros_plugin.so\">\n";
    t += &format!("      <fluid_density>{}</fluid_density>\n", num(RHO));
    t += "      <flow_velocity_topic>hydrodynamics/current_velocity</flow_velocity_topic>\n";
    t += "      <link name=\"base_link\">\n";
    match buoyancy(m) {
        Some((v, c)) => {
            t += "        <neutrally_buoyant>0</neutrally_buoyant>\n";
            t += &format!("        <volume>{}</volume>\n", num(v));
            t += &format!(
                "        <center_of_buoyancy>{}</center_of_buoyancy>\n",
                c.map(num).join(" ")
            );
        }
        None => {
            t += "        <neutrally_buoyant>1</neutrally_buoyant>\n        <volume>0</volume>\n        <center_of_buoyancy>0 0 0</center_of_buoyancy>\n"
        }
    }
    let quad: Vec<String> = (0..6).map(|i| num(h.quad[i][i][i])).collect();
    t += &format!(
        "        <hydrodynamic_model>\n          <type>fossen</type>\n          <added_mass>{}</added_mass>\n          <linear_damping>{}</linear_damping>\n          <quadratic_damping>{}</quadratic_damping>\n        </hydrodynamic_model>\n",
        row_major(&h.added.map(|r| r.map(|x| -x))),
        row_major(&h.lin),
        quad.join(" ")
    );
    t += "      </link>\n    </plugin>\n  </gazebo>\n</robot>\n";
    (t, left)
}

fn numbers(node: Option<roxmltree::Node>, what: &str) -> Result<Vec<f64>, String> {
    let Some(n) = node else { return Ok(Vec::new()) };
    n.text()
        .unwrap_or("")
        .split_whitespace()
        .map(|s| {
            s.parse()
                .map_err(|_| format!("{what}: `{s}` is not a number"))
        })
        .collect()
}

fn matrix(v: &[f64], what: &str) -> Result<Mat6, String> {
    match v.len() {
        0 => Ok([[0.0; 6]; 6]),
        6 => Ok(std::array::from_fn(|i| {
            std::array::from_fn(|j| if i == j { v[i] } else { 0.0 })
        })),
        36 => Ok(std::array::from_fn(|i| {
            std::array::from_fn(|j| v[6 * i + j])
        })),
        n => Err(format!(
            "{what} has {n} numbers; uuv_simulator takes 6 or 36"
        )),
    }
}

pub fn read(text: &str) -> Result<Model, String> {
    let doc = roxmltree::Document::parse(text).map_err(|e| format!("not XML: {e}"))?;
    let find = |name: &str| doc.descendants().find(|n| n.has_tag_name(name));
    let model = find("hydrodynamic_model").ok_or("no <hydrodynamic_model>")?;
    let child = |name: &str| model.children().find(|n| n.has_tag_name(name));
    let added = matrix(&numbers(child("added_mass"), "added_mass")?, "added_mass")?;
    let lin = matrix(
        &numbers(child("linear_damping"), "linear_damping")?,
        "linear_damping",
    )?;
    let quad = matrix(
        &numbers(child("quadratic_damping"), "quadratic_damping")?,
        "quadratic_damping",
    )?;
    let mut h = Hydro {
        added: added.map(|r| r.map(|x| -x)),
        lin,
        ..Hydro::default()
    };
    for (i, q) in quad.iter().enumerate() {
        h.quad[i][i][i] = q[i];
    }
    let inertial = find("inertial");
    let attr = |tag: &str, a: &str| -> f64 {
        inertial
            .and_then(|n| n.descendants().find(|c| c.has_tag_name(tag)))
            .and_then(|c| c.attribute(a))
            .and_then(|s| s.parse().ok())
            .unwrap_or(0.0)
    };
    let mass = attr("mass", "value");
    let neutral = numbers(find("neutrally_buoyant"), "neutrally_buoyant")?.first() == Some(&1.0);
    let volume = numbers(find("volume"), "volume")?
        .first()
        .copied()
        .unwrap_or(0.0);
    let rho = numbers(find("fluid_density"), "fluid_density")?
        .first()
        .copied()
        .unwrap_or(1028.0);
    let cob = numbers(find("center_of_buoyancy"), "center_of_buoyancy")?;
    if !neutral && volume > 0.0 && cob.len() == 3 {
        let b = rho * volume * G;
        h.net_weight = mass * G - b;
        // r_B in FRD from the FLU centre of buoyancy; eta = -B r_B.
        h.moment = [-b * cob[0], b * cob[1], b * cob[2]];
    }
    Ok(Model {
        name: "uuv_simulator model".into(),
        mass_kg: mass,
        inertia_kg_m2: [
            attr("inertia", "ixx"),
            attr("inertia", "iyy"),
            attr("inertia", "izz"),
        ],
        dofs: crate::core::dof::Dof::ALL.to_vec(),
        hydro: h,
        command_lag_s: 0.0,
        provenance: Default::default(),
    })
}
