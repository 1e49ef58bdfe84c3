//! A rival fitted together with the kept effects: when an effect that explained as much as
//! the kept one alone loses its share on top of it, the two may share one mismatch, so each
//! kept effect is refitted beside it and all refined together; what that joint fit gains
//! decides whether the rival is taken, listed as possibly beside them, or dropped.

use super::rules::{Criteria, Tested, at_bound, corroborated, params_map, significant};
use crate::core::model::Plant;
use crate::diagnose::{Data, Hypothesis, Selection, augmentation, search};
use rayon::prelude::*;
use std::collections::BTreeMap;

/// An effect possibly present beside the kept ones: fitted together with them it fits the
/// held-out runs better by the share a named effect must gain, but by less than the noise
/// margin, so it is listed, never named.
#[derive(Debug, Clone)]
pub struct Possible {
    /// The kept effects it was fitted with; it shared its mismatch with the last of them.
    pub beside: Vec<&'static str>,
    pub name: &'static str,
    pub parameters: BTreeMap<String, f64>,
    /// The kept effects' parameters in the joint fit, by name.
    pub joint: BTreeMap<String, BTreeMap<String, f64>>,
    /// Held-out cost of the kept effects refined without it, from where the joint fit left
    /// them ...
    pub without: f64,
    /// ... and of the joint fit.
    pub with: f64,
}

/// A candidate fitted on top of the kept effects: the effect, its parameters, its training
/// cost, its held-out cost, the kept effects as they were fitted with it, and, when its
/// joint fit with them was too small a gain to take, what that fit found ([`Possible`]).
pub(super) type Fitted = (
    &'static Hypothesis,
    Vec<f64>,
    f64,
    f64,
    Selection,
    Option<Possible>,
);

/// An effect that explained as much as the kept one alone ([`strong_rivals`]): its parameters
/// then, and the share of the training cost it removed.
pub(super) type Rival = (&'static Hypothesis, Vec<f64>, f64);

/// Each candidate fitted on top of the kept effects (`selected`, at training cost
/// `current_train`), in parallel. A candidate among `rivals` that, fitted so, removes under
/// half the share of the training cost it removed alone has lost its part of the mismatch to
/// the kept effects: it is also fitted together with them ([`jointly`]), and that fit is taken
/// when it is the better on the training runs and the rival carries its share in it; when the
/// share it carries is only under the noise margin, it is [`possibly_beside`] them.
pub(super) fn fit_candidates(
    plant: &Plant,
    data: &Data,
    criteria: &Criteria,
    (selected, current_train): (&Selection, f64),
    candidates: &[&'static Hypothesis],
    rivals: &[Rival],
) -> Vec<Fitted> {
    candidates
        .par_iter()
        .map(|h| {
            let (p, train_cost) = search::fit_one(plant, data, selected, h);
            let mut best = (p, train_cost, selected.clone());
            let mut possible = None;
            let lost = |alone: f64| 1.0 - train_cost / current_train < 0.5 * alone;
            let rival = rivals
                .iter()
                .find(|(r, _, alone)| r.name == h.name && lost(*alone));
            if let Some((_, earlier, _)) = rival {
                let mut joint = jointly(plant, data, selected, (h, earlier));
                let train = data.cost(plant, &augmentation(&joint), false);
                if train < best.1 {
                    let (without, with) = share(plant, data, &joint);
                    let params = h.free_params(&joint.last().expect("pushed").1);
                    if significant(criteria, data, without, with, params) {
                        let (_, q) = joint.pop().expect("pushed above");
                        best = (q, train, joint);
                    } else if corroborated(criteria, current_train, train)
                        && possibly_beside(criteria, (without, with), params)
                        && joint
                            .iter()
                            .all(|(k, q)| at_bound(k, q, data.size).is_empty())
                    {
                        let ((_, q), kept) = joint.split_last().expect("pushed above");
                        possible = Some(Possible {
                            beside: selected.iter().map(|(k, _)| k.name).collect(),
                            name: h.name,
                            parameters: params_map(h, q),
                            joint: (kept.iter())
                                .map(|(k, p)| (k.name.to_string(), params_map(k, p)))
                                .collect(),
                            without,
                            with,
                        });
                    }
                }
            }
            let (p, train_cost, with) = best;
            let mut sel = with.clone();
            sel.push((*h, p.clone()));
            let val = data.cost(plant, &augmentation(&sel), true);
            (*h, p, train_cost, val, with, possible)
        })
        .collect()
}

/// The kept effects and rival `h` fitted together: each kept effect refitted (grid, then
/// Nelder-Mead) with `h` at its earlier parameters, then all refined together.
fn jointly(
    plant: &Plant,
    data: &Data,
    selected: &Selection,
    (h, earlier): (&'static Hypothesis, &[f64]),
) -> Selection {
    let mut start = selected.clone();
    start.push((h, earlier.to_vec()));
    for i in 0..selected.len() {
        let mut rest = start.clone();
        let (kept, _) = rest.remove(i);
        start[i].1 = search::fit_one(plant, data, &rest, kept).0;
    }
    search::refine_all(plant, data, &start, &[])
}

/// The held-out costs that say whether the last effect of `joint` earns its place: without
/// it (the others refined from where the joint fit left them), and with it. It carries its
/// share when the first exceeds the second by the margin a new effect must reach
/// ([`significant`]). What the kept effects gain by moving is theirs (a 15 N dead zone whose
/// first fit stopped 15 % high, refitted beside a reverse-thrust loss of 0.014).
fn share(plant: &Plant, data: &Data, joint: &Selection) -> (f64, f64) {
    let (_, others) = joint.split_last().expect("the rival is last");
    let alone = search::refine_all(plant, data, &others.to_vec(), &[]);
    let without = data.cost(plant, &augmentation(&alone), true);
    (without, data.cost(plant, &augmentation(joint), true))
}

/// Whether a rival whose joint fit did not carry its share ([`share`]) may still be there:
/// it lowers the held-out cost by the fraction an effect must gain to be named, less the
/// per-parameter penalty, and fails only the noise margin. A sensor delay of 0.35 s and a
/// thruster lag of 0.15 s concealed together on the reference vehicle's navigation log (seed
/// 312): the delay was named alone (0.458 s, filtered at 0.271 s); fitted together with it
/// the lag came out at 0.148 s and the delay at 0.342 s (filtered at 0.204 s), the held-out
/// cost 26 % lower, yet 0.0017 against the 0.0021 that half the noise floor asks. On the
/// regression sets no refused joint fit gained over 4 %.
fn possibly_beside(criteria: &Criteria, (without, with): (f64, f64), params: f64) -> bool {
    (without - with) / without - criteria.gain_per_parameter * params >= criteria.min_gain
}

/// The candidates of a round that would have been named alone beside the one kept (row `b`),
/// explaining at least half as much of the mismatch (by the score), with their parameters.
/// Two such effects may share one mismatch: a sensor delay and a thruster lag concealed
/// together were fitted as one delay of 0.81 s (for 0.3 s of each; the lag alone scored 0.70
/// of the delay), and with that delay held the lag gained nothing in the next round, though
/// together, each at its share, they explain the runs. So in the next round each is also
/// fitted together with the kept effects. The score is logarithmic: a kept effect that takes
/// the cost to 2 % of the start scores three times one that takes it to 30 %, though both
/// explain most of the mismatch (a 0.4 s sensor delay and a 0.2 s thruster lag concealed
/// together on a navigation log: the delay alone took 98 %, the lag alone 70 %, and held
/// beside the delay, whose filter had taken up the lag, it gained nothing), so an effect
/// that explains half as much of the mismatch counts too. An effect that alone explains a
/// small part of what the kept one does is not sharing its mismatch, and is only fitted on
/// top of it.
pub(super) fn strong_rivals(
    fitted: &[Fitted],
    rows: &[Tested],
    b: usize,
    criteria: &Criteria,
    data: &Data,
    (current, current_train): (f64, f64),
) -> Vec<Rival> {
    (0..rows.len())
        .filter(|&i| {
            let r = &rows[i];
            i != b
                && r.at_bound.is_empty()
                && (r.score >= 0.5 * rows[b].score || r.gain >= 0.5 * rows[b].gain)
                && corroborated(criteria, current_train, r.train_cost)
                && significant(
                    criteria,
                    data,
                    current,
                    r.validation_cost,
                    r.parameters.len() as f64,
                )
        })
        .map(|i| {
            let share = 1.0 - rows[i].train_cost / current_train;
            (fitted[i].0, fitted[i].1.clone(), share)
        })
        .collect()
}
