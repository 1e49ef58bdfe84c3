//! Every format's mapping checked against the target's own documented force equation: a
//! random model (coupled, with buoyancy) is written, the target's numbers are read from the
//! file as the target reads them (its frame, its signs), the target's equation is evaluated on
//! random states, and the force must be hydrofit's to 1e-9. Then every format reads back to
//! the model it was written from.

use super::*;
use crate::core::model::dynamics::{coriolis_full, hydro_force_at};
use crate::core::model::{Hydro, Vec6};
use crate::core::rng::Rng;

fn random_model(rng: &mut Rng, full_quadratic: bool) -> Model {
    let mut h = Hydro::default();
    let u = |rng: &mut Rng, a: f64, b: f64| a + (b - a) * rng.uniform();
    for i in 0..6 {
        for j in i..6 {
            let x = if i == j {
                u(rng, -40.0, -1.0)
            } else {
                u(rng, -2.0, 2.0)
            };
            h.added[i][j] = x;
            h.added[j][i] = x;
        }
        for j in 0..6 {
            h.lin[i][j] = if i == j {
                u(rng, -30.0, -1.0)
            } else {
                u(rng, -3.0, 3.0)
            };
            for k in 0..6 {
                let diag = k == i && i == j;
                if diag || full_quadratic {
                    h.quad[k][i][j] = if diag {
                        u(rng, -90.0, -5.0)
                    } else {
                        u(rng, -4.0, 4.0)
                    };
                }
            }
        }
    }
    h.net_weight = u(rng, -8.0, 8.0);
    h.moment = [u(rng, -1.0, 1.0), u(rng, -1.0, 1.0), u(rng, 1.0, 5.0)];
    Model {
        name: "random vehicle".into(),
        mass_kg: 30.0,
        inertia_kg_m2: [1.1, 1.7, 2.3],
        dofs: crate::core::dof::Dof::ALL.to_vec(),
        hydro: h,
        command_lag_s: 0.0,
        provenance: Provenance {
            hydrofit: "test".into(),
            stage: "fit".into(),
            method: "pem".into(),
            inputs: vec![InputFile::new("cases/pool/a/run.yaml", "00ff")],
            not_identifiable: vec![],
        },
    }
}

fn random_state(rng: &mut Rng) -> (Vec6, Vec6, [f64; 3]) {
    let v = |rng: &mut Rng| std::array::from_fn(|_| 2.0 * rng.uniform() - 1.0);
    let (phi, theta) = (0.6 * rng.uniform() - 0.3, 0.6 * rng.uniform() - 0.3);
    (
        v(rng),
        v(rng),
        crate::core::model::dynamics::gravity_body(phi, theta),
    )
}

/// hydrofit's hydrodynamic force on the body, without the constant force (no format holds it).
fn hydrofit_force(h: &Hydro, nu: &Vec6, nu_dot: &Vec6, g: &[f64; 3]) -> Vec6 {
    let mut h = *h;
    h.constant = [0.0; 6];
    hydro_force_at(&h, nu, nu_dot, g).map(|x| -x)
}

fn close(a: &Vec6, b: &Vec6, what: &str) {
    for i in 0..6 {
        let tol = 1e-9 * (1.0 + a[i].abs().max(b[i].abs()));
        assert!((a[i] - b[i]).abs() <= tol, "{what}: {a:?} against {b:?}");
    }
}

/// C_A(nu) nu, Fossen eq. 6.43, for a positive M_A.
fn ca(ma: &[[f64; 6]; 6], nu: &Vec6) -> Vec6 {
    coriolis_full(ma, nu)
}

fn mat_vec(a: &[[f64; 6]; 6], x: &Vec6) -> Vec6 {
    std::array::from_fn(|i| (0..6).map(|j| a[i][j] * x[j]).sum())
}

/// The restoring force of weight W at the origin and buoyancy B at r_B (FRD), g_b the unit
/// gravity: [(W-B) g_b; r_B x (-B g_b)].
fn restoring(w_minus_b: f64, b: f64, r_b: [f64; 3], g: &[f64; 3]) -> Vec6 {
    let f = g.map(|x| -b * x);
    let m = [
        r_b[1] * f[2] - r_b[2] * f[1],
        r_b[2] * f[0] - r_b[0] * f[2],
        r_b[0] * f[1] - r_b[1] * f[0],
    ];
    [
        w_minus_b * g[0],
        w_minus_b * g[1],
        w_minus_b * g[2],
        m[0],
        m[1],
        m[2],
    ]
}

fn tag_numbers(doc: &roxmltree::Document, tag: &str) -> Vec<f64> {
    doc.descendants()
        .find(|n| n.has_tag_name(tag))
        .and_then(|n| n.text())
        .map(|s| s.split_whitespace().map(|x| x.parse().unwrap()).collect())
        .unwrap_or_default()
}

#[test]
fn uuv_simulators_equation_on_the_written_numbers_is_hydrofits_force() {
    let mut rng = Rng::new(3);
    let m = random_model(&mut rng, false);
    let text = export(&m, Format::Uuv).text;
    let doc = roxmltree::Document::parse(&text).unwrap();
    let ma = tag_numbers(&doc, "added_mass");
    let l = tag_numbers(&doc, "linear_damping");
    let q = tag_numbers(&doc, "quadratic_damping");
    let ma: [[f64; 6]; 6] = std::array::from_fn(|i| std::array::from_fn(|j| ma[6 * i + j]));
    let l: [[f64; 6]; 6] = std::array::from_fn(|i| std::array::from_fn(|j| l[6 * i + j]));
    let (v, rho) = (
        tag_numbers(&doc, "volume")[0],
        tag_numbers(&doc, "fluid_density")[0],
    );
    let cob = tag_numbers(&doc, "center_of_buoyancy");
    let b = rho * v * 9.80665;
    for _ in 0..20 {
        let (nu, nu_dot, g) = random_state(&mut rng);
        // HMFossen: -M_A nu_dot - C_A(nu) nu + (L + diag(q)|nu|) nu; the buoyancy at the
        // centre of buoyancy, given in the link's FLU frame.
        let (a, c, d) = (mat_vec(&ma, &nu_dot), ca(&ma, &nu), mat_vec(&l, &nu));
        let r = restoring(m.mass_kg * 9.80665 - b, b, [cob[0], -cob[1], -cob[2]], &g);
        let tau: Vec6 =
            std::array::from_fn(|i| -a[i] - c[i] + d[i] + q[i] * nu[i].abs() * nu[i] + r[i]);
        close(
            &tau,
            &hydrofit_force(&m.hydro, &nu, &nu_dot, &g),
            "uuv_simulator",
        );
    }
}

#[test]
fn gz_sims_equation_in_its_frame_on_the_written_numbers_is_hydrofits_force() {
    let mut rng = Rng::new(5);
    let m = random_model(&mut rng, true);
    let text = export(&m, Format::Gazebo).text;
    let doc = roxmltree::Document::parse(&text).expect("a real XML parser reads the SDF");
    assert_eq!(doc.root_element().attribute("version"), Some("1.11"));
    // The target's numbers, as gz reads them: FLU, SNAME signs.
    let plugin = doc
        .descendants()
        .find(|n| n.has_tag_name("plugin"))
        .unwrap();
    let (mut l, mut qa) = ([[0.0; 6]; 6], [[[0.0; 6]; 6]; 6]);
    for c in plugin
        .children()
        .filter(|c| c.is_element() && c.tag_name().name() != "link_name")
    {
        let (i, j, k, _) = gazebo::coefficient(c.tag_name().name())
            .unwrap_or_else(|| panic!("{}", c.tag_name().name()));
        let x: f64 = c.text().unwrap().parse().unwrap();
        match k {
            None => l[i][j] = x,
            Some(k) => qa[i][j][k] = x,
        }
    }
    let fam = doc
        .descendants()
        .find(|n| n.has_tag_name("fluid_added_mass"))
        .unwrap();
    let mut ma = [[0.0; 6]; 6];
    for c in fam.children().filter(|c| c.is_element()) {
        let n = c.tag_name().name().as_bytes();
        let idx = |b: u8| "xyzpqr".bytes().position(|x| x == b).unwrap();
        let (i, j) = (idx(n[0]), idx(n[1]));
        let x: f64 = c.text().unwrap().parse().unwrap();
        (ma[i][j], ma[j][i]) = (x, x);
    }
    let col = doc
        .descendants()
        .find(|n| n.has_tag_name("collision"))
        .unwrap();
    let pose: Vec<f64> = col
        .descendants()
        .find(|n| n.has_tag_name("pose"))
        .unwrap()
        .text()
        .unwrap()
        .split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect();
    let size: Vec<f64> = col
        .descendants()
        .find(|n| n.has_tag_name("size"))
        .unwrap()
        .text()
        .unwrap()
        .split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect();
    let b = 1000.0 * 9.80665 * size.iter().product::<f64>();
    for _ in 0..20 {
        let (nu, nu_dot, g) = random_state(&mut rng);
        let t = |x: &Vec6| -> Vec6 { std::array::from_fn(|i| FLU[i] * x[i]) };
        let (n, nd) = (t(&nu), t(&nu_dot));
        // gz: -M_A nu_dot - C_A(nu) nu (DART, fluid_added_mass) + D(nu) nu, in FLU.
        let (a, c, d) = (mat_vec(&ma, &nd), ca(&ma, &n), mat_vec(&l, &n));
        let tau_flu: Vec6 = std::array::from_fn(|i| {
            let q: f64 = (0..6)
                .flat_map(|j| (0..6).map(move |k| (j, k)))
                .map(|(j, k)| qa[i][j][k] * n[j] * n[k].abs())
                .sum();
            -a[i] - c[i] + d[i] + q
        });
        // The Buoyancy system's box at its pose (FLU), weight at the origin.
        let r = restoring(
            m.mass_kg * 9.80665 - b,
            b,
            [pose[0], -pose[1], -pose[2]],
            &g,
        );
        let tau: Vec6 = std::array::from_fn(|i| FLU[i] * tau_flu[i] + r[i]);
        close(&tau, &hydrofit_force(&m.hydro, &nu, &nu_dot, &g), "gz-sim");
    }
}

#[test]
fn mss_matrices_in_fossens_equation_are_hydrofits_force() {
    let mut rng = Rng::new(7);
    let m = random_model(&mut rng, true);
    let text = export(&m, Format::Mss).text;
    assert!(text.starts_with("function vehicle = hydrofit_fit()"));
    let r = import(Format::Mss, &text).unwrap();
    // MSS's matrices (positive), as the file defines them.
    let ma = r.hydro.added.map(|x| x.map(|y| -y));
    let d = r.hydro.lin.map(|x| x.map(|y| -y));
    for _ in 0..20 {
        let (nu, nu_dot, g) = random_state(&mut rng);
        let (a, c, lin) = (mat_vec(&ma, &nu_dot), ca(&ma, &nu), mat_vec(&d, &nu));
        let tau: Vec6 = std::array::from_fn(|i| {
            let q: f64 = (0..6)
                .map(|k| nu[k].abs() * (0..6).map(|j| -r.hydro.quad[k][i][j] * nu[j]).sum::<f64>())
                .sum();
            -a[i] - c[i] - lin[i] - q
        });
        let rest = restoring(r.hydro.net_weight, 0.0, [0.0; 3], &g);
        let mg: Vec6 = {
            let e = r.hydro.moment;
            let mm = [
                e[1] * g[2] - e[2] * g[1],
                e[2] * g[0] - e[0] * g[2],
                e[0] * g[1] - e[1] * g[0],
            ];
            [rest[0], rest[1], rest[2], mm[0], mm[1], mm[2]]
        };
        let tau: Vec6 = std::array::from_fn(|i| tau[i] + mg[i]);
        close(&tau, &hydrofit_force(&m.hydro, &nu, &nu_dot, &g), "MSS");
    }
}

#[test]
fn every_format_reads_back_to_the_model_it_was_written_from() {
    let mut rng = Rng::new(11);
    let full = random_model(&mut rng, true);
    let diag = random_model(&mut rng, false);
    for (f, m) in [
        (Format::Yaml, &full),
        (Format::Mss, &full),
        (Format::Gazebo, &full),
        (Format::Uuv, &diag),
    ] {
        let e = export(m, f);
        let r = import(f, &e.text).unwrap_or_else(|err| panic!("{f:?}: {err}\n{}", e.text));
        let (a, b) = (&m.hydro, &r.hydro);
        let pairs = a
            .added
            .iter()
            .flatten()
            .zip(b.added.iter().flatten())
            .chain(a.lin.iter().flatten().zip(b.lin.iter().flatten()))
            .chain(
                a.quad
                    .iter()
                    .flatten()
                    .flatten()
                    .zip(b.quad.iter().flatten().flatten()),
            )
            .chain(std::iter::once((&a.net_weight, &b.net_weight)))
            .chain(a.moment.iter().zip(&b.moment));
        for (x, y) in pairs {
            assert!(
                (x - y).abs() <= 1e-9 * (1.0 + x.abs()),
                "{f:?}: {x} read back as {y}"
            );
        }
        assert!(
            (m.mass_kg - r.mass_kg).abs() < 1e-12 && m.inertia_kg_m2 == r.inertia_kg_m2,
            "{f:?}"
        );
        assert!(
            e.text.contains("00ff cases/pool/a/run.yaml"),
            "{f:?}: the provenance travels"
        );
    }
    // hydrofit's own file is exact, lag and provenance included.
    let mut m = full.clone();
    m.command_lag_s = 0.2;
    assert_eq!(
        import(Format::Yaml, &export(&m, Format::Yaml).text).unwrap(),
        m
    );
}

#[test]
fn what_a_format_cannot_hold_is_listed() {
    let mut rng = Rng::new(13);
    let mut m = random_model(&mut rng, true);
    m.hydro.constant = [0.0, 0.0, -6.0, 0.0, 0.0, 0.0];
    m.command_lag_s = 0.25;
    let uuv = export(&m, Format::Uuv);
    let said = uuv.left_out.join("\n");
    assert!(
        said.contains("cross terms") && said.contains("X_0..N_0") && said.contains("T_cmd"),
        "{said}"
    );
    assert!(
        uuv.text
            .contains("left out: the quadratic drag's cross terms")
    );
    let sf = export(&m, Format::Stonefish);
    assert!(sf.left_out[0].contains("added mass and the linear and quadratic drag"));
    roxmltree::Document::parse(&sf.text).unwrap();
    assert!((import(Format::Stonefish, &sf.text).unwrap().mass_kg - 30.0).abs() < 1e-12);
}
