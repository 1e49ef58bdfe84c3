//! An SDF model for gz-sim (SDF 1.11, gz Harmonic and later; gz-sim's Hydrodynamics system,
//! Apache-2.0). gz links are x forward, y left, z up (REP-103), so every coefficient is
//! turned into that frame: entry (i, j) of a matrix changes sign when exactly one of i, j is
//! v, w, q or r (a quadratic term c nu_j |nu_k| likewise, by i and j); diagonal terms do not.
//!
//! - mass and principal inertia in the link's `<inertial>` (the centre of gravity at the link's
//!   origin);
//! - the added mass as the link's `<fluid_added_mass>` (21 elements of the symmetric M_A,
//!   positive), which DART integrates implicitly with its Coriolis term -C_A(nu) nu; the
//!   Hydrodynamics system's own `<xDotU>` terms are not used (their Coriolis term has the
//!   opposite sign in the gz-sim sources of 2026, and the system refuses both at once);
//! - damping in the Hydrodynamics system: `<xU>` .. (linear, force i per velocity j) and
//!   `<xUabsV>` .. (force i per nu_j |nu_k|), negative (SNAME), defaults 0;
//! - buoyancy, when the model has it: gz's Buoyancy system takes it from the link's collision
//!   volume, so a box collision of volume B / (rho g) at the centre of buoyancy carries it
//!   (add `gz-sim-buoyancy-system` with `uniform_fluid_density` 1000 to the world).
//!
//! The force the body gets: -M_A nu_dot - C_A(nu) nu + D(nu) nu with D(nu)_ij = L_ij + sum_k
//! Qabs_ijk |nu_k| (Hydrodynamics.cc, PreUpdate).

use super::{FLU, Model, flip, num};
use crate::core::model::{Hydro, Mat6};

const G: f64 = 9.80665;
const RHO: f64 = 1000.0;
const FORCE: [char; 6] = ['x', 'y', 'z', 'k', 'm', 'n'];
const VEL: [char; 6] = ['U', 'V', 'W', 'P', 'Q', 'R'];
/// The 21 elements of `fluid_added_mass`, upper triangle by rows.
const ADDED: [(&str, usize, usize); 21] = [
    ("xx", 0, 0),
    ("xy", 0, 1),
    ("xz", 0, 2),
    ("xp", 0, 3),
    ("xq", 0, 4),
    ("xr", 0, 5),
    ("yy", 1, 1),
    ("yz", 1, 2),
    ("yp", 1, 3),
    ("yq", 1, 4),
    ("yr", 1, 5),
    ("zz", 2, 2),
    ("zp", 2, 3),
    ("zq", 2, 4),
    ("zr", 2, 5),
    ("pp", 3, 3),
    ("pq", 3, 4),
    ("pr", 3, 5),
    ("qq", 4, 4),
    ("qr", 4, 5),
    ("rr", 5, 5),
];

fn comment(m: &Model, left: &[String]) -> String {
    let mut t = String::from("<!--\n");
    for l in super::header(m, "gz-sim SDF") {
        t += &format!("  {}\n", l.replace("--", "- -"));
    }
    for l in left {
        t += &format!("  left out: {}\n", l.replace("--", "- -"));
    }
    t + "-->\n"
}

fn inertial(m: &Model) -> String {
    let [ixx, iyy, izz] = m.inertia_kg_m2;
    let ma = flip(&m.hydro.added.map(|r| r.map(|x| -x)));
    let added: String = ADDED
        .iter()
        .filter(|(_, i, j)| ma[*i][*j] != 0.0)
        .map(|(n, i, j)| format!("<{n}>{}</{n}>", num(ma[*i][*j])))
        .collect();
    format!(
        "      <inertial>\n        <mass>{}</mass>\n        <inertia><ixx>{}</ixx><ixy>0</ixy><ixz>0</ixz><iyy>{}</iyy><iyz>0</iyz><izz>{}</izz></inertia>\n        <fluid_added_mass>{added}</fluid_added_mass>\n      </inertial>\n",
        num(m.mass_kg),
        num(ixx),
        num(iyy),
        num(izz)
    )
}

fn damping(h: &Hydro) -> String {
    let lin = flip(&h.lin);
    let mut t = String::new();
    for i in 0..6 {
        for j in 0..6 {
            if lin[i][j] != 0.0 {
                let n = format!("{}{}", FORCE[i], VEL[j]);
                t += &format!("      <{n}>{}</{n}>\n", num(lin[i][j]));
            }
        }
    }
    for (k, q) in h.quad.iter().enumerate() {
        for i in 0..6 {
            for j in 0..6 {
                let c = FLU[i] * FLU[j] * q[i][j];
                if c != 0.0 {
                    let n = format!("{}{}abs{}", FORCE[i], VEL[j], VEL[k]);
                    t += &format!("      <{n}>{}</{n}>\n", num(c));
                }
            }
        }
    }
    t
}

pub fn write(m: &Model) -> (String, Vec<String>) {
    let left = super::left_out(m, true, true);
    let mut t = String::from("<?xml version=\"1.0\"?>\n");
    t += &comment(m, &left);
    t += "<sdf version=\"1.11\">\n  <model name=\"hydrofit_model\">\n    <link name=\"base_link\">\n";
    t += &inertial(m);
    if let Some((v, c)) = super::uuv::buoyancy(m) {
        let side = v.cbrt();
        t += &format!(
            "      <collision name=\"buoyancy\">\n        <pose>{} 0 0 0</pose>\n        <geometry><box><size>{s} {s} {s}</size></box></geometry>\n      </collision>\n",
            c.map(num).join(" "),
            s = num(side)
        );
    }
    t += "    </link>\n";
    t += "    <plugin filename=\"gz-sim-hydrodynamics-system\" name=\"gz::sim::systems::Hydrodynamics\">\n      <link_name>base_link</link_name>\n";
    t += &damping(&m.hydro);
    t += "    </plugin>\n  </model>\n</sdf>\n";
    (t, left)
}

/// Reads an SDF with the Hydrodynamics system (and the link's inertial, fluid added mass and
/// buoyancy collision) back into hydrofit's frame. `<xDotU>`-style added mass is read too.
pub fn read(text: &str) -> Result<Model, String> {
    let doc = roxmltree::Document::parse(text).map_err(|e| format!("not XML: {e}"))?;
    let plugin = doc
        .descendants()
        .find(|n| {
            n.has_tag_name("plugin")
                && n.attribute("name")
                    .is_some_and(|a| a.contains("Hydrodynamics"))
        })
        .ok_or("no gz-sim Hydrodynamics system (plugin) in the file")?;
    let value = |n: roxmltree::Node| -> Result<f64, String> {
        let s = n.text().unwrap_or("").trim();
        s.parse()
            .map_err(|_| format!("<{}>: `{s}` is not a number", n.tag_name().name()))
    };
    let mut h = Hydro::default();
    let mut added_flu: Mat6 = [[0.0; 6]; 6];
    for c in plugin.children().filter(|c| c.is_element()) {
        let name = c.tag_name().name();
        if let Some((i, j, k, dot)) = coefficient(name) {
            let x = value(c)?;
            match (k, dot) {
                (_, true) => added_flu[i][j] = -x,
                (None, false) => h.lin[i][j] = FLU[i] * FLU[j] * x,
                (Some(k), false) => h.quad[k][i][j] = FLU[i] * FLU[j] * x,
            }
        }
    }
    if let Some(fam) = doc
        .descendants()
        .find(|n| n.has_tag_name("fluid_added_mass"))
    {
        for (n, i, j) in ADDED {
            if let Some(c) = fam.children().find(|c| c.has_tag_name(n)) {
                let x = value(c)?;
                added_flu[i][j] = x;
                added_flu[j][i] = x;
            }
        }
    }
    h.added = flip(&added_flu).map(|r| r.map(|x| -x));
    read_body(&doc, h)
}

/// The inertial and the buoyancy collision of the model's link.
fn read_body(doc: &roxmltree::Document, mut h: Hydro) -> Result<Model, String> {
    let number = |tag: &str| -> f64 {
        doc.descendants()
            .find(|n| n.has_tag_name(tag))
            .and_then(|n| n.text())
            .and_then(|s| s.trim().parse().ok())
            .unwrap_or(0.0)
    };
    let mass = number("mass");
    if let Some(col) = doc
        .descendants()
        .find(|n| n.has_tag_name("collision") && n.attribute("name") == Some("buoyancy"))
    {
        let nums = |tag: &str| -> Vec<f64> {
            col.descendants()
                .find(|n| n.has_tag_name(tag))
                .and_then(|n| n.text())
                .map(|s| {
                    s.split_whitespace()
                        .filter_map(|x| x.parse().ok())
                        .collect()
                })
                .unwrap_or_default()
        };
        let (pose, size) = (nums("pose"), nums("size"));
        if pose.len() >= 3 && size.len() == 3 {
            let b = RHO * G * size[0] * size[1] * size[2];
            h.net_weight = mass * G - b;
            h.moment = [-b * pose[0], b * pose[1], b * pose[2]];
        }
    }
    Ok(Model {
        name: "gz-sim model".into(),
        mass_kg: mass,
        inertia_kg_m2: [number("ixx"), number("iyy"), number("izz")],
        dofs: crate::core::dof::Dof::ALL.to_vec(),
        hydro: h,
        command_lag_s: 0.0,
        provenance: Default::default(),
    })
}

/// The (force row, velocity column, |velocity| index, added mass?) a parameter names:
/// `xU`, `xUabsV`, `xDotU`.
pub(crate) fn coefficient(name: &str) -> Option<(usize, usize, Option<usize>, bool)> {
    let mut ch = name.chars();
    let first = ch.next()?;
    let i = FORCE.iter().position(|c| *c == first)?;
    let rest: String = ch.collect();
    let vel = |s: &str| VEL.iter().position(|c| s == c.to_string());
    if let Some(v) = rest.strip_prefix("Dot") {
        return Some((i, vel(v)?, None, true));
    }
    if let Some((a, b)) = rest.split_once("abs") {
        return Some((i, vel(a)?, Some(vel(b)?), false));
    }
    Some((i, vel(&rest)?, None, false))
}
