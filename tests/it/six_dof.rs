//! Seed 003's coupled 6-DOF model: every parameter set that contains the six-DOF twin's truth
//! recovers it from exact samples, the regression is fast, TLS beats OLS when the regressors
//! are noisy too, and a mass matrix that is not positive definite is refused. The twin flies
//! with its own simulator (Fossen's matrix form), not the model code under test.

use hydrofit::core::model::{CustomTerms, Hydro, ParamLayout, Plant, Structure, Vehicle};
use hydrofit::identify::{self, Options, Regression};
use hydrofit::twin::six;

fn fly(h: &Hydro, seconds: f64) -> six::Record {
    let v = six::vehicle();
    let mut trial = six::default_trials().remove(0);
    trial.duration_s = seconds;
    six::fly(&six::Body::new(&v, h), &v, &trial)
}

fn layout(s: Structure) -> ParamLayout {
    let v = six::vehicle();
    ParamLayout::build(s, &v.dofs, &[], &CustomTerms::default()).unwrap()
}

fn fit(method: &str, reg: &Regression) -> Vec<f64> {
    let opts = Options {
        rigid_mass: six::vehicle().rigid_mass(),
        ..Options::default()
    };
    let m = identify::Method::parse(method, Default::default()).unwrap();
    let f = m.estimator.fit(reg, &opts).unwrap();
    f.parameters.iter().map(|p| p.value).collect()
}

/// Worst error against the truth, relative to the truth or, for a term that is small, to a
/// twentieth of the largest term of its kind and row (a cross term of 0.3 is not judged to
/// 1 % of 0.3).
fn worst(l: &ParamLayout, est: &[f64], h: &Hydro) -> (f64, String) {
    let truth = l.from_hydro(h);
    let scale = |j: usize| {
        let (g, d) = l.slot(j);
        let big = (0..l.len())
            .filter(|&k| l.slot(k) == (g, d))
            .map(|k| truth[k].abs())
            .fold(0.0, f64::max);
        truth[j].abs().max(0.05 * big).max(1e-9)
    };
    (0..l.len())
        .map(|j| ((est[j] - truth[j]).abs() / scale(j), l.name(j)))
        .fold((0.0, String::new()), |a, b| if b.0 > a.0 { b } else { a })
}

#[test]
fn every_set_that_contains_the_truth_recovers_it() {
    let v = six::vehicle();
    // The twin's truth is in CUSTOM (and in no other set: it has K_p and no K_pp).
    let rec = fly(&six::truth(), 240.0);
    let resp = rec.response();
    let l = layout(Structure::Custom);
    let start = std::time::Instant::now();
    let reg = Regression::build_with(&l, &v, &[&resp], 0.0);
    let est = fit("ols", &reg);
    eprintln!(
        "custom: {} rows x {} terms built and solved in {:.2} s",
        reg.rows(),
        reg.cols(),
        start.elapsed().as_secs_f64()
    );
    let (e, name) = worst(&l, &est, &six::truth());
    assert!(e < 0.01, "custom: {name} off by {:.2} %", 100.0 * e);
    // A truth within DIAG ALL is in every set that adds terms to it.
    let mut diag = Hydro::diagonal(
        six::truth().added_diag(),
        [0.0; 6],
        six::truth().quad_diag(),
    );
    diag.quad[3][3][3] = -35.0;
    diag.net_weight = six::truth().net_weight;
    diag.moment = six::truth().moment;
    let resp = fly(&diag, 240.0).response();
    for s in [
        Structure::DiagAll,
        Structure::DiagQd,
        Structure::DiagMass,
        Structure::FullQd,
    ] {
        let l = layout(s);
        let reg = Regression::build_with(&l, &v, &[&resp], 0.0);
        let (e, name) = worst(&l, &fit("ols", &reg), &diag);
        assert!(e < 0.01, "{}: {name} off by {:.2} %", s.label(), 100.0 * e);
    }
}

#[test]
fn tls_beats_ols_when_the_regressors_are_noisy() {
    // Errors in variables (seed 003 section III: TLS perturbs [A b], OLS only b): every
    // regressor column and the force carry noise of 10 % of their RMS. OLS is then biased
    // towards zero; TLS, on equilibrated columns, is not.
    let v = six::vehicle();
    let mut h = Hydro::diagonal(
        six::truth().added_diag(),
        [0.0; 6],
        six::truth().quad_diag(),
    );
    h.quad[3][3][3] = -35.0;
    h.net_weight = 4.0;
    h.moment = six::truth().moment;
    let resp = fly(&h, 240.0).response();
    let l = layout(Structure::DiagAll);
    let mut reg = Regression::build_with(&l, &v, &[&resp], 0.0);
    let (n, p) = (reg.rows(), reg.cols());
    let rms =
        |f: &dyn Fn(usize) -> f64| ((0..n).map(|i| f(i).powi(2)).sum::<f64>() / n as f64).sqrt();
    let col_rms: Vec<f64> = (0..p).map(|j| rms(&|i| reg.phi[i * p + j])).collect();
    let y_rms = rms(&|i| reg.y[i]);
    let mut rng = hydrofit::core::rng::Rng::new(11);
    for (row, y) in reg.phi.chunks_exact_mut(p).zip(reg.y.iter_mut()) {
        for (x, r) in row.iter_mut().zip(&col_rms) {
            *x += 0.1 * r * rng.normal();
        }
        *y += 0.1 * y_rms * rng.normal();
    }
    let truth = l.from_hydro(&h);
    let err = |est: &[f64]| -> f64 {
        let diag: Vec<usize> = (0..p).filter(|&j| l.terms[j].is_diagonal()).collect();
        diag.iter()
            .map(|&j| ((est[j] - truth[j]) / truth[j]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let (ols, tls) = (err(&fit("ols", &reg)), err(&fit("tls", &reg)));
    eprintln!("relative error of the diagonal terms: OLS {ols:.4}, TLS {tls:.4}");
    assert!(
        tls < 0.7 * ols,
        "TLS {tls} not clearly better than OLS {ols}"
    );
}

#[test]
fn a_mass_matrix_that_is_not_positive_definite_is_refused() {
    let v: Vehicle = six::vehicle();
    let mut h = six::truth();
    // Surge-pitch coupling larger than the geometric mean of their masses.
    h.added[0][4] = -300.0;
    h.added[4][0] = -300.0;
    let p = Plant::new(&v, h);
    let why = p.mass_problem().expect("refused");
    assert!(
        why.contains("not positive definite") && why.contains("smallest eigenvalue"),
        "{why}"
    );
    assert!(Plant::new(&v, six::truth()).mass_problem().is_none());
}

#[test]
fn the_model_code_and_the_twin_agree_on_the_acceleration() {
    // The same coefficients through model::dynamics (Kirchhoff form) and the twin's Fossen
    // matrix form: one accelerates as the other, at any velocity and attitude.
    let v = six::vehicle();
    let h = six::truth();
    let p = Plant::new(&v, h);
    let body = six::Body::new(&v, &h);
    for k in 0..20 {
        let x = k as f64;
        let nu = [
            0.3 * (x).sin(),
            -0.2 * (1.3 * x).cos(),
            0.1 * x.sin(),
            0.2 * (0.7 * x).cos(),
            -0.15 * x.sin(),
            0.4 * (2.1 * x).cos(),
        ];
        let tau = [
            50.0 * x.cos(),
            -20.0,
            30.0 * x.sin(),
            10.0,
            -15.0 * x.cos(),
            25.0,
        ];
        let (phi, theta) = (0.2 * x.sin(), -0.1 * x.cos());
        let g = hydrofit::core::model::dynamics::gravity_body(phi, theta);
        let a = p.accel_at(&nu, &tau, &g);
        let b = body.accel(
            &nalgebra::Vector6::from_row_slice(&nu),
            &nalgebra::Vector6::from_row_slice(&tau),
            phi,
            theta,
        );
        for i in 0..6 {
            assert!(
                (a[i] - b[i]).abs() < 1e-9 * (1.0 + b[i].abs()),
                "{k} {i}: {} vs {}",
                a[i],
                b[i]
            );
        }
    }
}

#[test]
fn the_output_error_of_a_coupled_model_is_zero_at_the_truth_only() {
    // Output error (seed 001 eq. 9) on a coupled structure, through the coupled lane kernel:
    // the twin's own trajectory is reproduced by its coefficients, not by coefficients 10 %
    // off in the quadratic drag.
    let v = six::vehicle();
    let resp = fly(&six::truth(), 60.0).response();
    let refs = [&resp];
    let oe = hydrofit::identify::output_error::OutputError::new(&v, &refs);
    let l = layout(Structure::Custom);
    let truth = l.from_hydro(&six::truth());
    let off: Vec<f64> = truth
        .iter()
        .zip(&l.terms)
        .map(|(x, t)| {
            if t.group() == hydrofit::core::model::params::Group::QuadraticDrag {
                1.1 * x
            } else {
                *x
            }
        })
        .collect();
    let rms = |r: Vec<f64>| (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt();
    let (at_truth, at_off) = (rms(oe.residuals(&l, &truth)), rms(oe.residuals(&l, &off)));
    eprintln!("output error: {at_truth:.2e} at the truth, {at_off:.2e} 10 % off");
    assert!(
        at_truth < 1e-4 && at_off > 100.0 * at_truth,
        "{at_truth} vs {at_off}"
    );
}
