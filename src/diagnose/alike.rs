//! Look-alikes: the effects the runs cannot tell from a named one, from the greedy rounds
//! ([`select::alike`]) and, once discovery has found terms, fitted in its place beside them.

use super::discover::Discovered;
use super::result::{Alike, Found, PossiblyBeside};
use super::{Criteria, Data, Search, Selection, augmentation_beside, search, select, testable};
use crate::core::model::Plant;
use std::sync::Arc;

/// The held-out cost of the named effects and discovered terms, and each named effect's
/// look-alikes beside the terms (by the effect's name).
pub(super) type Beside = (f64, Vec<(String, Alike)>);

/// The effects of the table the runs cannot tell from a named effect kept beside discovered
/// `terms`, by name of the effect, and the held-out cost of the named effects and terms: each
/// effect not named is fitted in its place, beside the other named effects and the terms, and
/// is its look-alike when [`select::told_apart`] does not tell them apart and it earns, in its
/// place, the margin any named effect needs. The greedy rounds' look-alikes were
/// judged before the terms were found: on a navigation-log twin with a tether's drag and a
/// thruster mounted askew, `coupled_drag` was named beside `N += 0.030 X` alone, the
/// tether's drag fitting as well in its place.
pub(super) fn alike_beside(
    plant: &Plant,
    data: &Data,
    crit: &Criteria,
    selected: &Selection,
    terms: &[Arc<Discovered>],
) -> Beside {
    let mut found = Vec::new();
    if terms.is_empty() {
        return (f64::NAN, found);
    }
    let now = augmentation_beside(selected, terms);
    let (current, current_train) = (data.cost(plant, &now, true), data.cost(plant, &now, false));
    for (i, (k, _)) in selected.iter().enumerate() {
        let mut rest = selected.clone();
        rest.remove(i);
        let before = data.cost(plant, &augmentation_beside(&rest, terms), true);
        let others = (data.effects.iter().copied()).filter(|h| {
            !selected.iter().any(|(s, _)| s.name == h.name) && testable::applicable(h, data)
        });
        for h in others {
            let (p, train) = search::fit_beside(plant, data, (&rest, terms), h);
            if !select::at_bound(h, &p, data.size).is_empty() {
                continue;
            }
            let mut with = rest.clone();
            with.push((h, p.clone()));
            let cost = data.cost(plant, &augmentation_beside(&with, terms), true);
            let apart = select::told_apart(crit, data, (cost, current), (train, current_train));
            if apart || !select::significant(crit, data, before, cost, h.free_params(&p)) {
                continue;
            }
            let alike = Alike {
                name: h.name.to_string(),
                parameters: select::params_map(h, &p),
                validation_cost: cost,
            };
            found.push((k.name.to_string(), alike));
        }
    }
    (current, found)
}

/// Each effect's look-alikes: the candidates its round could not tell from it and those
/// `beside` the discovered terms (by effect, [`alike_beside`]), except those named themselves
/// (an effect kept in a later round is beside it, not instead of it), each kind said.
pub(super) fn list_alike(
    effects: &mut [Found],
    (search, (current, beside)): (&Search, Beside),
    crit: &Criteria,
    data: &Data,
) {
    let named: Vec<String> = effects.iter().map(|e| e.name.clone()).collect();
    for e in effects {
        e.alike = select::alike(search, crit, data, &e.name);
        e.alike.retain(|a| !named.contains(&a.name));
        if !e.alike.is_empty() {
            let sentence = e.alike_sentence(data.noise_cost);
            e.evidence.push_str(&sentence);
        }
        let more: Vec<&Alike> = (beside.iter())
            .filter(|(k, a)| *k == e.name && !named.contains(&a.name))
            .map(|(_, a)| a)
            .filter(|a| !e.alike.iter().any(|x| x.name == a.name))
            .collect();
        if more.is_empty() {
            continue;
        }
        let said: Vec<String> = (more.iter())
            .map(|a| format!("{} (held-out cost {:.4})", a.name, a.validation_cost))
            .collect();
        e.evidence.push_str(&format!(
            " Beside the discovered terms, {} fits in its place as well as it does ({current:.4}; noise floor {:.4}): these runs cannot tell them apart.",
            said.join(" and "),
            data.noise_cost
        ));
        e.alike.extend(more.into_iter().cloned());
    }
}

/// The effects possibly beside a named one ([`select::Possible`]), listed with the effect
/// they shared their mismatch with, each with its figures. Listed only while what they were
/// fitted beside stands: every effect of that fit still named and it not named itself; none
/// once discovery has found `terms` (a closed form may hold what they fitted). After drift no
/// effect is named, so none is listed.
pub(super) fn list_possible(
    effects: &mut [Found],
    (search, terms): (&Search, &[Arc<Discovered>]),
    crit: &Criteria,
    data: &Data,
) {
    if !terms.is_empty() {
        return;
    }
    let named: Vec<String> = effects.iter().map(|e| e.name.clone()).collect();
    let margin = crit.min_noise_multiple * data.noise_cost;
    for p in &search.possible {
        let stands = p.beside.len() == named.len()
            && p.beside.iter().all(|b| named.iter().any(|n| n == b))
            && !named.iter().any(|n| n == p.name);
        let Some(last) = p.beside.last().filter(|_| stands) else {
            continue;
        };
        let Some(e) = effects.iter_mut().find(|e| e.name == *last) else {
            continue;
        };
        e.possibly_beside.push(PossiblyBeside {
            name: p.name.to_string(),
            parameters: p.parameters.clone(),
            beside_parameters: p.joint.clone(),
            validation_cost_without: p.without,
            validation_cost_with: p.with,
        });
    }
    for e in effects {
        if !e.possibly_beside.is_empty() {
            let sentence = e.possibly_beside_sentence(margin);
            e.evidence.push_str(&sentence);
        }
    }
}
