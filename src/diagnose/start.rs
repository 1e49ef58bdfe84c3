//! Which model a diagnosis starts from. When `from` lists several fits of the vehicle and the
//! stage names no `model`, each is simulated on the held-out runs. A fit from CFD is
//! diagnosed when there is one (the best of them): the physics it leaves out is what the
//! diagnosis is for, while a fit to the pool runs absorbs some of it into its coefficients
//! (on the twin, a pool fit had taken in the thruster lag and the tether drag that the CFD
//! model's mismatch names). Without a CFD fit, the fit that predicts the held-out runs best
//! is diagnosed. Every candidate's held-out error is reported beside it.

pub use super::result::Start;
use super::{Criteria, Data};
use crate::core::model::Plant;
use crate::pool::fusion::run::FusedRun;
use std::collections::BTreeMap;

/// How fit `f`, as the model `plant` (its command lag applied to the runs), predicts the
/// held-out runs: the error cost and NMAE per DOF, or why it cannot be scored.
pub fn held_out(
    f: &crate::identify::result::FitResult,
    plant: &Plant,
    fused: &[FusedRun],
    crit: &Criteria,
) -> Start {
    let fused: Vec<FusedRun> = fused
        .iter()
        .map(|r| r.clone().with_command_of(plant))
        .collect();
    let (runs, _, _) = super::verdict::prepare_runs(plant, &fused, crit);
    let scored = Data::new(runs).map_err(|e| e.to_string()).and_then(|data| {
        let diverged = super::verdict::diverged_runs(plant, &data);
        if !diverged.is_empty() {
            return Err(format!(
                "its simulation diverges on {}",
                diverged.join(", ")
            ));
        }
        let sums = data.eval(plant, &super::Augmentation::default(), true);
        Ok((sums.cost(&data.scale), super::nmae_map(&sums, &data.slots)))
    });
    let (validation_cost, validation_nmae, note) = match scored {
        Ok((c, n)) => (c, n, None),
        Err(e) => (f64::NAN, BTreeMap::new(), Some(e)),
    };
    Start {
        model: f.stage.clone(),
        method: f.method.clone(),
        from_cfd: !f.cases.is_empty(),
        validation_cost,
        validation_nmae,
        chosen: false,
        note,
    }
}

/// Marks the one to diagnose as chosen and returns its index: of the fits from CFD, else of
/// all, the one with the lowest finite held-out cost (the first when none could be scored).
pub fn choose(starts: &mut [Start]) -> usize {
    let lowest = |cfd_only: bool| {
        (0..starts.len())
            .filter(|&i| starts[i].validation_cost.is_finite() && (starts[i].from_cfd || !cfd_only))
            .min_by(|&a, &b| {
                starts[a]
                    .validation_cost
                    .total_cmp(&starts[b].validation_cost)
            })
    };
    let best = lowest(true).or_else(|| lowest(false)).unwrap_or(0);
    if let Some(s) = starts.get_mut(best) {
        s.chosen = true;
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn start(model: &str, cost: f64) -> Start {
        Start {
            model: model.into(),
            method: "ols".into(),
            from_cfd: model.starts_with("cfd"),
            validation_cost: cost,
            validation_nmae: BTreeMap::new(),
            chosen: false,
            note: None,
        }
    }

    #[test]
    fn a_cfd_fit_is_chosen_else_the_best_scored_and_a_diverged_one_never() {
        let mut s = vec![
            start("pool", 0.05),
            start("cfd_a", 0.3),
            start("cfd_b", 0.2),
        ];
        assert_eq!(choose(&mut s), 2);
        assert!(s[2].chosen && !s[0].chosen && !s[1].chosen);
        let mut s = vec![start("cfd", f64::NAN), start("pool", 0.2), start("b", 0.1)];
        assert_eq!(choose(&mut s), 2);
        let mut s = vec![start("cfd", f64::NAN), start("pool", f64::NAN)];
        assert_eq!(choose(&mut s), 0);
    }
}
