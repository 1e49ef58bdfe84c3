//! Drift: the model's own parameters re-estimated on the training runs, for a mismatch that
//! no left-out effect explains but the model's coefficients do.

use super::result::Reestimated;
use super::{self as dx, Augmentation, Data};
use crate::core::model::{ParamLayout, Plant};

/// The model's own parameters re-estimated on the training runs (drift), and how that model
/// does on the held-out runs.
pub(super) struct Drifted {
    pub(super) parameters: Vec<crate::identify::Estimate>,
    pub(super) sums: dx::Sums,
    pub(super) cost: f64,
    slots: dx::Slots,
}

impl Drifted {
    pub(super) fn estimate(
        vehicle: &crate::core::model::Vehicle,
        fused: &[crate::pool::fusion::run::FusedRun],
        data: &Data,
    ) -> anyhow::Result<Drifted> {
        let parameters = reestimate(vehicle, fused, data)?;
        let values: Vec<f64> = parameters.iter().map(|p| p.value).collect();
        let plant = Plant::new(vehicle, ParamLayout::of(vehicle).to_hydro(&values));
        let sums = data.eval(&plant, &Augmentation::default(), true);
        let cost = sums.cost(&data.scale);
        Ok(Drifted {
            parameters,
            sums,
            cost,
            slots: data.slots,
        })
    }

    /// The report's record of the re-estimated model.
    pub(super) fn into_record(self, within_noise: bool) -> Reestimated {
        Reestimated {
            parameters: self.parameters,
            validation_nmae: dx::nmae_map(&self.sums, &self.slots),
            validation_cost: self.cost,
            within_noise,
        }
    }
}

/// The model's parameters re-estimated on the training runs: equation error, least squares.
fn reestimate(
    vehicle: &crate::core::model::Vehicle,
    fused: &[crate::pool::fusion::run::FusedRun],
    data: &Data,
) -> anyhow::Result<Vec<crate::identify::Estimate>> {
    use crate::identify::Estimator as _;
    let train: Vec<crate::core::response::Response> = fused
        .iter()
        .filter(|r| data.train.iter().any(|t| t.name == r.meta.run))
        .filter_map(|r| r.as_response(vehicle, None))
        .collect();
    let refs: Vec<&crate::core::response::Response> = train.iter().collect();
    let problem = crate::identify::Regression::build(vehicle, &refs, 1.0);
    Ok(crate::identify::ols::Ols
        .fit(&problem, &Default::default())?
        .parameters)
}
