//! Look-alikes: the effects the runs cannot tell from a named one, from the greedy rounds
//! ([`select::alike`]) and, once discovery has found terms, fitted in its place beside them.

use super::discover::Discovered;
use super::result::{Alike, Found};
use super::{Criteria, Data, Search, Selection, augmentation, search, select, testable};
use crate::core::model::Plant;
use std::sync::Arc;

/// The effects of the table the runs cannot tell from a named effect kept beside discovered
/// `terms`, by name of the effect and with the held-out cost of the named effects and terms: each effect not named is fitted in its place, beside the
/// other named effects and the terms, and is its look-alike by [`select::alike`]'s rule (not
/// apart on the held-out runs by the margin, or the training runs preferring it) when it
/// earns, in its place, the margin any named effect needs. The greedy rounds' look-alikes were
/// judged before the terms were found: on a navigation-log twin with a tether's drag and a
/// thruster mounted askew, `coupled_drag` was named beside `N += 0.030 X` alone, the
/// tether's drag fitting as well in its place.
pub(super) fn alike_beside(
    plant: &Plant,
    data: &Data,
    crit: &Criteria,
    selected: &Selection,
    terms: &[Arc<Discovered>],
) -> Vec<(String, Alike, f64)> {
    let with_terms = |sel: &Selection| {
        let mut aug = augmentation(sel);
        aug.discovered = terms.to_vec();
        aug
    };
    let mut found = Vec::new();
    if terms.is_empty() {
        return found;
    }
    let now = with_terms(selected);
    let (current, current_train) = (data.cost(plant, &now, true), data.cost(plant, &now, false));
    let margin = crit.min_noise_multiple * data.noise_cost;
    for (i, (k, _)) in selected.iter().enumerate() {
        let mut rest = selected.clone();
        rest.remove(i);
        let before = data.cost(plant, &with_terms(&rest), true);
        let others = (data.effects.iter().copied()).filter(|h| {
            !selected.iter().any(|(s, _)| s.name == h.name) && testable::applicable(h, data)
        });
        for h in others {
            let (p, train) = search::fit_beside(plant, data, (&rest, terms), h);
            if !select::at_bound(h, &p).is_empty() {
                continue;
            }
            let mut with = rest.clone();
            with.push((h, p.clone()));
            let cost = data.cost(plant, &with_terms(&with), true);
            let (held_out, train) = (cost - current, train - current_train);
            let decisive = held_out.abs() >= crit.min_gain * cost.max(current);
            let apart = held_out.abs() >= margin && (held_out * train > 0.0 || decisive);
            if apart || !select::significant(crit, data, before, cost, h.free_params(&p)) {
                continue;
            }
            let alike = Alike {
                name: h.name.to_string(),
                parameters: select::params_map(h, &p),
                validation_cost: cost,
            };
            found.push((k.name.to_string(), alike, current));
        }
    }
    found
}

/// Each effect's look-alikes: the candidates its round could not tell from it and those
/// `beside` the discovered terms (by effect, [`alike_beside`]), except those named themselves
/// (an effect kept in a later round is beside it, not instead of it), each kind said.
pub(super) fn list_alike(
    effects: &mut [Found],
    (search, beside): (&Search, Vec<(String, Alike, f64)>),
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
        let more: Vec<&(String, Alike, f64)> = (beside.iter())
            .filter(|(k, a, _)| *k == e.name && !named.contains(&a.name))
            .filter(|(_, a, _)| !e.alike.iter().any(|x| x.name == a.name))
            .collect();
        let Some((_, _, current)) = more.first() else {
            continue;
        };
        let said: Vec<String> = (more.iter())
            .map(|(_, a, _)| format!("{} (held-out cost {:.4})", a.name, a.validation_cost))
            .collect();
        e.evidence.push_str(&format!(
            " Beside the discovered terms, {} fits in its place as well as it does ({current:.4}; noise floor {:.4}): these runs cannot tell them apart.",
            said.join(" and "),
            data.noise_cost
        ));
        e.alike.extend(more.into_iter().map(|(_, a, _)| a.clone()));
    }
}
