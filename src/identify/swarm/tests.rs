use super::*;
use crate::core::dof::Dof;
use crate::core::model::ParamLayout;

#[test]
fn blocked_population_kernels_equal_the_one_particle_cost() {
    // 1,027 rows (not a multiple of the 4-row tile or the 1,024-row block) and 37
    // particles (two tiles of 16, none of 8, five single): every path of the kernels.
    let layout = ParamLayout::new(&[Dof::Surge, Dof::Sway, Dof::Heave, Dof::Yaw]);
    let p = layout.len();
    let mut rng = Rng::new(9);
    let n = 1027;
    let dofs = [Dof::Surge, Dof::Sway, Dof::Heave, Dof::Yaw];
    let reg = Regression {
        layout,
        phi: (0..n * p).map(|_| rng.normal()).collect(),
        y: (0..n).map(|_| 10.0 * rng.normal()).collect(),
        row_dof: (0..n).map(|i| dofs[i % 4]).collect(),
    };
    let mass = [35.2, 35.2, 35.2, 0.0, 0.0, 1.38];
    for norm in [Norm::L1, Norm::L2] {
        let problem = Problem::new(&reg, &mass, norm);
        let pop: Vec<Vec<f64>> = (0..37).map(|_| problem.random_point(&mut rng)).collect();
        let all = problem.cost_all(&pop);
        for (x, c) in pop.iter().zip(&all) {
            let one = match norm {
                Norm::L2 => problem.cost(x),
                Norm::L1 => {
                    let s: f64 = (0..n)
                        .map(|i| {
                            (problem.w[i]
                                * (reg.y[i]
                                    - reg.row(i).iter().zip(x).map(|(a, t)| a * t).sum::<f64>()))
                            .abs()
                        })
                        .sum();
                    s / (n as f64).sqrt()
                }
            };
            assert!(
                (c - one).abs() <= 1e-9 * one.abs().max(1.0),
                "{norm:?}: {c} vs {one}"
            );
        }
    }
}

/// A yaw with a constant moment drifts at a steady rate while its command is zero: there the
/// force over speed the search box was bounded by is 0, and the linear drag was pinned at it.
/// The box now holds the least-squares value, the drag is found, and its standard error is
/// the regression's, not the restarts' agreement (1e-9 of the value).
#[test]
fn a_drift_under_a_constant_moment_does_not_pin_the_drag() {
    use crate::core::model::{Plant, Vehicle};
    use crate::core::response::{Response, Series, Source, differentiate};
    use crate::identify::{Method, Options};
    let mut vehicle = Vehicle::reference();
    vehicle.dofs = vec![Dof::Yaw];
    vehicle.constant_force = vec![Dof::Yaw];
    let layout = ParamLayout::of(&vehicle);
    let truth = |name: &str| match name {
        "N_rdot" => -0.5,
        "N_r" => -8.0,
        "N_rr" => -4.0,
        "N_0" => 1.5,
        other => panic!("unexpected {other}"),
    };
    let theta: Vec<f64> = layout.names().iter().map(|n| truth(n)).collect();
    let plant = Plant::new(&vehicle, layout.to_hydro(&theta));
    let mut rng = Rng::new(4);
    let t: Vec<f64> = (0..2400).map(|k| k as f64 * 0.05).collect();
    let mut level = 0.0;
    let cmd: Vec<[f64; 6]> = (0..t.len())
        .map(|k| {
            if k % 60 == 0 {
                // A third of the holds are at zero command: the drift.
                let u = rng.uniform();
                level = if u < 1.0 / 3.0 {
                    0.0
                } else {
                    16.0 * (u - 2.0 / 3.0)
                };
            }
            [0.0, 0.0, 0.0, 0.0, 0.0, level]
        })
        .collect();
    let nu = plant.simulate(&t, &cmd, [0.0; 6], 0.01);
    let velocity: Vec<f64> = nu.iter().map(|v| v[5] + 0.005 * rng.normal()).collect();
    let series = Series {
        force: cmd.iter().map(|c| c[5]).collect(),
        accel: differentiate(&t, &velocity),
        velocity,
        force_source: Source::Column,
        accel_source: Source::Differentiated,
    };
    let run = Response {
        t,
        dofs: [(Dof::Yaw, series)].into_iter().collect(),
        attitude: Vec::new(),
    };
    let reg = Regression::build(&vehicle, &[&run], 0.0);
    let method = Method::parse("qpso", Default::default()).unwrap();
    let opts = method.options(Options {
        rigid_mass: vehicle.rigid_mass(),
        ..Options::default()
    });
    let fit = method.estimator.fit(&reg, &opts).unwrap();
    let n_r = fit.parameters.iter().find(|p| p.name == "N_r").unwrap();
    assert!(
        (n_r.value - -8.0).abs() < 0.15 * 8.0 && n_r.identifiable,
        "{n_r:?}"
    );
    assert!(
        n_r.stderr > 1e-4 * n_r.value.abs() && n_r.stderr < 0.1 * n_r.value.abs(),
        "{n_r:?}"
    );
}

/// An added mass beyond the default fit's prior is said in its note; one within it is not.
#[test]
fn an_added_mass_beyond_the_prior_is_said() {
    use crate::identify::{Estimate, Fit};
    let layout = ParamLayout::new(&[Dof::Surge, Dof::Yaw]);
    let rigid = [35.2, 35.2, 35.2, 0.0, 0.0, 1.38];
    let value = |name: &str| match name {
        "X_udot" => -3.0 * 35.2,
        "N_rdot" => -1.0,
        _ => -5.0,
    };
    let mut fit = Fit {
        parameters: (layout.names().iter())
            .map(|n| Estimate {
                name: n.clone(),
                value: value(n),
                unit: String::new(),
                stderr: 0.1,
                interval: None,
                identifiable: true,
                note: None,
            })
            .collect(),
        ..Fit::default()
    };
    let reg = Regression {
        layout,
        phi: Vec::new(),
        y: Vec::new(),
        row_dof: Vec::new(),
    };
    super::executor::say_beyond_prior(&mut fit, &reg, &rigid, &[2.0; 6]);
    let note = |n: &str| {
        let p = fit.parameters.iter().find(|p| p.name == n).unwrap();
        p.note.clone()
    };
    let x = note("X_udot").expect("X_udot at 3 times is beyond the prior");
    assert!(x.contains("3.0 times the rigid-body term 35.200"), "{x}");
    assert_eq!(note("N_rdot"), None);
    assert_eq!(note("X_u"), None);
}
