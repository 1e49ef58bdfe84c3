//! The model's own coefficients re-estimated beside the named effects, and the named effects
//! that this makes redundant dropped (backward elimination against drift).
//!
//! The greedy rounds fit each effect on top of the model as it is. When the model's
//! coefficients are also a little off, an effect of the table can stand in for them: on a
//! BlueROV2 Heavy-sized twin whose added masses were 2 % off, a right net buoyancy was named
//! with `coupled_drag` (-0.62) beside it, the Munk moment of the added-mass error taken for a
//! coupled drag, and the yaw left unexplained at 17 times its noise. Re-estimating the
//! coefficients with the named effects held, then asking of each named effect whether the
//! held-out runs still need it, separates the two: what the coefficients take up is drift,
//! what they cannot is a left-out effect.

use super::discover::Discovered;
use super::{self as dx, Augmentation, Criteria, Data, SLOTS, Selection};
use crate::core::model::{ParamLayout, Plant, Vehicle};
use crate::identify::refine::Bounds;
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

/// The model re-estimated beside a set of named effects, and the effects refitted on it.
#[derive(Clone)]
pub(super) struct Beside {
    pub(super) plant: Plant,
    pub(super) selected: Selection,
    /// Held-out cost of the re-estimated model with the effects.
    pub(super) cost: f64,
    /// Where the coefficients may go: around the model as it is ([`around`]).
    pub(super) bounds: Bounds,
}

/// Levenberg-Marquardt steps at most, first with the effects as the greedy rounds fitted
/// them, then once more after refitting them on the re-estimated model.
const STEPS: [usize; 2] = [8, 4];

/// How much better the model re-estimated beside the named effects must predict the held-out
/// runs than the named effects on the model as it is, as a share of the latter's cost, for
/// the re-estimate to be taken: the margin an effect needs ([`Criteria::min_gain`]).
fn worth_it(crit: &Criteria, with_effects: f64, beside: f64) -> bool {
    beside < (1.0 - crit.min_gain) * with_effects
}

/// Whether the re-estimated model still needs an effect: dropping it raises the held-out
/// cost from `with` to `without` by the relative margin an effect needs (step 4's
/// `min_gain` plus `gain_per_parameter` per parameter). The forward rounds' other test, a
/// drop larger than half the noise floor, is not asked again: the effect passed it when it
/// was named, and near the floor it would hand a weak effect to the re-estimated model,
/// which with every coefficient free takes up part of anything (a tether's drag of 0.15 on
/// the small twin, named at 0.0105 -> 0.0027: 0.0021 with it re-estimated, 0.0030 without).
fn still_needed(crit: &Criteria, without: f64, with: f64, params: f64) -> bool {
    (without - with) / without - crit.gain_per_parameter * params >= crit.min_gain
}

/// The outcome of settling the named effects beside the re-estimated model.
pub(super) struct Settled {
    pub(super) beside: Beside,
    /// The sentences of each change, in the order made, each with whether it dropped (or
    /// replaced) a named effect, and the numbers that decided it.
    pub(super) said: Vec<(bool, String)>,
}

/// The named effects `selected` (at held-out cost `with_effects` on the model as it is)
/// with the model's own coefficients re-estimated beside them; each effect the re-estimated
/// model no longer needs (dropping it loses less than the margin an effect needs) dropped,
/// the weakest first. `None` when the re-estimate does not beat the effects on the model as
/// it is by that margin, or leaves more than the re-estimated model's allowance
/// ([`super::noise_rule::reestimate_within_noise`]): the coefficients have then taken up part
/// of something missing. `drift_cost` is the held-out cost of the model re-estimated with no
/// effect (what dropping the last one leaves).
pub(super) fn settle(
    vehicle: &Vehicle,
    plant: &Plant,
    data: &Data,
    crit: &Criteria,
    (selected, with_effects): (&Selection, f64),
    drift_cost: f64,
    progress: &(dyn Fn(&str) + Sync),
) -> Option<Settled> {
    if selected.is_empty() {
        return None;
    }
    progress("re-estimating the model's parameters beside the named effects");
    let layout = ParamLayout::of(vehicle);
    let bounds = around(&layout, vehicle, plant);
    let mut full = Beside::fit(vehicle, plant, data, (selected, &[]), &bounds);
    if !worth_it(crit, with_effects, full.cost) {
        return None;
    }
    let mut said = Vec::new();
    // The effects dropped: not taken back by a later round.
    let mut gone: Vec<&'static str> = Vec::new();
    // Drop what the re-estimated model does not need, try one more round on it, and drop
    // again after a change (an effect taken in that round may make one kept before
    // redundant); a few times at most.
    for _ in 0..3 {
        let out = eliminate(vehicle, data, crit, (&mut full, drift_cost));
        for (name, sentence) in out {
            gone.push(name);
            said.push((true, sentence));
        }
        let before: Vec<&'static str> = full.selected.iter().map(|(h, _)| h.name).collect();
        let (next, swap) = swapped(vehicle, data, crit, (full, &gone));
        full = next;
        gone.extend(
            before
                .into_iter()
                .filter(|n| !full.selected.iter().any(|(h, _)| h.name == *n)),
        );
        match swap {
            Some(change) => said.push(change),
            None => break,
        }
    }
    // A re-estimate that still leaves more than the re-estimated model's allowance has taken
    // part of what is missing into the coefficients: discovery then looks for it on the model
    // as it is (a cross flow's loss of thrust, left at 13 times the floor beside
    // `thruster_deadband`, was found as `|u| Y` at -0.40 where the twin has -0.5).
    if !super::noise_rule::reestimate_within_noise(crit, data, full.cost) {
        return None;
    }
    // Nor, above the noise, is one taken that leaves a DOF's residual structured: the
    // coefficients have then stood in for part of something the effects do not hold (a
    // thrust lost to the inflow beside `coupled_drag`: X_udot -15.9 -> -21.8, X_uu -44 ->
    // -72, 3.6 times the floor with yaw 14-60 times its noise), and discovery looks for it
    // on the model as it is. Within the noise the allowance is not at stake: a sensor delay
    // beside coefficients 1-2.5 % off, re-estimated to 1.1 times the floor, is taken.
    let aug = dx::augmentation(&full.selected);
    if !super::noise_rule::within_noise(crit, data, full.cost)
        && !super::unexplained::structured_left(&full.plant, data, &aug, crit).is_empty()
    {
        return None;
    }
    Some(Settled { beside: full, said })
}

/// Backward elimination on the re-estimated model: the weakest named effect of `full` that
/// the model re-estimated beside the others does not need ([`still_needed`]) is dropped,
/// until each is needed or none is left (then `full` is the model re-estimated alone, at
/// `drift_cost`). Returns each effect dropped with its sentence.
fn eliminate(
    vehicle: &Vehicle,
    data: &Data,
    crit: &Criteria,
    (full, drift_cost): (&mut Beside, f64),
) -> Vec<(&'static str, String)> {
    let mut dropped = Vec::new();
    while !full.selected.is_empty() {
        // Each effect's loss: the re-estimated model beside the others, without it.
        let without: Vec<(usize, f64, Option<Beside>)> = (0..full.selected.len())
            .map(|i| {
                let mut rest = full.selected.clone();
                rest.remove(i);
                if rest.is_empty() {
                    (i, drift_cost, None)
                } else {
                    let b = Beside::fit(vehicle, &full.plant, data, (&rest, &[]), &full.bounds);
                    (i, b.cost, Some(b))
                }
            })
            .collect();
        let weakest = without
            .into_iter()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("at least one effect");
        let (i, cost_without, rest) = weakest;
        let (h, p) = &full.selected[i];
        if still_needed(crit, cost_without, full.cost, h.free_params(p)) {
            break;
        }
        let name = h.name;
        dropped.push((name, format!(
            "The named effect {} was dropped: with the model's own parameters re-estimated beside {}, the held-out runs do not need it (error cost {:.4} with it, {cost_without:.4} without)",
            h.name,
            match full.selected.len() {
                1 => "nothing else".to_string(),
                _ => full
                    .selected
                    .iter()
                    .filter(|(o, _)| o.name != h.name)
                    .map(|(o, _)| o.name)
                    .collect::<Vec<_>>()
                    .join(" and "),
            },
            full.cost
        )));
        match rest {
            Some(b) => *full = b,
            None => {
                full.selected.clear();
                full.cost = cost_without;
            }
        }
    }
    dropped
}

/// One more round on the re-estimated model, when with the effects kept it still leaves more
/// than `within_noise` times the noise floor: each effect of the table not kept is fitted on
/// it in place of each kept effect, and beside them all (an effect dropped before is not
/// taken back) (while fewer than `max_effects`); the
/// best on the training runs is re-estimated with the others, and taken when it predicts the
/// held-out runs better by the margin an effect needs (in place of one: `min_gain`; beside
/// them: step 4's test, [`super::select::significant`]). The greedy rounds chose on the model
/// as it is, where the coefficients' own error took part of the mismatch: on the small twin
/// a sensor delay of 0.15 s was named `thruster_lag`, its yaw left at 116 times its noise.
/// Returns the settled model and the sentence of the change (`true`: an effect replaced).
fn swapped(
    vehicle: &Vehicle,
    data: &Data,
    crit: &Criteria,
    (full, gone): (Beside, &[&str]),
) -> (Beside, Option<(bool, String)>) {
    use rayon::prelude::*;
    if full.selected.is_empty() || full.cost <= crit.within_noise * data.noise_cost {
        return (full, None);
    }
    let kept = &full.selected;
    let others: Vec<&'static dx::Hypothesis> = (data.effects.iter().copied())
        .filter(|h| {
            super::testable::applicable(h, data)
                && !kept.iter().any(|(k, _)| k.name == h.name)
                && !gone.contains(&h.name)
        })
        .collect();
    // `None`: beside them all; `Some(i)`: in place of kept effect `i`.
    let mut places: Vec<Option<usize>> = (0..kept.len()).map(Some).collect();
    if kept.len() < crit.max_effects {
        places.push(None);
    }
    let tries: Vec<(Option<usize>, &'static dx::Hypothesis)> = (places.iter())
        .flat_map(|w| others.iter().map(move |h| (*w, *h)))
        .collect();
    let fitted: Vec<(Option<usize>, Selection, f64)> = tries
        .par_iter()
        .filter_map(|(w, h)| {
            let mut rest = kept.clone();
            if let Some(i) = w {
                rest.remove(*i);
            }
            let (p, train) = super::search::fit_beside(&full.plant, data, (&rest, &[]), h);
            if !super::select::at_bound(h, &p, data.size).is_empty() || !train.is_finite() {
                return None;
            }
            rest.push((*h, p));
            Some((*w, rest, train))
        })
        .collect();
    let Some((w, sel, _)) = fitted.into_iter().min_by(|a, b| a.2.total_cmp(&b.2)) else {
        return (full, None);
    };
    let b = Beside::fit(vehicle, &full.plant, data, (&sel, &[]), &full.bounds);
    let (h, p) = sel.last().expect("the effect tried");
    let better = match w {
        Some(_) => b.cost < (1.0 - crit.min_gain) * full.cost,
        None => super::select::significant(crit, data, full.cost, b.cost, h.free_params(p)),
    };
    if !better {
        return (full, None);
    }
    let sentence = match w {
        Some(i) => (
            true,
            format!(
                "With the model's own parameters re-estimated, {} explains the held-out runs better in place of {} (error cost {:.4} against {:.4}), and is named instead",
                h.name, kept[i].0.name, b.cost, full.cost
            ),
        ),
        None => (
            false,
            format!(
                "With the model's own parameters re-estimated, {} explains more beside the named effects (error cost {:.4} against {:.4}), and is named too",
                h.name, b.cost, full.cost
            ),
        ),
    };
    (b, Some(sentence))
}

impl Beside {
    /// The model's coefficients re-estimated by output error on the training runs with the
    /// effects `selected` held (and discovered `terms`, as found), the effects refitted on
    /// the re-estimated model, and the coefficients re-estimated once more beside them; from
    /// `plant`'s coefficients (the model as it is, or for a later change the model already
    /// re-estimated, so that a change is judged from where the last one left it), within
    /// `bounds`.
    pub(super) fn fit(
        vehicle: &Vehicle,
        plant: &Plant,
        data: &Data,
        (selected, terms): (&Selection, &[Arc<Discovered>]),
        bounds: &Bounds,
    ) -> Beside {
        let layout = ParamLayout::of(vehicle);
        let aug = dx::augmentation_beside(selected, terms);
        let first = lm(vehicle, plant, data, (&layout, bounds), &aug, STEPS[0]);
        let refit = super::search::refine_all(&first, data, selected, terms);
        let aug = dx::augmentation_beside(&refit, terms);
        let second = lm(vehicle, &first, data, (&layout, bounds), &aug, STEPS[1]);
        let cost = data.cost(&second, &aug, true);
        Beside {
            plant: second,
            selected: refit,
            cost,
            bounds: bounds.clone(),
        }
    }
}

/// How far the re-estimate beside named effects may move a coefficient, as a share of the
/// model's own value: it corrects a model a little off (the twins' coefficients are moved
/// 1-2.5 %); a model far off is drift, re-estimated alone ([`super::drift`]).
const MOVE: f64 = 0.25;

/// The re-estimate's bounds around the model as it is (`plant`): each coefficient within
/// [`MOVE`] of its own value (one at zero within the plausible range), inside the
/// identification's plausible ranges, each added mass's prior (0 to 2 times the rigid-body
/// term) widened to hold the model's own value.
///
/// A CFD model's heave added mass is often more than twice the mass (the reference ROV's is
/// 2.4 times): clamped into the prior, the re-estimate started from a model it was not, the
/// heave's held-out NMAE went from 0.03 to 0.10 on a twin 1.5 times the reference's length
/// and the re-estimate was refused beside a right net buoyancy. Free to go anywhere
/// plausible, the coefficients took in part of a thrust lost to the inflow beside
/// `coupled_drag` (X_udot -15.9 -> -21.8, X_uu -44 -> -72) and the loss was named
/// `coupled_drag`.
fn around(layout: &ParamLayout, vehicle: &Vehicle, plant: &Plant) -> Bounds {
    let rigid = vehicle.rigid_mass();
    let added = plant.hydro.added_diag();
    let prior: [f64; 6] = std::array::from_fn(|i| {
        let ratio = if rigid[i] > 0.0 {
            -added[i] / rigid[i]
        } else {
            0.0
        };
        crate::identify::pem::DEFAULT_PRIOR.max(ratio)
    });
    let mut b = crate::identify::pem::plausible(layout, &rigid, &prior);
    for (j, own) in layout.from_hydro(&plant.hydro).into_iter().enumerate() {
        let reach = MOVE * own.abs();
        if reach > 0.0 {
            b.lo[j] = b.lo[j].max(own - reach).min(own);
            b.hi[j] = b.hi[j].min(own + reach).max(own);
        }
    }
    b
}

/// `plant` with coefficients `theta` (in `layout`'s order).
pub(super) fn with_theta(
    vehicle: &Vehicle,
    plant: &Plant,
    layout: &ParamLayout,
    theta: &[f64],
) -> Plant {
    let mut h = plant.hydro;
    for (t, v) in layout.terms.iter().zip(theta) {
        h.set(*t, *v);
    }
    Plant::new(vehicle, h)
}

/// The training runs' residuals, each DOF's divided by the square root of its sample count
/// times its mean square velocity: their sum of squares is the training cost's mean-square
/// form (samples before a delay's start count as zero).
fn weighted(data: &Data, plant: &Plant, aug: &Augmentation) -> Vec<f64> {
    let res = dx::residuals(plant, aug, &data.train);
    let n: [f64; SLOTS] = std::array::from_fn(|j| {
        (data.train.iter())
            .map(|r| r.vel[j].len() as f64)
            .sum::<f64>()
            .max(1.0)
    });
    let w: [f64; SLOTS] = std::array::from_fn(|j| 1.0 / (n[j] * data.scale[j]).sqrt());
    res.iter()
        .flat_map(|r| {
            (0..SLOTS).flat_map(move |j| {
                r[j].iter()
                    .map(move |e| if e.is_finite() { e * w[j] } else { 0.0 })
            })
        })
        .collect()
}

fn sum_sq(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

/// Levenberg-Marquardt on the training runs' simulated velocities (the diagnosis's own
/// simulation, re-anchored as the runs say, with the effects of `aug`), from `plant`'s
/// coefficients, within `bounds`; forward-difference Jacobian. A step that does not lower
/// the error is not taken.
fn lm(
    vehicle: &Vehicle,
    plant: &Plant,
    data: &Data,
    (layout, bounds): (&ParamLayout, &Bounds),
    aug: &Augmentation,
    steps: usize,
) -> Plant {
    let mut theta = layout.from_hydro(&plant.hydro);
    bounds.clamp(&mut theta);
    let residual = |th: &[f64]| weighted(data, &with_theta(vehicle, plant, layout, th), aug);
    let mut r = residual(&theta);
    let mut cost = sum_sq(&r);
    if !cost.is_finite() {
        return plant.clone();
    }
    let p = theta.len();
    let mut lambda: f64 = 1e-3;
    for _ in 0..steps {
        if crate::core::interrupt::requested() {
            break;
        }
        let columns: Vec<Vec<f64>> = (0..p)
            .map(|j| {
                let h = 1e-3 * theta[j].abs().max(0.1);
                let mut th = theta.clone();
                // Forward, or backward where forward would leave the range.
                let step = if theta[j] + h <= bounds.hi[j] { h } else { -h };
                th[j] += step;
                let rj = residual(&th);
                rj.iter().zip(&r).map(|(a, b)| (a - b) / step).collect()
            })
            .collect();
        if columns.iter().flatten().any(|x| !x.is_finite()) {
            break;
        }
        let a = DMatrix::from_fn(p, p, |i, k| {
            columns[i]
                .iter()
                .zip(&columns[k])
                .map(|(x, y)| x * y)
                .sum::<f64>()
        });
        let g = DVector::from_fn(p, |i, _| {
            columns[i].iter().zip(&r).map(|(x, y)| x * y).sum::<f64>()
        });
        let mut improved = false;
        for _ in 0..6 {
            let mut m = a.clone();
            for i in 0..p {
                m[(i, i)] += lambda * a[(i, i)].max(1e-12);
            }
            let Some(delta) = m.cholesky().map(|c| c.solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            let mut next: Vec<f64> = theta.iter().zip(delta.iter()).map(|(t, d)| t + d).collect();
            bounds.clamp(&mut next);
            let rn = residual(&next);
            let cn = sum_sq(&rn);
            if cn.is_finite() && cn < cost {
                let gain = (cost - cn) / cost;
                (theta, r, cost) = (next, rn, cn);
                lambda = (lambda / 3.0).max(1e-9);
                improved = gain > 1e-5;
                break;
            }
            lambda *= 4.0;
        }
        if !improved {
            break;
        }
    }
    with_theta(vehicle, plant, layout, &theta)
}

/// The verdict's note on a model re-estimated beside the named effects (`before`: the named
/// effects' held-out cost on the model as it is).
pub(super) fn note(b: &Beside, before: f64) -> String {
    format!(
        "The named effects are fitted with the model's own parameters re-estimated beside them (held-out error cost {:.4}; on the model as it is {before:.4}): use the re-estimated parameters",
        b.cost
    )
}
