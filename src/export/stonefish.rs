//! Stonefish (GPL-3.0) computes a body's added mass and drag from its geometry and takes no
//! coefficients: its scenario format holds a body's mass, principal inertia and centre of
//! gravity (`<mass>`, `<inertia>`, `<cg>`), and per-axis weights of its drag integral
//! (`<hydrodynamics viscous_drag quadratic_drag>`) that are not hydrofit's coefficients. This
//! writes what it can hold, as a `<dynamic>` body to put in a robot, and lists every
//! coefficient it cannot, so a Stonefish user sets the geometry to match them.

use super::{Model, num};
use crate::core::model::Hydro;

pub fn write(m: &Model) -> (String, Vec<String>) {
    let mut left = vec![
        "the added mass and the linear and quadratic drag: Stonefish computes them from the body's geometry; choose a shape whose added mass and drag match those below".to_string(),
    ];
    left.extend(super::left_out(m, true, false));
    let mut t = String::from("<?xml version=\"1.0\"?>\n<!--\n");
    for l in super::header(m, "Stonefish") {
        t += &format!("  {}\n", l.replace("--", "- -"));
    }
    for l in &left {
        t += &format!("  left out: {}\n", l.replace("--", "- -"));
    }
    let h = &m.hydro;
    t += &format!(
        "  for reference: added mass X_udot..N_rdot {:?}, linear drag {:?}, quadratic drag {:?}\n",
        (0..6).map(|i| h.added[i][i]).collect::<Vec<_>>(),
        (0..6).map(|i| h.lin[i][i]).collect::<Vec<_>>(),
        (0..6).map(|i| h.quad[i][i][i]).collect::<Vec<_>>()
    );
    t += "-->\n";
    let [ixx, iyy, izz] = m.inertia_kg_m2;
    t += &format!(
        "<dynamic name=\"hydrofit_model\" type=\"model\" physics=\"submerged\" buoyant=\"true\">\n  <mass value=\"{}\"/>\n  <inertia xyz=\"{} {} {}\"/>\n  <cg xyz=\"0.0 0.0 0.0\" rpy=\"0.0 0.0 0.0\"/>\n</dynamic>\n",
        num(m.mass_kg),
        num(ixx),
        num(iyy),
        num(izz)
    );
    (t, left)
}

pub fn read(text: &str) -> Result<Model, String> {
    let doc = roxmltree::Document::parse(text).map_err(|e| format!("not XML: {e}"))?;
    let attr = |tag: &str, a: &str| {
        doc.descendants()
            .find(|n| n.has_tag_name(tag))
            .and_then(|n| n.attribute(a))
            .map(str::to_string)
    };
    let mass: f64 = attr("mass", "value")
        .and_then(|s| s.parse().ok())
        .ok_or("no <mass value=..> in the Stonefish body")?;
    let inertia: Vec<f64> = attr("inertia", "xyz")
        .map(|s| {
            s.split_whitespace()
                .filter_map(|x| x.parse().ok())
                .collect()
        })
        .unwrap_or_default();
    Ok(Model {
        name: "Stonefish body".into(),
        mass_kg: mass,
        inertia_kg_m2: std::array::from_fn(|i| inertia.get(i).copied().unwrap_or(0.0)),
        dofs: crate::core::dof::Dof::ALL.to_vec(),
        hydro: Hydro::default(),
        command_lag_s: 0.0,
        provenance: Default::default(),
    })
}
