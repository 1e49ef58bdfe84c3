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
