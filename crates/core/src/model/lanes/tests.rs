use super::*;
use crate::model::{Hydro, Vehicle};

/// Plants around the reference vehicle, each coefficient moved by up to +-40 %.
fn population(vehicle: &Vehicle, n: usize) -> Vec<Plant> {
    let h0 = Hydro::reference();
    (0..n)
        .map(|j| {
            let f =
                |i: usize, g: usize| 1.0 + 0.4 * (((j * 7 + i * 3 + g) % 11) as f64 / 5.0 - 1.0);
            let mut h = h0;
            for i in 0..6 {
                h.added[i][i] *= f(i, 0);
                h.lin[i][i] *= f(i, 1);
                h.quad[i][i][i] *= f(i, 2);
                h.constant[i] = 3.0 * (f(i, 3) - 1.0);
            }
            Plant::new(vehicle, h)
        })
        .collect()
}

fn check(vehicle: &Vehicle, lanes: usize) {
    check_plants(&population(vehicle, lanes));
}

/// Each lane of `plants`, simulated together, against the plant's own simulation.
fn check_plants(plants: &[Plant]) {
    let t: Vec<f64> = (0..400).map(|k| k as f64 * 0.025).collect();
    let tau: Vec<Vec6> = t
        .iter()
        .map(|&x| {
            let s = (0.7 * x).sin();
            [
                60.0 * s,
                25.0 * (1.3 * x).cos(),
                -30.0 * s,
                4.0 * s,
                -3.0 * s,
                8.0 * (0.9 * x).sin(),
            ]
        })
        .collect();
    let nu0 = [0.2, -0.1, 0.05, 0.0, 0.0, 0.1];
    let lp = LanePlants::new(plants);
    let mut got = vec![[[0.0; LANES]; 6]; t.len()];
    lp.simulate(&t, &tau, (nu0, [0.0; 2]), 0.01, &mut |k, nu| got[k] = *nu);
    for (l, p) in plants.iter().enumerate() {
        let want = p.simulate(&t, &tau, nu0, 0.01);
        for k in 0..t.len() {
            for i in 0..6 {
                let (a, b) = (got[k][i][l], want[k][i]);
                assert!(
                    (a - b).abs() <= 1e-11 * (1.0 + b.abs()),
                    "lane {l}, sample {k}, DOF {i}: {a} vs {b}"
                );
            }
        }
        assert!(
            want.last().unwrap().iter().any(|x| x.abs() > 0.05),
            "the plant moves"
        );
    }
}

#[test]
fn every_lane_follows_its_own_plant_in_four_dof() {
    check(&Vehicle::reference(), LANES);
    check(&Vehicle::reference(), 3);
}

/// A single plant runs one lane wide, to the bit what it gives beside seven others.
#[test]
fn a_single_plant_runs_alone_as_it_runs_in_a_population() {
    let v = Vehicle::reference();
    let plants = population(&v, LANES);
    check_plants(&plants[..1]);
    let t: Vec<f64> = (0..300).map(|k| k as f64 * 0.05).collect();
    let tau: Vec<Vec6> = (t.iter())
        .map(|&x| {
            [
                40.0 * x.sin(),
                20.0,
                -10.0 * x.cos(),
                0.0,
                0.0,
                6.0 * x.sin(),
            ]
        })
        .collect();
    let run = |lp: &LanePlants| {
        let mut out = Vec::new();
        lp.simulate(
            &t,
            &tau,
            ([0.1, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0; 2]),
            0.02,
            &mut |_, nu| out.push(std::array::from_fn::<f64, 6, _>(|i| nu[i][0])),
        );
        out
    };
    assert_eq!(
        run(&LanePlants::new(&plants[..1])),
        run(&LanePlants::new(&plants))
    );
}

/// A sway-yaw linear coupling (N_v, Y_r) runs in the lane kernel as the plant's own
/// coupled solve runs it.
#[test]
fn every_lane_follows_its_own_plant_with_cross_drag() {
    let v = Vehicle::reference();
    let plants: Vec<Plant> = (population(&v, LANES).into_iter().enumerate())
        .map(|(l, p)| {
            let mut h = p.hydro;
            h.lin[5][1] = 0.5 + 0.3 * l as f64;
            h.lin[1][5] = if l % 2 == 0 { -2.0 } else { 0.0 };
            Plant::new(&v, h)
        })
        .collect();
    assert!(plants[0].is_coupled(), "the reference simulates it coupled");
    assert_eq!(LanePlants::new(&plants).crosses, 1);
    check_plants(&plants);
}

/// Two linear couplings into one DOF (N_v and N_u in yaw), in some lanes one or none.
#[test]
fn every_lane_follows_its_own_plant_with_two_cross_terms() {
    let v = Vehicle::reference();
    let plants: Vec<Plant> = (population(&v, LANES).into_iter().enumerate())
        .map(|(l, p)| {
            let mut h = p.hydro;
            h.lin[5][1] = if l % 3 == 0 {
                0.0
            } else {
                0.5 + 0.3 * l as f64
            };
            h.lin[5][0] = if l % 2 == 0 { -0.4 * l as f64 } else { 0.0 };
            h.lin[1][5] = -1.0;
            Plant::new(&v, h)
        })
        .collect();
    assert_eq!(LanePlants::new(&plants).crosses, 2);
    check_plants(&plants);
}

#[test]
fn every_lane_follows_its_own_plant_in_six_dof() {
    let mut v = Vehicle::reference();
    v.dofs = crate::dof::Dof::ALL.to_vec();
    v.inertia_kg_m2.xx = 1.2;
    v.inertia_kg_m2.yy = 1.5;
    assert!(LanePlants::new(&population(&v, 1)).six_dof());
    check(&v, LANES);
}

/// Weight and buoyancy in the lane kernel: a six-DOF vehicle that a moment of buoyancy rights
/// and a net weight sinks, with a roll moment from the sway velocity (K_v), from a tilted
/// start. Each lane against the coupled kernel, which carries the gravity direction as this
/// one does (to rounding), and against the plant's own simulation, which integrates roll and
/// pitch angles instead (to 1e-5 relative: the two attitude integrations part by a few 1e-6).
#[test]
fn every_lane_follows_its_own_plant_with_weight_and_buoyancy() {
    let mut v = Vehicle::reference();
    v.dofs = crate::dof::Dof::ALL.to_vec();
    v.inertia_kg_m2.xx = 1.2;
    v.inertia_kg_m2.yy = 1.5;
    let plants: Vec<Plant> = (population(&v, LANES).into_iter().enumerate())
        .map(|(l, p)| {
            let mut h = p.hydro;
            h.net_weight = -2.0 + 0.5 * l as f64;
            h.moment = [0.0, 0.1 * l as f64, 3.0 + l as f64];
            h.lin[3][1] = 0.8;
            // Roll and pitch damped, as a vehicle's are (the reference has no terms there).
            for i in [3, 4] {
                h.lin[i][i] = -3.0;
                h.quad[i][i][i] = -1.0;
            }
            Plant::new(&v, h)
        })
        .collect();
    let lp = LanePlants::new(&plants);
    assert!(lp.att && lp.crosses == 1);
    let t: Vec<f64> = (0..400).map(|k| k as f64 * 0.025).collect();
    let tau: Vec<Vec6> = (t.iter())
        .map(|&x| {
            let s = (0.7 * x).sin();
            [
                12.0 * s,
                8.0 * (1.3 * x).cos(),
                -6.0 * s,
                2.0 * s,
                -1.5,
                3.0 * (0.9 * x).sin(),
            ]
        })
        .collect();
    let start = ([0.2, -0.1, 0.05, 0.1, -0.05, 0.1], [0.2, -0.15]);
    let mut got = vec![[[0.0; LANES]; 6]; t.len()];
    lp.simulate(&t, &tau, start, 0.01, &mut |k, nu| got[k] = *nu);
    let coupled = crate::model::lanes_coupled::CoupledLanes::new(&plants);
    let mut other = got.clone();
    coupled.simulate(&t, &tau, start, 0.01, &mut |k, nu| other[k] = *nu);
    for (l, p) in plants.iter().enumerate() {
        let want = p.simulate_from(&t, &tau, start.0, start.1, 0.01);
        let level = p.simulate_from(&t, &tau, start.0, [0.0; 2], 0.01);
        let mut apart: f64 = 0.0;
        for k in 0..t.len() {
            for i in 0..6 {
                let (a, b, c) = (got[k][i][l], other[k][i][l], want[k][i]);
                assert!(
                    (a - b).abs() <= 1e-10 * (1.0 + b.abs())
                        && (a - c).abs() <= 1e-5 * (1.0 + c.abs()),
                    "lane {l}, sample {k}, DOF {i}: {a} vs {b} (coupled kernel), {c} (plant)"
                );
                apart = apart.max((c - level[k][i]).abs());
            }
        }
        assert!(apart > 0.01, "the start's tilt matters ({apart})");
    }
}
