use super::*;
use crate::core::model::{Hydro, Plant};
use crate::core::rng::Rng;
use crate::identify::fit;
use crate::identify::pem::tests::lagged_run;

/// Runs of the reference vehicle under random steps of the command (0.1 s command lag),
/// pushed by a constant force of `push` N in sway, their velocities noisy.
fn runs_pushed_in_sway(push: f64, seed: u64) -> Vec<Response> {
    let mut hydro = Hydro::reference();
    hydro.constant[Dof::Sway.index()] = push;
    let plant = Plant::new(&Vehicle::reference(), hydro);
    let mut rng = Rng::derive(seed, "runs pushed in sway");
    (0..8).map(|_| lagged_run(&plant, 0.1, &mut rng)).collect()
}

/// The default fit of `runs` of `vehicle` with the candidates `optional`.
fn default_fit(vehicle: &Vehicle, runs: &[Response], optional: &[Candidate]) -> fit::Identified {
    let method = crate::identify::Method::parse("pem", Default::default()).unwrap();
    let data = fit::Data {
        vehicle,
        cases: Vec::new(),
        pool: runs.iter().collect(),
        skip_start_s: 0.0,
    };
    fit::identify(&data, &fit::Request::plain(&method, optional)).unwrap()
}

/// The default fit of `runs` with a candidate constant in every DOF, as a fit of recordings
/// alone asks for it.
fn fit_with_candidates(runs: &[Response]) -> fit::Identified {
    let mut vehicle = Vehicle::reference();
    vehicle.constant_force = vehicle.dofs.clone();
    let optional: Vec<Candidate> = (vehicle.dofs.iter())
        .map(|d| Candidate::Constant(*d))
        .collect();
    default_fit(&vehicle, runs, &optional)
}

/// A constant force every run shares (a tether's pull in sway) predicts the runs left out
/// better, so it is kept and found; those of the DOFs that have none predict nothing and are
/// dropped, and the fit is made again without them.
#[test]
fn a_constant_the_runs_share_is_kept_and_those_they_lack_are_dropped() {
    for (seed, push) in [(11, -3.0), (12, 4.0)] {
        let id = fit_with_candidates(&runs_pushed_in_sway(push, seed));
        let note = &id.notes[0];
        assert!(note.contains("sway kept"), "seed {seed}: {note}");
        for d in [Dof::Surge, Dof::Yaw] {
            assert!(!id.constant_force.contains(&d), "seed {seed}: {note}");
            assert!(
                note.contains(&format!("{d} dropped")),
                "seed {seed}: {note}"
            );
        }
        assert!(id.constant_force.contains(&Dof::Sway), "seed {seed}");
        let y0 = id.fit.parameters.iter().find(|p| p.name == "Y_0").unwrap();
        assert!(
            (y0.value - push).abs() < 0.1 * push.abs(),
            "seed {seed}: Y_0 {} against {push}",
            y0.value
        );
        assert!(id.fit.parameters.iter().all(|p| p.name != "X_0"));
    }
}

/// Without a shared constant anywhere, none is kept: each candidate's left-out error is the
/// same with it and without it, within the margin.
#[test]
fn no_constant_is_kept_where_no_run_has_one() {
    let id = fit_with_candidates(&runs_pushed_in_sway(0.0, 13));
    let note = &id.notes[0];
    for d in [Dof::Surge, Dof::Sway, Dof::Yaw] {
        assert!(!id.constant_force.contains(&d), "{note}");
    }
}

/// Too few runs to leave one out and still fit: no choice, the candidates are kept.
#[test]
fn two_runs_are_too_few_to_choose_on() {
    let runs = runs_pushed_in_sway(-3.0, 14);
    let mut vehicle = Vehicle::reference();
    vehicle.constant_force = vehicle.dofs.clone();
    let full = Full {
        vehicle: &vehicle,
        skip_start_s: 0.0,
        rigid_mass: [0.0; 6],
        added_mass_prior: [2.0; 6],
        command_lag: Default::default(),
        iterations: 50,
    };
    let two: Vec<&Response> = runs.iter().take(2).collect();
    assert!(choose(&full, &two, &[Candidate::Constant(Dof::Sway)]).is_none());
}

/// Runs of the reference vehicle (0.1 s command lag, noisy velocities) whose yaw moment
/// follows the sway velocity by `n_v` N m s/m, as an open frame's offset centre of lateral
/// resistance gives it.
fn runs_with_n_v(n_v: f64, seed: u64) -> Vec<Response> {
    let mut hydro = Hydro::reference();
    hydro.lin[Dof::Yaw.index()][Dof::Sway.index()] = n_v;
    let plant = Plant::new(&Vehicle::reference(), hydro);
    let mut rng = Rng::derive(seed, "runs with N_v");
    (0..8).map(|_| lagged_run(&plant, 0.1, &mut rng)).collect()
}

/// The default fit's choice of the sway-yaw coupling: on runs with N_v it is kept and found
/// (within 15 %); on runs without it, it is dropped and the model is the diagonal one again.
#[test]
fn a_coupling_is_kept_where_the_runs_have_it_and_dropped_where_they_lack_it() {
    let fit = |runs: &[Response]| {
        let mut vehicle = Vehicle::reference();
        let optional = with_couplings(&mut vehicle);
        assert_eq!(optional, [Candidate::Coupling(Term::Linear(5, 1))]);
        default_fit(&vehicle, runs, &optional)
    };
    for (seed, n_v) in [(15, 6.0), (16, -6.0)] {
        let id = fit(&runs_with_n_v(n_v, seed));
        let note = &id.notes[0];
        assert!(note.contains("N_v kept"), "seed {seed}: {note}");
        let got = id.fit.parameters.iter().find(|p| p.name == "N_v").unwrap();
        assert!(
            (got.value - n_v).abs() < 0.15 * n_v.abs(),
            "seed {seed}: N_v {} against {n_v}",
            got.value
        );
        assert_eq!(id.vehicle.structure, crate::core::model::Structure::Custom);
    }
    let id = fit(&runs_with_n_v(0.0, 17));
    let note = &id.notes[0];
    assert!(note.contains("N_v dropped"), "{note}");
    assert!(id.fit.parameters.iter().all(|p| p.name != "N_v"));
    assert_eq!(
        id.vehicle.structure,
        crate::core::model::Structure::Diagonal,
        "{note}"
    );
}

/// The default six-DOF fit's choice of z_g, the centre of gravity's height from the
/// thrusters' origin: on runs whose thrusters sit 8 cm above the centre of gravity it is
/// kept and found (within 10 %); on runs whose logged moments are the body's it is dropped
/// or found under a centimetre.
#[test]
fn the_centre_of_gravitys_height_is_kept_where_the_thrust_moments_hang_on_it() {
    use crate::identify::pem::tests::{about_cg_below, buoyant_six_dof, tilting_run_under};
    for (seed, height) in [(21, 0.08), (22, 0.0)] {
        let (mut vehicle, plant) = buoyant_six_dof();
        let mut rng = Rng::derive(seed, "six-DOF runs under thrusters above the CG");
        let runs: Vec<Response> = (0..6)
            .map(|_| tilting_run_under(&plant, &vehicle, &mut rng, about_cg_below(height)))
            .collect();
        let optional = with_couplings(&mut vehicle);
        assert!(optional.contains(&Candidate::Coupling(Term::Lever(2))));
        let id = default_fit(&vehicle, &runs, &optional);
        let note = &id.notes[0];
        let z_g = id.fit.parameters.iter().find(|p| p.name == "z_g");
        match height > 0.0 {
            true => {
                assert!(note.contains("z_g kept"), "seed {seed}: {note}");
                let found = z_g.expect("z_g in the fit").value;
                assert!(
                    (found - height).abs() < 0.1 * height,
                    "seed {seed}: z_g {found} for {height}"
                );
            }
            false => assert!(
                z_g.is_none_or(|p| p.value.abs() < 0.01),
                "seed {seed}: {note}, z_g {z_g:?}"
            ),
        }
    }
}
