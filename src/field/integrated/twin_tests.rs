//! The integrated regressor against the DSRV twin (seed 000), whose dynamics are written apart
//! from it.

mod identification {
    use crate::field::integrated::{Equation, least_squares, windows};
    use crate::twin::dsrv::*;

    /// Seed 000's claim on its own terms: from noise-free samples at 10 Hz the integrated
    /// regressor recovers every coefficient (the trapezoid's error only).
    #[test]
    fn noise_free_samples_give_the_coefficients() {
        let v = Dsrv::healey();
        let rec = fly(&v, &default_runs()[0]);
        let col = |j: usize| rec.x.iter().map(|x| x[j]).collect::<Vec<f64>>();
        let phi = vec![col(0), col(1), col(2), rec.delta.clone()];
        let held = vec![false, false, false, true];
        let truth = v.coefficients();
        for (i, tr) in truth.iter().enumerate() {
            let eq = Equation {
                y: col(i),
                phi: phi.clone(),
                held: held.clone(),
            };
            let est = least_squares(&[&windows(&rec.t, &eq, 1)]).unwrap();
            for (j, (x, t)) in est.theta.iter().zip(tr).enumerate() {
                let tol = 0.01 * t.abs() + 2e-3;
                assert!((x - t).abs() < tol, "{}: {x} vs {t}", NAMES[i][j]);
            }
        }
    }
}
