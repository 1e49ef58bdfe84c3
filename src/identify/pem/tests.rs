use super::*;
use crate::core::model::dynamics::lagged;
use crate::core::model::{Hydro, Plant, Vehicle};
use crate::core::response::{Response, Series, Source, differentiate};
use crate::core::rng::Rng;

/// A run of the reference vehicle under random steps of the command, delivered through a
/// first-order lag of `lag_s`, its velocities noisy.
pub(crate) fn lagged_run(plant: &Plant, lag_s: f64, rng: &mut Rng) -> Response {
    let t: Vec<f64> = (0..1200).map(|k| k as f64 * 0.05).collect();
    let scale = [40.0, 40.0, 40.0, 0.0, 0.0, 8.0];
    let mut level = [0.0; 6];
    let cmd: Vec<[f64; 6]> = (0..t.len())
        .map(|k| {
            if k % 50 == 0 {
                level = std::array::from_fn(|i| scale[i] * (2.0 * rng.uniform() - 1.0));
            }
            level
        })
        .collect();
    let nu = plant.simulate(&t, &lagged(&t, &cmd, lag_s), [0.0; 6], 0.01);
    logged(t, &cmd, &nu, &Vehicle::reference().dofs, 0.005, rng)
}

/// The response a run's log gives in `dofs`: the command, and the velocities `nu` with white
/// noise of deviation `noise` (the acceleration differentiated from them).
fn logged(
    t: Vec<f64>,
    cmd: &[[f64; 6]],
    nu: &[[f64; 6]],
    dofs: &[crate::core::dof::Dof],
    noise: f64,
    rng: &mut Rng,
) -> Response {
    let dofs = dofs
        .iter()
        .map(|&d| {
            let i = d.index();
            let velocity: Vec<f64> = nu.iter().map(|v| v[i] + noise * rng.normal()).collect();
            let series = Series {
                force: cmd.iter().map(|c| c[i]).collect(),
                accel: differentiate(&t, &velocity),
                velocity,
                force_source: Source::Column,
                accel_source: Source::Differentiated,
            };
            (d, series)
        })
        .collect();
    Response {
        t,
        dofs,
        attitude: Vec::new(),
    }
}

/// The prediction-error fit with its default settings of `responses` of `vehicle`, with
/// `tune` applied to its options first.
fn default_fit(vehicle: &Vehicle, responses: &[Response], tune: impl FnOnce(&mut Options)) -> Fit {
    let refs: Vec<_> = responses.iter().collect();
    let reg = Regression::build(vehicle, &refs, 0.0);
    let mut o = Options {
        rigid_mass: vehicle.rigid_mass(),
        output_error: Some((vehicle, &refs[..])),
        ..Options::default()
    };
    Pem.settings(Default::default()).unwrap().apply(&mut o);
    tune(&mut o);
    Pem.fit(&reg, &o).unwrap()
}

/// A known command lag is found within three of its standard errors (counted beside the
/// coefficients; the line search alone leaves it up to its 0.02 s bracket off, a hundred
/// of them), and the correlation matrix has its row.
#[test]
fn the_command_lag_is_found_and_counted_with_the_coefficients() {
    let vehicle = Vehicle::reference();
    let plant = Plant::new(&vehicle, Hydro::reference());
    for (seed, truth) in [(1, 0.25), (3, 0.1), (4, 0.4)] {
        let mut rng = Rng::derive(seed, "lagged runs");
        let responses: Vec<_> = (0..4)
            .map(|_| lagged_run(&plant, truth, &mut rng))
            .collect();
        // The reference vehicle's heave added mass is 2.4 times its mass: within reach
        // (held at 2, the lag grows to make up the missing inertia).
        let fit = default_fit(&vehicle, &responses, |o| o.added_mass_prior[2] = 3.0);
        let l = fit.command_lag.expect("a lag found");
        assert!(
            (l.value_s - truth).abs() <= 3.0 * l.stderr_s,
            "seed {seed}: T_cmd {} ± {} for {truth}",
            l.value_s,
            l.stderr_s
        );
        assert!(
            l.stderr_s > 0.0 && l.stderr_s < 0.01,
            "seed {seed}: T_cmd ± {}",
            l.stderr_s
        );
        let r = fit.refinement.as_ref().unwrap();
        let n = fit.parameters.len() + 1;
        assert_eq!(r.names.last().map(String::as_str), Some("T_cmd"));
        assert_eq!((r.names.len(), r.correlation.len()), (n, n));
        assert!(r.correlation.iter().all(|row| row.len() == n));
        assert!((r.correlation[n - 1][n - 1] - 1.0).abs() < 1e-9);
        // Steps of the command tell a lag from an inertia: no lag a profile step away is
        // within the margin, and no coefficient gets a range over lags.
        assert!(l.profile.is_empty(), "seed {seed}: {:?}", l.profile);
        assert!(fit.parameters.iter().all(|p| p.interval.is_none()));
    }
}

/// A coefficient that moves with the lag over lags the runs cannot tell apart gets that
/// range as its interval and says so; one wider than its value is not identifiable, and one
/// within its standard errors is left alone.
#[test]
fn a_coefficient_that_trades_with_the_lag_says_its_range() {
    let vehicle = Vehicle::reference();
    let t = vec![0.0, 0.1];
    let responses = [lagged_run_stub(&t)];
    let refs: Vec<_> = responses.iter().collect();
    let reg = Regression::build(&vehicle, &refs, 0.0);
    let n = reg.layout.len();
    let point = |lag_s: f64, x: f64| super::super::lag::LagPoint {
        lag_s,
        cost: 0.5,
        theta: (0..n).map(|j| if j == 0 { x } else { -1.0 }).collect(),
    };
    let lag = LagEstimate {
        value_s: 0.2,
        stderr_s: 0.005,
        cost_without: 0.6,
        cost_with: 0.5,
        estimated: true,
        searched_on_candidates: None,
        profile: vec![point(0.1, -3.0), point(0.3, -0.5)],
    };
    let est = |value: f64, stderr: f64| Estimate {
        name: "X".into(),
        value,
        unit: "kg".into(),
        stderr,
        interval: None,
        identifiable: true,
        note: None,
    };
    // Coefficient 0 runs from -3 to -0.5 over 0.1-0.3 s: wider than its value -2.
    let e = over_the_lag(est(-2.0, 0.05), Some(&lag), 0, &reg);
    assert_eq!(e.interval, Some([-3.0, -0.5]));
    assert!(!e.identifiable);
    let note = e.note.as_deref().unwrap();
    assert!(note.contains("0.10-0.30 s"), "{note}");
    assert!(note.ends_with("would tell them apart"), "{note}");
    // Wider than four standard errors but narrower than the value: said, still trusted.
    let e = over_the_lag(est(-20.0, 0.05), Some(&lag), 0, &reg);
    assert!(e.identifiable && e.note.is_some());
    // Coefficient 1 stays at -1 over the lags: an interval, nothing to say.
    let e = over_the_lag(est(-1.0, 0.05), Some(&lag), 1, &reg);
    assert_eq!(e.interval, Some([-1.0, -1.0]));
    assert!(e.identifiable && e.note.is_none());
    // No profile, no interval.
    let bare = LagEstimate {
        profile: Vec::new(),
        ..lag
    };
    assert!(
        over_the_lag(est(-2.0, 0.05), Some(&bare), 0, &reg)
            .interval
            .is_none()
    );
}

/// The manoeuvre a note names for a moment of weight and buoyancy is the one that shows it:
/// eta_z turns the vehicle in roll and pitch as it tilts, not in yaw.
#[test]
fn the_moment_of_weight_is_shown_by_the_axes_it_turns() {
    use crate::core::model::terms::Term;
    assert_eq!(acts_in(Term::Moment(2)), "roll and pitch");
    assert_eq!(acts_in(Term::Moment(0)), "pitch and yaw");
    assert_eq!(acts_in(Term::Linear(5, 5)), "yaw");
}

/// A two-sample run of the reference vehicle's DOFs at rest: enough for a layout.
fn lagged_run_stub(t: &[f64]) -> Response {
    let dofs = Vehicle::reference()
        .dofs
        .iter()
        .map(|&d| {
            let series = Series {
                force: vec![0.0; t.len()],
                accel: vec![0.0; t.len()],
                velocity: vec![0.0; t.len()],
                force_source: Source::Column,
                accel_source: Source::Differentiated,
            };
            (d, series)
        })
        .collect();
    Response {
        t: t.to_vec(),
        dofs,
        attitude: Vec::new(),
    }
}

/// A BlueROV2 Heavy-sized vehicle in six DOF (the diagonal coefficients Wu (2018) published
/// for it), 2 N buoyant, its centre of gravity 2 cm below its centre of buoyancy.
pub(crate) fn buoyant_six_dof() -> (Vehicle, Plant) {
    use crate::core::dof::Dof;
    let vehicle = Vehicle {
        name: "buoyant six-DOF vehicle".into(),
        mass_kg: 11.5,
        inertia_kg_m2: crate::core::model::vehicle::Inertia {
            xx: 0.16,
            yy: 0.16,
            zz: 0.16,
        },
        dofs: Dof::ALL.to_vec(),
        constant_force: Dof::ALL.to_vec(),
        ..Vehicle::reference()
    };
    let mut h = Hydro::diagonal(
        [-5.5, -12.7, -14.57, -0.12, -0.12, -0.12],
        [-4.03, -6.22, -5.18, -0.07, -0.07, -0.07],
        [-18.18, -21.66, -36.99, -1.55, -1.55, -1.55],
    );
    h.net_weight = -2.0;
    h.moment = [0.0, 0.0, 0.02 * 112.8];
    let plant = Plant::new(&vehicle, h);
    (vehicle, plant)
}

/// A run of [`buoyant_six_dof`] under random steps of the command in every DOF, the pitch and
/// roll moments large enough to tilt it 20-30 deg; velocities and attitude as logged, noisy.
fn tilting_run(plant: &Plant, vehicle: &Vehicle, rng: &mut Rng) -> Response {
    tilting_run_under(plant, vehicle, rng, |tau| *tau)
}

/// [`tilting_run`] with the body driven by `applied` of each logged command.
pub(crate) fn tilting_run_under(
    plant: &Plant,
    vehicle: &Vehicle,
    rng: &mut Rng,
    applied: impl Fn(&[f64; 6]) -> [f64; 6],
) -> Response {
    use crate::core::model::attitude::{State, rk4};
    let t: Vec<f64> = (0..1200).map(|k| k as f64 * 0.05).collect();
    let scale = [10.0, 10.0, 10.0, 0.8, 0.8, 0.5];
    let mut level = [0.0; 6];
    let mut x = State {
        nu: [0.0; 6],
        att: [0.0; 2],
    };
    let (mut cmd, mut nu, mut att) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..t.len() {
        if k % 50 == 0 {
            level = std::array::from_fn(|i| scale[i] * (2.0 * rng.uniform() - 1.0));
        }
        cmd.push(level);
        nu.push(x.nu);
        att.push(x.att);
        let acting = applied(&level);
        for _ in 0..5 {
            x = rk4(plant, &x, &acting, 0.01);
        }
    }
    let mut r = logged(t, &cmd, &nu, &vehicle.dofs, 0.003, rng);
    r.attitude = att
        .iter()
        .map(|a| a.map(|x| x + 0.002 * rng.normal()))
        .collect();
    r
}

/// A vehicle that pitches and rolls with net buoyancy feels it along its hull: the default fit
/// of a six-DOF diagonal model has the net weight W - B, which tilts with the vehicle, and finds
/// it, where a body-fixed surge constant stood in for it before (on a simulated BlueROV2 Heavy,
/// -1.04 N, and the held-out surge drifted to -0.14 m/s where the vehicle coasted at -0.02).
#[test]
fn net_buoyancy_tilts_with_the_vehicle_and_is_found() {
    let (vehicle, plant) = buoyant_six_dof();
    let mut rng = Rng::derive(5, "tilting runs");
    let responses: Vec<_> = (0..4)
        .map(|_| tilting_run(&plant, &vehicle, &mut rng))
        .collect();
    let max_pitch = (responses.iter().flat_map(|r| &r.attitude))
        .map(|a| a[1].abs().to_degrees())
        .fold(0.0, f64::max);
    assert!(max_pitch > 15.0, "the runs pitch to {max_pitch} deg only");
    let fit = default_fit(&vehicle, &responses, |_| {});
    let value = |name: &str| {
        let p = fit.parameters.iter().find(|p| p.name == name);
        p.unwrap_or_else(|| panic!("no {name} in {:?}", fit.parameters))
            .value
    };
    let wb = value("W-B");
    assert!((wb + 2.0).abs() < 0.3, "W-B {wb} for -2.0");
    for c in ["X_0", "Y_0"] {
        assert!(value(c).abs() < 0.3, "{c} {} for none", value(c));
    }
    let (xu, eta) = (value("X_udot"), value("eta_z"));
    assert!((xu + 5.5).abs() < 1.1, "X_udot {xu} for -5.5");
    assert!((eta - 2.256).abs() < 0.2, "eta_z {eta} for 2.256");
}

/// A restoring moment is bounded as the drag is: no stiffer than a natural frequency of
/// 1 / FASTEST_S with the heaviest inertia the prior allows. When the logged roll and pitch
/// moments do not drive the motion (here the horizontal thrust's lever is wrong by 0.5 m in
/// the log), the output error pins the attitude with the stiffest spring it may: on a real
/// BlueROV2 Heavy's tank runs eta_z came out 682 N m (a metacentric height of 6 m) and was
/// reported identifiable to 28 %. Now it stops at the bound, flagged, with the reason; and a
/// drag whose inertia was freed beyond its prior is judged against the freed bound.
#[test]
fn a_restoring_moment_that_pins_the_attitude_is_flagged_at_its_bound() {
    use crate::core::dof::Dof;
    let (vehicle, plant) = buoyant_six_dof();
    let mut rng = Rng::derive(5, "tilting runs");
    let responses: Vec<_> = (0..4)
        .map(|_| {
            let mut r = tilting_run(&plant, &vehicle, &mut rng);
            let (x, y) = (
                r.dofs[&Dof::Surge].force.clone(),
                r.dofs[&Dof::Sway].force.clone(),
            );
            let roll = &mut r.dofs.get_mut(&Dof::Roll).unwrap().force;
            roll.iter_mut().zip(&y).for_each(|(k, y)| *k -= 0.5 * y);
            let pitch = &mut r.dofs.get_mut(&Dof::Pitch).unwrap().force;
            pitch.iter_mut().zip(&x).for_each(|(m, x)| *m += 0.5 * x);
            r
        })
        .collect();
    let fit = default_fit(&vehicle, &responses, |_| {});
    let p = |name: &str| fit.parameters.iter().find(|p| p.name == name).unwrap();
    // Roll's heaviest inertia: 0.16 kg m^2 and twice that added; (1 / 0.1 s)^2 times it.
    let (eta, bound) = (p("eta_z"), 3.0 * 0.16 / (FASTEST_S * FASTEST_S));
    assert!(
        eta.value.abs() <= bound * (1.0 + 1e-9),
        "eta_z {} beyond {bound}",
        eta.value
    );
    assert!(
        (eta.value - bound).abs() < 1e-6 * bound,
        "eta_z {} not pinned",
        eta.value
    );
    let note = eta.note.as_deref().unwrap_or_default();
    assert!(
        !eta.identifiable && note.contains("stiffness bound") && note.contains("K_v"),
        "{note}"
    );
    assert!(note.contains("roll and pitch"), "{note}");
    // Pitch's inertia was freed (M_qdot to 5 times the rigid term), its drag with it, to the
    // freed bound: on it, it is flagged as on any other.
    // Pitch's inertia was freed, to 5 times the rigid term and then, on that bound, further:
    // past 5 times it is flagged as the command's shortfall it stands in for (here the logged
    // pitch moment's lever is wrong), and its drag, whose bound grows with the inertia, is
    // judged against the bound it was freed to: on it, it is flagged as on any other.
    let mqdot = p("M_qdot");
    let note = mqdot.note.as_deref().unwrap_or_default();
    assert!(mqdot.value < -5.0 * 0.16, "M_qdot {mqdot:?}");
    assert!(
        !mqdot.identifiable && note.contains("stands in for a command"),
        "{note}"
    );
    let (mqq, freed) = (p("M_qq"), -51.0 * 0.16 / (FASTEST_S * 2.0));
    assert!(
        (mqq.value - freed).abs() < 1e-6 * freed.abs(),
        "M_qq {mqq:?}"
    );
    assert!(
        !mqq.identifiable,
        "M_qq on its freed bound, not flagged: {mqq:?}"
    );
}

/// The restoring moment's bound counts only the rotations the model has: a model in roll and
/// yaw takes roll's inertia; one without roll or pitch has no eta.
#[test]
fn a_restoring_moments_bound_follows_the_rotations_it_rights() {
    use crate::core::dof::Dof;
    use crate::core::model::ParamLayout;
    let rigid = [10.0, 10.0, 10.0, 0.2, 0.5, 0.4];
    let prior = [2.0; 6];
    let bound_of = |dofs: &[Dof]| {
        let layout = ParamLayout::new(dofs);
        let b = plausible(&layout, &rigid, &prior);
        let j = layout.names().iter().position(|n| n == "eta_z");
        j.map(|j| (b.lo[j], b.hi[j]))
    };
    let six = bound_of(&Dof::ALL).unwrap();
    assert!(
        (six.1 - 3.0 * 0.2 / 0.01).abs() < 1e-9 && six.0 == -six.1,
        "{six:?}"
    );
    let pitch_only = bound_of(&[Dof::Pitch, Dof::Yaw]).unwrap();
    assert!(
        (pitch_only.1 - 3.0 * 0.5 / 0.01).abs() < 1e-9,
        "{pitch_only:?}"
    );
    assert_eq!(
        bound_of(&[Dof::Surge, Dof::Sway, Dof::Heave, Dof::Yaw]),
        None
    );
}

/// A roll moment from the sway velocity (K_v: the sway drag's centre below the centre of
/// gravity) is fitted after the translations (see `identify::attitude_rows`): it is found,
/// and the sway coefficients are those a model without it finds, which the roll errors do
/// not pull.
#[test]
fn a_roll_moment_from_sway_is_found_after_the_sway_drag() {
    use crate::core::dof::Dof;
    use crate::core::model::{CustomTerms, Structure};
    let (mut vehicle, plant) = buoyant_six_dof();
    let (roll, sway) = (Dof::Roll.index(), Dof::Sway.index());
    let mut hydro = plant.hydro;
    hydro.lin[roll][sway] = 1.0;
    let plant = Plant::new(&vehicle, hydro);
    let mut rng = Rng::derive(6, "tilting runs with K_v");
    let responses: Vec<_> = (0..4)
        .map(|_| tilting_run(&plant, &vehicle, &mut rng))
        .collect();
    let without = default_fit(&vehicle, &responses, |_| {});
    vehicle.structure = Structure::Custom;
    vehicle.custom_terms = Some(CustomTerms {
        base: Structure::Diagonal,
        add: vec!["K_v".into()],
        remove: Vec::new(),
    });
    let with = default_fit(&vehicle, &responses, |_| {});
    let value = |fit: &Fit, name: &str| {
        let p = fit.parameters.iter().find(|p| p.name == name);
        p.unwrap_or_else(|| panic!("no {name}")).value
    };
    let kv = value(&with, "K_v");
    assert!((kv - 1.0).abs() < 0.15, "K_v {kv} for 1.0");
    for name in ["Y_vdot", "Y_v", "Y_vv", "X_u", "Z_w"] {
        let (a, b) = (value(&with, name), value(&without, name));
        assert!(
            (a - b).abs() < 0.01 * b.abs(),
            "{name} {a} with K_v, {b} without"
        );
    }
}

/// Thrusters laid out about a point 8 cm above the centre of gravity (as a BlueROV2 Heavy's
/// documented layout sits above its ballasted centre of gravity): the logged surge and sway
/// thrust pitch and roll the body less than the layout says. The fit with z_g finds the
/// height, and on runs whose logged moments are the body's it finds none.
#[test]
fn the_centre_of_gravity_below_the_thrusters_origin_is_found() {
    use crate::core::model::{CustomTerms, Structure};
    let (mut vehicle, plant) = buoyant_six_dof();
    vehicle.structure = Structure::Custom;
    vehicle.custom_terms = Some(CustomTerms {
        base: Structure::Diagonal,
        add: vec!["z_g".into()],
        remove: Vec::new(),
    });
    for (seed, height) in [(7, 0.08), (8, 0.0)] {
        let mut rng = Rng::derive(seed, "tilting runs under thrusters above the CG");
        let responses: Vec<_> = (0..4)
            .map(|_| tilting_run_under(&plant, &vehicle, &mut rng, about_cg_below(height)))
            .collect();
        let fit = default_fit(&vehicle, &responses, |_| {});
        let z_g = fit.parameters.iter().find(|p| p.name == "z_g");
        let z_g = z_g.expect("z_g in the fit");
        let found = z_g.value;
        if height > 0.0 {
            let note = z_g.note.as_deref().unwrap_or_default();
            assert!(note.contains("cm below the point"), "{note}");
        }
        assert!(
            (found - height).abs() < 0.008,
            "seed {seed}: z_g {found} for {height}"
        );
    }
}

/// The logged wrench as it acts about a centre of gravity `height` below the thrusters'
/// origin (z down): M_cg = M_logged + (r_origin - r_cg) x F, r_origin - r_cg = (0, 0,
/// -height).
pub(crate) fn about_cg_below(height: f64) -> impl Fn(&[f64; 6]) -> [f64; 6] {
    move |tau: &[f64; 6]| {
        let (d, f) = ([0.0, 0.0, -height], [tau[0], tau[1], tau[2]]);
        let arm = [
            d[1] * f[2] - d[2] * f[1],
            d[2] * f[0] - d[0] * f[2],
            d[0] * f[1] - d[1] * f[0],
        ];
        [
            f[0],
            f[1],
            f[2],
            tau[3] + arm[0],
            tau[4] + arm[1],
            tau[5] + arm[2],
        ]
    }
}

/// A yaw command that delivers a quarter of what it asks (a thrust table off in yaw) makes the
/// runs demand an inertia past the search bound: freed once more, the fit takes the inertia
/// the motion needs (as a per-DOF first-order model, whose gain is free, would), and flags it
/// as standing in for the command's gain rather than passing it off as an added inertia. With
/// the whole command delivered, the same runs keep the inertia on its prior.
#[test]
fn a_yaw_command_that_delivers_a_quarter_is_read_as_its_gain() {
    let mut vehicle = Vehicle::reference();
    vehicle.dofs = vec![Dof::Yaw];
    let (added, linear) = (-1.06, -1.18);
    let plant = Plant::new(
        &vehicle,
        Hydro::diagonal(
            [0.0, 0.0, 0.0, 0.0, 0.0, added],
            [0.0, 0.0, 0.0, 0.0, 0.0, linear],
            [0.0; 6],
        ),
    );
    let izz = vehicle.rigid_mass()[5];
    let runs = |gain: f64| -> Vec<Response> {
        let mut rng = Rng::derive(7, "weak yaw");
        let t: Vec<f64> = (0..1200).map(|k| k as f64 * 0.05).collect();
        (0..4)
            .map(|_| {
                let mut level = 0.0;
                let cmd: Vec<[f64; 6]> = (0..t.len())
                    .map(|k| {
                        if k % 80 == 0 {
                            level = 8.0 * (2.0 * rng.uniform() - 1.0);
                        }
                        [0.0, 0.0, 0.0, 0.0, 0.0, level]
                    })
                    .collect();
                let delivered: Vec<[f64; 6]> = cmd.iter().map(|c| c.map(|x| gain * x)).collect();
                let nu = plant.simulate(&t, &delivered, [0.0; 6], 0.01);
                logged(t.clone(), &cmd, &nu, &vehicle.dofs, 0.005, &mut rng)
            })
            .collect()
    };
    let n_rdot = |gain: f64| {
        let fit = default_fit(&vehicle, &runs(gain), |o| o.command_lag = CommandLag::None);
        fit.parameters
            .into_iter()
            .find(|p| p.name == "N_rdot")
            .unwrap()
    };
    // (I + a) r' = tau / 4 + N_r r  is  (I + a') r' = tau + 4 N_r r  with a' = 4 (I + a) - I.
    let truth = -(4.0 * (izz - added) - izz);
    assert!(
        truth < -BEYOND_PRIOR * izz,
        "the case needs an inertia past the search bound"
    );
    let n = n_rdot(0.25);
    let note = n.note.as_deref().unwrap_or_default();
    assert!(
        (n.value - truth).abs() < 0.05 * truth.abs(),
        "N_rdot {} for an equivalent {truth}: {note}",
        n.value
    );
    assert!(
        !n.identifiable && note.contains("stands in for a command that delivers about"),
        "{note}"
    );
    let whole = n_rdot(1.0);
    assert!(
        (whole.value - added).abs() < 0.05 * added.abs(),
        "N_rdot {} for {added}",
        whole.value
    );
    assert!(
        whole.identifiable && whole.note.is_none(),
        "{:?}",
        whole.note
    );
}
