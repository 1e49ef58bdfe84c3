//! Choosing the effects: greedy forward selection on held-out runs (module docs, step 3),
//! with a swap step for effects that only make sense together.

use super::testable::applicable;
use super::{Augmentation, Data, Hypothesis, Selection, augmentation, search};
use crate::core::model::Plant;
use rayon::prelude::*;

mod joint;
mod rules;

pub use joint::Possible;
use joint::{Fitted, Rival, fit_candidates, strong_rivals};
pub use rules::{Criteria, Tested, at_bound, params_map, significant};
use rules::{corroborated, score};

/// Result of the greedy search.
pub struct Search {
    pub selected: Selection,
    pub tested: Vec<Tested>,
    /// Held-out cost of the CFD model, then after each accepted effect.
    pub costs: Vec<f64>,
    /// Rivals of the last kept effect that, fitted together with the kept effects in the
    /// round that ended the search, lowered the held-out cost by the share an effect needs
    /// but by less than the noise margin ([`joint`]).
    pub possible: Vec<Possible>,
}

/// The effects that can be tested on these runs and are not in `selected` yet.
fn untried<'a>(
    data: &'a Data,
    selected: &'a Selection,
) -> impl Iterator<Item = &'static Hypothesis> + 'a {
    data.effects
        .iter()
        .copied()
        .filter(move |h| applicable(h, data) && !selected.iter().any(|(s, _)| s.name == h.name))
}

/// Greedy forward selection of effects on top of `plant` (module docs, step 3).
pub fn select(
    plant: &Plant,
    data: &Data,
    criteria: &Criteria,
    progress: &(dyn Fn(&str) + Sync),
) -> Search {
    let mut selected: Selection = Vec::new();
    let mut tested = Vec::new();
    let mut current = data.cost(plant, &Augmentation::default(), true);
    let mut current_train = data.cost(plant, &Augmentation::default(), false);
    let mut costs = vec![current];
    let mut rivals: Vec<Rival> = Vec::new();
    let mut possible = Vec::new();
    for round in 1..=criteria.max_effects {
        let candidates: Vec<&'static Hypothesis> = untried(data, &selected).collect();
        progress(&format!(
            "round {round}: testing {} effects",
            candidates.len()
        ));
        let on_top = (&selected, current_train);
        let fitted = fit_candidates(plant, data, criteria, on_top, &candidates, &rivals);
        // What the joint fits of this round found too small to name: it stands only if the
        // search ends here, with the kept effects it was fitted beside.
        possible = fitted.iter().filter_map(|f| f.5.clone()).collect();
        let mut rows = tested_rows(&fitted, criteria, (current, data.size), round);
        let Some(b) = best_row(&rows, criteria, current_train) else {
            // Every candidate is refused (not corroborated on the training runs, or on a
            // bound): the round's rows still go to the report.
            tested.extend(rows);
            break;
        };
        let (h, p, _, val, _, _) = &fitted[b];
        if !significant(criteria, data, current, *val, h.free_params(p))
            || outgained_on_a_bound(&rows, b, criteria, current_train)
        {
            tested.extend(rows);
            break;
        }
        progress(&format!(
            "round {round}: {} kept, refining every kept effect together",
            h.name
        ));
        rivals = strong_rivals(&fitted, &rows, b, criteria, data, (current, current_train));
        match keep(plant, data, &fitted[b].4, (*h, p.clone())) {
            Ok(kept) => selected = kept,
            Err(on_bound) => {
                rows[b].at_bound = on_bound;
                tested.extend(rows);
                break;
            }
        }
        rows[b].accepted = true;
        possible.clear();
        let aug = augmentation(&selected);
        (current, current_train) = (data.cost(plant, &aug, true), data.cost(plant, &aug, false));
        costs.push(current);
        tested.extend(rows);
        if selected.len() > 1
            && let Some((out, row)) = swap(
                plant,
                data,
                criteria,
                &mut selected,
                (current, current_train),
                round,
                progress,
            )
        {
            (current, current_train) = (row.validation_cost, row.train_cost);
            *costs.last_mut().expect("pushed above") = current;
            record_swap(&mut tested, &out, row);
        }
    }
    Search {
        selected,
        tested,
        costs,
        possible,
    }
}

/// The best-scoring row among those corroborated on the training runs and off their bounds.
fn best_row(rows: &[Tested], criteria: &Criteria, current_train: f64) -> Option<usize> {
    (0..rows.len())
        .filter(|&i| {
            corroborated(criteria, current_train, rows[i].train_cost) && rows[i].at_bound.is_empty()
        })
        .max_by(|&a, &b| rows[a].score.total_cmp(&rows[b].score))
}

/// Whether an effect refused on its search bound gained over twice what row `b` does. The data
/// then want something beyond that effect's range; naming the lesser effect would patch the
/// mismatch with the wrong physics, so the search stops and what is left is `unexplained`.
fn outgained_on_a_bound(rows: &[Tested], b: usize, criteria: &Criteria, train: f64) -> bool {
    rows.iter().any(|r| {
        !r.at_bound.is_empty()
            && corroborated(criteria, train, r.train_cost)
            && r.gain > 2.0 * rows[b].gain
    })
}

/// The effect swapped out no longer counts as kept; its replacement's row is added.
fn record_swap(tested: &mut Vec<Tested>, out: &str, row: Tested) {
    if let Some(t) = tested.iter_mut().find(|t| t.accepted && t.name == out) {
        t.accepted = false;
    }
    tested.push(row);
}

/// The report's rows of one round: each candidate's parameters, costs, gain and score.
fn tested_rows(
    fitted: &[Fitted],
    criteria: &Criteria,
    (current, size): (f64, f64),
    round: usize,
) -> Vec<Tested> {
    fitted
        .iter()
        .map(|(h, p, tc, vc, _, _)| Tested {
            round,
            name: h.name.into(),
            parameters: params_map(h, p),
            train_cost: *tc,
            validation_cost: *vc,
            gain: (current - vc) / current,
            score: score(criteria, current, *vc, h.free_params(p)),
            accepted: false,
            at_bound: at_bound(h, p, size),
        })
        .collect()
}

/// The kept effects with `new` added, refitted together when there are several; or, when the
/// refit pushes a kept effect onto a search bound (no longer a finding), its parameters there.
fn keep(
    plant: &Plant,
    data: &Data,
    selected: &Selection,
    new: (&'static Hypothesis, Vec<f64>),
) -> Result<Selection, Vec<String>> {
    let mut kept = selected.clone();
    kept.push(new);
    if kept.len() == 1 {
        return Ok(kept);
    }
    let kept = search::refine_all(plant, data, &kept, &[]);
    match kept
        .iter()
        .find(|(hb, pb)| !at_bound(hb, pb, data.size).is_empty())
    {
        Some((hb, pb)) => Err(at_bound(hb, pb, data.size)
            .into_iter()
            .map(|n| format!("{}.{n} (refitted with the others)", hb.name))
            .collect()),
        None => Ok(kept),
    }
}

/// Each (kept effect i, candidate h) of `options`: h fitted with the kept effects but i, kept
/// when corroborated on the training runs and off its bounds, with its held-out cost.
fn fit_replacements(
    plant: &Plant,
    data: &Data,
    criteria: &Criteria,
    selected: &Selection,
    options: &[(usize, &'static Hypothesis)],
    current_train: f64,
) -> Vec<(usize, &'static Hypothesis, Vec<f64>, f64)> {
    options
        .par_iter()
        .filter_map(|&(i, h)| {
            let mut rest = selected.clone();
            rest.remove(i);
            let (p, train) = search::fit_one(plant, data, &rest, h);
            rest.push((h, p.clone()));
            (corroborated(criteria, current_train, train) && at_bound(h, &p, data.size).is_empty())
                .then(|| (i, h, p, data.cost(plant, &augmentation(&rest), true)))
        })
        .collect()
}

/// A greedy pick can be wrong when two missing effects only make sense together (a current
/// and coupled drag: neither alone fits, and a third effect stands in for one of them). After
/// each round, every earlier kept effect is tried replaced by every untried one, refitted with
/// the rest; the best replacement is made when it lowers the held-out cost by the same margin
/// a new effect must reach. Returns the name swapped out and the row of the one swapped in.
fn swap(
    plant: &Plant,
    data: &Data,
    criteria: &Criteria,
    selected: &mut Selection,
    (current, current_train): (f64, f64),
    round: usize,
    progress: &(dyn Fn(&str) + Sync),
) -> Option<(String, Tested)> {
    let options: Vec<(usize, &'static Hypothesis)> = (0..selected.len() - 1)
        .flat_map(|i| untried(data, selected).map(move |h| (i, h)))
        .collect();
    progress(&format!(
        "round {round}: trying {} replacements of earlier effects",
        options.len()
    ));
    let fitted = fit_replacements(plant, data, criteria, selected, &options, current_train);
    // Parameters beyond those of the effect replaced.
    let extra = |i: usize, h: &Hypothesis, p: &[f64]| {
        (h.free_params(p) - selected[i].0.free_params(&selected[i].1)).max(0.0)
    };
    let (i, h, p, val) = fitted.into_iter().max_by(|a, b| {
        score(criteria, current, a.3, extra(a.0, a.1, &a.2)).total_cmp(&score(
            criteria,
            current,
            b.3,
            extra(b.0, b.1, &b.2),
        ))
    })?;
    if !significant(criteria, data, current, val, extra(i, h, &p)) {
        return None;
    }
    let mut next = selected.clone();
    let (out, _) = next.remove(i);
    next.push((h, p));
    let next = search::refine_all(plant, data, &next, &[]);
    let after = data.cost(plant, &augmentation(&next), true);
    if after >= current
        || next
            .iter()
            .any(|(hb, pb)| !at_bound(hb, pb, data.size).is_empty())
    {
        return None;
    }
    progress(&format!("round {round}: {} replaces {}", h.name, out.name));
    let (_, p) = next.last().expect("pushed above");
    let row = Tested {
        round,
        name: h.name.into(),
        parameters: params_map(h, p),
        train_cost: data.cost(plant, &augmentation(&next), false),
        validation_cost: after,
        gain: (current - after) / current,
        score: score(criteria, current, after, h.free_params(p)),
        accepted: true,
        at_bound: Vec::new(),
    };
    *selected = next;
    Some((out.name.to_string(), row))
}

/// The candidates of the round in which `name` was kept that the runs cannot tell from it,
/// while being significant themselves and off their bounds. Two effects are told apart when
/// one fits the held-out runs better by more than `min_noise_multiple` times the noise floor
/// (the margin by which any effect must beat the model to be named) and either the training
/// runs agree on which or the held-out gap is itself as large as an effect must gain to be
/// named (`min_gain` of the larger cost); otherwise they are look-alikes. The training runs'
/// say follows the selection's own rule that a real effect explains them too: on the field
/// example the two lag forms were 0.54 floors (7 %) apart on the held-out runs, the thruster
/// lag ahead, while the training runs put the sensor delay ahead (and the twin lags the
/// sensor).
pub fn alike(
    search: &Search,
    criteria: &Criteria,
    data: &Data,
    name: &str,
) -> Vec<super::result::Alike> {
    let Some(kept) = search.tested.iter().find(|t| t.accepted && t.name == name) else {
        return Vec::new();
    };
    let Some(&before) = search.costs.get(kept.round - 1) else {
        return Vec::new();
    };
    let apart = |t: &Tested| {
        let (them, it) = (t.validation_cost, kept.validation_cost);
        told_apart(criteria, data, (them, it), (t.train_cost, kept.train_cost))
    };
    search
        .tested
        .iter()
        .filter(|t| t.round == kept.round && !t.accepted && t.at_bound.is_empty())
        .filter(|t| !apart(t))
        .filter(|t| {
            let params = t.parameters.len() as f64;
            significant(criteria, data, before, t.validation_cost, params)
        })
        .map(|t| super::result::Alike {
            name: t.name.clone(),
            parameters: t.parameters.clone(),
            validation_cost: t.validation_cost,
        })
        .collect()
}

/// Whether two effects of held-out costs `(a, b)` and training costs `(ta, tb)` are told
/// apart ([`alike`]'s rule).
pub(super) fn told_apart(
    criteria: &Criteria,
    data: &Data,
    (a, b): (f64, f64),
    (ta, tb): (f64, f64),
) -> bool {
    let margin = criteria.min_noise_multiple * data.noise_cost;
    let (held_out, train) = (a - b, ta - tb);
    let decisive = held_out.abs() >= criteria.min_gain * a.max(b);
    held_out.abs() >= margin && (held_out * train > 0.0 || decisive)
}
