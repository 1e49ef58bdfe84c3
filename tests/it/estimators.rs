//! Every estimator on the shipped twin CFD cases against the twin's truth (seed 001 Table 1),
//! and reproducibility of the stochastic ones.

use crate::common::*;
use hydrofit::cfd::starccm::{ColumnMap, ImportOptions, parse};
use hydrofit::core::model::{Hydro, ParamLayout, Vehicle};
use hydrofit::identify::{self, Options, Regression, swarm::Norm};

fn problem() -> Regression {
    let vehicle = Vehicle::reference();
    let columns = ColumnMap::default();
    let opts = ImportOptions {
        columns: &columns,
        dofs: &vehicle.dofs,
        configured_force: Default::default(),
    };
    let mut files: Vec<_> = std::fs::read_dir(manifest_dir().join("cases/cfd/starccm"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    let responses: Vec<_> = files
        .iter()
        .map(|p| {
            parse(
                &p.display().to_string(),
                &std::fs::read_to_string(p).unwrap(),
                &opts,
            )
            .unwrap()
            .response
        })
        .collect();
    let refs: Vec<_> = responses.iter().collect();
    Regression::build(&vehicle, &refs, 0.0)
}

/// Largest relative error against truth, and the parameter it is on.
fn worst(fit: &identify::Fit) -> (f64, String) {
    let truth = ParamLayout::new(&Vehicle::reference().dofs).from_hydro(&Hydro::reference());
    fit.parameters
        .iter()
        .zip(truth)
        .map(|(p, t)| (((p.value - t) / t).abs(), p.name.clone()))
        .fold((0.0, String::new()), |a, b| if b.0 > a.0 { b } else { a })
}

#[test]
fn every_method_recovers_the_twin_within_its_tolerance() {
    let reg = problem();
    let base = Options {
        rigid_mass: Vehicle::reference().rigid_mass(),
        ..Options::default()
    };
    // Tolerances: the LS family is exact up to the twin's noise; the population methods are
    // judged after 5 restarts x 2000 iterations of 40 particles on the 12-D problem.
    let cases: [(&str, Norm, f64); 7] = [
        ("ols", Norm::L2, 0.02),
        ("tls", Norm::L2, 0.03),
        ("rls", Norm::L2, 0.02),
        ("qpso", Norm::L2, 0.03),
        ("qpso", Norm::L1, 0.03), // evaluated over every row: fewer iterations (below)
        ("pso", Norm::L2, 0.03),
        ("ga", Norm::L2, 0.03),
    ];
    for (name, norm, tol) in cases {
        let est = identify::by_name(name).unwrap();
        let t0 = std::time::Instant::now();
        let iterations = if norm == Norm::L1 {
            1500
        } else {
            base.iterations
        };
        let restarts = if norm == Norm::L1 { 1 } else { base.restarts };
        let fit = est
            .fit(
                &reg,
                &Options {
                    norm,
                    iterations,
                    restarts,
                    ..base.clone_opts()
                },
            )
            .unwrap();
        let (err, which) = worst(&fit);
        eprintln!(
            "{name} {norm:?}: worst {:.2} % ({which}) in {:.2} s, {:?} evaluations",
            100.0 * err,
            t0.elapsed().as_secs_f64(),
            fit.evaluations
        );
        assert!(
            err < tol,
            "{name} {norm:?}: {which} off by {:.2} % (tolerance {:.0} %)",
            100.0 * err,
            100.0 * tol
        );
        if est.stochastic() {
            assert!(fit.parameters.iter().all(|p| p.interval.is_some()));
        }
    }
}

#[test]
fn same_seed_same_numbers_on_any_thread_count() {
    let reg = problem();
    let opts = || Options {
        rigid_mass: Vehicle::reference().rigid_mass(),
        iterations: 60,
        restarts: 2,
        seed: 42,
        ..Options::default()
    };
    let a = identify::by_name("qpso")
        .unwrap()
        .fit(&reg, &opts())
        .unwrap();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let b = one.install(|| {
        identify::by_name("qpso")
            .unwrap()
            .fit(&reg, &opts())
            .unwrap()
    });
    assert_eq!(a.parameters, b.parameters);
    let c = identify::by_name("qpso")
        .unwrap()
        .fit(&reg, &Options { seed: 43, ..opts() })
        .unwrap();
    assert_ne!(a.parameters, c.parameters, "the seed matters");
}

#[test]
fn output_error_with_the_simulator_in_the_loop_recovers_the_twin() {
    // Seed 001 eq. 9: velocities simulated under the applied force against the measured ones.
    let vehicle = Vehicle::reference();
    let columns = ColumnMap::default();
    let opts = ImportOptions {
        columns: &columns,
        dofs: &vehicle.dofs,
        configured_force: Default::default(),
    };
    let dir = manifest_dir().join("cases/cfd/starccm");
    let responses: Vec<_> = [
        "surge_2N",
        "surge_20N",
        "surge_100N",
        "sway_2N",
        "sway_60N",
        "heave_5N",
        "heave_80N",
        "yaw_0p5Nm",
        "yaw_8Nm",
        "surge_yaw_40N_2Nm",
    ]
    .iter()
    .map(|n| {
        let p = dir.join(format!("{n}.csv"));
        parse(
            &p.display().to_string(),
            &std::fs::read_to_string(&p).unwrap(),
            &opts,
        )
        .unwrap()
        .response
    })
    .collect();
    let refs: Vec<_> = responses.iter().collect();
    let reg = Regression::build(&vehicle, &refs, 0.0);
    let o = Options {
        rigid_mass: vehicle.rigid_mass(),
        iterations: 400,
        restarts: 1,
        population: 30,
        output_error: Some((&vehicle, &refs[..])),
        ..Options::default()
    };
    let t0 = std::time::Instant::now();
    let fit = identify::by_name("qpso").unwrap().fit(&reg, &o).unwrap();
    let (err, which) = worst(&fit);
    eprintln!(
        "qpso output error: worst {:.2} % ({which}) in {:.1} s, {:?} evaluations",
        100.0 * err,
        t0.elapsed().as_secs_f64(),
        fit.evaluations
    );
    // Drag is pinned by the steady speeds, added mass by the rise times; the slow cases pin
    // the linear drag because each case counts by its relative error.
    assert!(err < 0.03, "{which} off by {:.2} %", 100.0 * err);
    let e = identify::by_name("ols")
        .unwrap()
        .fit(&reg, &o)
        .unwrap_err()
        .to_string();
    assert!(e.contains("use qpso, pso or ga"), "{e}");
}

#[test]
fn a_time_limit_returns_the_best_so_far_and_says_so() {
    let reg = problem();
    let o = Options {
        rigid_mass: Vehicle::reference().rigid_mass(),
        norm: Norm::L1,
        iterations: 100_000,
        restarts: 3,
        max_seconds: Some(0.5),
        ..Options::default()
    };
    let t0 = std::time::Instant::now();
    let fit = identify::by_name("qpso").unwrap().fit(&reg, &o).unwrap();
    assert!(t0.elapsed().as_secs_f64() < 5.0);
    let why = fit.stopped_early.expect("stopped by the limit");
    assert!(why.contains("time limit of 0.5 s"), "{why}");
}
