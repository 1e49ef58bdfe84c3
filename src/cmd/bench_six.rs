//! `hydrofit bench --objective six-dof`: seed 003's largest regression (CUSTOM, 241 terms) on
//! the six-DOF twin's Table II trial, built and solved by QR (OLS) and SVD (TLS), and the
//! coupled model's simulation step against the diagonal one's.

use crate::core::model::{ParamLayout, Plant, Vec6};
use crate::core::response::Response;
use crate::identify::{self, Options, Regression};
use crate::twin::six;
use std::process::ExitCode;
use std::time::Instant;

/// The Table II trial sampled at its command rate with the twin's exact accelerations.
fn trial_response() -> Response {
    let v = six::vehicle();
    let trial = six::default_trials().remove(0);
    six::fly(&six::Body::new(&v, &six::truth()), &v, &trial).response()
}

/// The median of `reps` timings of `f`, s.
fn median_time(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[reps / 2]
}

pub fn run() -> anyhow::Result<ExitCode> {
    let v = six::vehicle();
    let resp = trial_response();
    let layout = ParamLayout::of(&v);
    let opts = Options {
        rigid_mass: v.rigid_mass(),
        ..Options::default()
    };
    let mut reg = Regression::build_with(&layout, &v, &[&resp], 0.0);
    let build = median_time(5, || {
        reg = Regression::build_with(&layout, &v, &[&resp], 0.0)
    });
    println!(
        "six-DOF regression (CUSTOM): {} rows x {} terms from {} samples of the Table II trial",
        reg.rows(),
        reg.cols(),
        resp.len()
    );
    println!("  build        {:8.1} ms", 1e3 * build);
    for method in ["ols", "tls"] {
        let m = identify::Method::parse(method, Default::default()).map_err(anyhow::Error::msg)?;
        let s = median_time(5, || {
            m.estimator
                .fit(&reg, &opts)
                .expect("the twin's trial is well posed");
        });
        println!(
            "  {method} solve    {:8.1} ms (build + solve {:.1} ms)",
            1e3 * s,
            1e3 * (build + s)
        );
    }
    simulation_step(&v, &resp);
    Ok(ExitCode::SUCCESS)
}

/// ns per RK4 step of the coupled model and of a diagonal one, scalar, on the same trial.
fn simulation_step(v: &crate::core::model::Vehicle, resp: &Response) {
    let tau: Vec<Vec6> = (0..resp.len()).map(|k| resp.tau(k)).collect();
    let steps: usize = resp
        .t
        .windows(2)
        .map(|w| crate::core::model::dynamics::substeps(w[1] - w[0], 0.01))
        .sum();
    let h = six::truth();
    let diag = crate::core::model::Hydro::diagonal(h.added_diag(), h.lin_diag(), h.quad_diag());
    for (name, hydro) in [("coupled (CUSTOM truth)", h), ("diagonal", diag)] {
        let p = Plant::new(v, hydro);
        let s = median_time(5, || {
            std::hint::black_box(p.simulate_from(
                &resp.t,
                &tau,
                resp.nu(0),
                resp.attitude(0),
                0.01,
            ));
        });
        println!(
            "  simulation, {name:22} {:7.0} ns per RK4 step ({steps} steps)",
            1e9 * s / steps as f64
        );
    }
    // Eight candidates per pass, as the output-error objective simulates them.
    let lanes = crate::core::model::lanes::LANES;
    let coupled =
        crate::core::model::lanes_coupled::CoupledLanes::new(&vec![Plant::new(v, h); lanes]);
    let start = (resp.nu(0), resp.attitude(0));
    let s = median_time(5, || {
        coupled.simulate(&resp.t, &tau, start, 0.01, &mut |_, nu| {
            std::hint::black_box(nu);
        })
    });
    let per = s / (steps * lanes) as f64;
    let flops = crate::core::model::lanes_coupled::FLOPS_PER_STEP as f64;
    println!(
        "  simulation, coupled, {lanes} per SIMD lane {:7.1} ns per RK4 step per candidate ({:.1} GFLOP/s at {flops} flops a step)",
        1e9 * per,
        flops / per / 1e9
    );
    // The diagonal model, and with the truth's weight and buoyancy (the default pool fit of a
    // vehicle that rolls and pitches), in the lane kernel.
    let mut restoring = diag;
    (restoring.net_weight, restoring.moment) = (h.net_weight, h.moment);
    for (name, hydro) in [("diagonal", diag), ("diagonal, buoyancy", restoring)] {
        let lp = crate::core::model::lanes::LanePlants::new(&vec![Plant::new(v, hydro); lanes]);
        let s = median_time(5, || {
            lp.simulate(&resp.t, &tau, start, 0.01, &mut |_, nu| {
                std::hint::black_box(nu);
            })
        });
        println!(
            "  simulation, {name}, {lanes} per SIMD lane {:6.1} ns per RK4 step per candidate",
            1e9 * s / (steps * lanes) as f64
        );
    }
}
