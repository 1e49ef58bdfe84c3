//! Drift: the model's own parameters re-estimated on the training runs, for a mismatch that
//! no left-out effect explains but the model's coefficients do.

use super::result::Reestimated;
use super::{self as dx, Augmentation, Data};
use crate::core::model::{ParamLayout, Plant};

/// The model's own parameters re-estimated on the training runs (drift), and how that model
/// does on the held-out runs: per DOF, the coefficients re-estimated by output error, by
/// equation error, or the model's own, whichever predict the held-out runs best.
pub(super) struct Drifted {
    pub(super) parameters: Vec<crate::identify::Estimate>,
    pub(super) sums: dx::Sums,
    pub(super) cost: f64,
    slots: dx::Slots,
    /// The model with the re-estimated parameters.
    plant: Plant,
}

/// How much better (a share of the held-out cost) another source's coefficients must predict
/// the held-out runs to replace the output error's in a DOF: less is the held-out runs' noise
/// choosing (a small vehicle's surge took the equation error's X_udot, 3.7 % off, for 1 % of
/// the cost, where the output error had it within 0.1 %).
const SWAP_GAIN: f64 = 0.05;

impl Drifted {
    pub(super) fn estimate(
        vehicle: &crate::core::model::Vehicle,
        fused: &[crate::pool::fusion::run::FusedRun],
        data: &Data,
        plant: &Plant,
    ) -> anyhow::Result<Drifted> {
        let layout = ParamLayout::of(vehicle);
        let start = layout.from_hydro(&plant.hydro);
        let own = point_estimates(
            &layout,
            &start,
            "the model's own value: re-estimated, it predicted the held-out runs worse",
        );
        let (equation, output) = reestimate(vehicle, fused, data, &start)?;
        let model_of = |ps: &[crate::identify::Estimate]| {
            let values: Vec<f64> = ps.iter().map(|p| p.value).collect();
            super::beside::with_theta(vehicle, plant, &layout, &values)
        };
        let score = |ps: &[crate::identify::Estimate]| {
            let sums = data.eval(&model_of(ps), &Augmentation::default(), true);
            let cost = sums.cost(&data.scale);
            (sums, cost)
        };
        let sources = [&equation, &own];
        let (s, c) = score(&output);
        let (mut parameters, mut sums, mut cost) = (output.clone(), Some(s), c);
        // Per DOF, the coefficients that predict the held-out runs clearly best: a DOF the training
        // runs barely excite can take output-error coefficients that trade one drag against
        // the other (a small vehicle's heave: linear drag x3.4, quadratic /10, its held-out
        // NMAE from 0.02 to 0.15) where the equation error, or the model's own, hold.
        for j in data.slots.on() {
            let dof = data.slots.dof(j);
            for from in sources {
                let mut mixed = parameters.clone();
                let mut moved = false;
                for ((t, p), q) in layout.terms.iter().zip(&mut mixed).zip(from.iter()) {
                    if t.dof() == dof && p.value != q.value {
                        (*p, moved) = (q.clone(), true);
                    }
                }
                if !moved {
                    continue;
                }
                let (s, c) = score(&mixed);
                if c < (1.0 - SWAP_GAIN) * cost {
                    (parameters, sums, cost) = (mixed, Some(s), c);
                }
            }
        }
        let sums = sums.unwrap_or_else(|| score(&parameters).0);
        let plant = model_of(&parameters);
        Ok(Drifted {
            parameters,
            sums,
            cost,
            slots: data.slots,
            plant,
        })
    }

    /// Whether the re-estimate explains what the model leaves structured inside the pooled
    /// noise: the model's held-out cost within the noise but a DOF's residual structured
    /// above its own (the one rule then calls it unexplained), and the re-estimated model
    /// within the noise, below the named effects' cost (`after_effects`), with no DOF
    /// structured. On a vehicle 1.5 times the reference's length whose added masses were
    /// 1.5-2 % off, the Munk moment (Y_vdot - X_udot) u v left yaw 6.4 times its noise
    /// while the pooled cost was 1.2 times the floor; re-estimated, 0.97 times and yaw
    /// white. Halving the pooled cost, which drift otherwise asks, cannot happen there: the
    /// other DOFs' noise is most of it.
    pub(super) fn clears_structure(
        &self,
        plant: &Plant,
        data: &Data,
        crit: &dx::Criteria,
        (base, after_effects): (f64, f64),
    ) -> bool {
        use super::noise_rule::within_noise;
        use super::unexplained::structured_left;
        let none = Augmentation::default();
        within_noise(crit, data, base)
            && within_noise(crit, data, self.cost)
            && self.cost < after_effects
            && self.cost < base
            && !structured_left(plant, data, &none, crit).is_empty()
            && structured_left(&self.plant, data, &none, crit).is_empty()
    }

    /// The report's record of the re-estimated model.
    pub(super) fn into_record(self, within_noise: bool) -> Reestimated {
        Reestimated {
            parameters: self.parameters,
            validation_nmae: dx::nmae_map(&self.sums, &self.slots),
            validation_cost: self.cost,
            within_noise,
            beside: Vec::new(),
        }
    }
}

/// The report's record of the model re-estimated beside named effects
/// ([`super::beside`]): its coefficients (no standard errors: the re-estimate is a point
/// fit) and how it predicts the held-out runs with the effects.
pub(super) fn beside_record(
    vehicle: &crate::core::model::Vehicle,
    data: &Data,
    b: &super::beside::Beside,
    within_noise: bool,
) -> Reestimated {
    let layout = ParamLayout::of(vehicle);
    let values = layout.from_hydro(&b.plant.hydro);
    let parameters = point_estimates(&layout, &values, "re-estimated beside the named effects");
    let sums = data.eval(&b.plant, &dx::augmentation(&b.selected), true);
    Reestimated {
        parameters,
        validation_nmae: dx::nmae_map(&sums, &data.slots),
        validation_cost: b.cost,
        within_noise,
        beside: b.selected.iter().map(|(h, _)| h.name.to_string()).collect(),
    }
}

/// Coefficients `values` (in `layout`'s order) as estimates without standard errors (a point
/// fit, or the model's own value), each with `note`.
fn point_estimates(
    layout: &ParamLayout,
    values: &[f64],
    note: &str,
) -> Vec<crate::identify::Estimate> {
    (layout.terms.iter().zip(values))
        .map(|(t, v)| crate::identify::Estimate {
            name: t.name(),
            value: *v,
            unit: t.unit().to_string(),
            stderr: f64::NAN,
            interval: None,
            identifiable: true,
            note: Some(note.to_string()),
        })
        .collect()
}

/// The model's parameters re-estimated on the training runs, from the model's own values
/// (`start`): by equation error (least squares on the fused velocities), and by the
/// prediction-error method (output error, the added mass inside its prior) with no command
/// lag (a lag is an effect of the table, tested on its own).
fn reestimate(
    vehicle: &crate::core::model::Vehicle,
    fused: &[crate::pool::fusion::run::FusedRun],
    data: &Data,
    start: &[f64],
) -> anyhow::Result<(
    Vec<crate::identify::Estimate>,
    Vec<crate::identify::Estimate>,
)> {
    use crate::identify::Estimator as _;
    let train: Vec<crate::core::response::Response> = fused
        .iter()
        .filter(|r| data.train.iter().any(|t| t.name == r.meta.run))
        .filter_map(|r| r.as_response(vehicle, None))
        .collect();
    let refs: Vec<&crate::core::response::Response> = train.iter().collect();
    let problem = crate::identify::Regression::build(vehicle, &refs, 1.0);
    let equation = crate::identify::ols::Ols.fit(&problem, &Default::default())?;
    let mut opts = crate::identify::Options {
        rigid_mass: vehicle.rigid_mass(),
        output_error: Some((vehicle, &refs[..])),
        ..Default::default()
    };
    crate::identify::pem::PemSettings::default().apply(&mut opts);
    opts.command_lag = crate::identify::lag::CommandLag::None;
    opts.start = Some(start);
    let output = crate::identify::pem::Pem.fit(&problem, &opts)?;
    Ok((equation.parameters, output.parameters))
}
