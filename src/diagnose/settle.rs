//! Named effects settled beside a discovered closed form. The greedy rounds chose the named
//! effects before discovery was considered; beside the discovered terms each must still earn
//! its margin ([`joint_selection`]), an effect whose form the terms carry is taken back
//! (`readmit`), and the effects kept are refitted beside the terms ([`refit_beside`]).

use std::sync::Arc;

use super::discover::Discovered;
use super::result::{Candidate, Figure};
use super::{self as dx, Chosen, Criteria, Data};
use crate::core::dof::Dof;
use crate::core::model::Plant;

/// Named effects settled beside a discovered candidate, with the sentences of the effects
/// dropped and of those taken back or moved.
pub(super) type Settled = Chosen<(Vec<String>, Vec<String>)>;

/// The named effects `selected` (found by the search that `tested` them) settled beside the
/// discovered term `c`: dropped where it explains them ([`joint_selection`]), taken back where
/// it carries their form (`readmit`), refitted beside it ([`refit_beside`]); with the sentences
/// of the effects dropped, and of those taken back or moved.
pub(super) fn settle(
    plant: &Plant,
    data: &Data,
    crit: &Criteria,
    (selected, tested): (dx::Selection, &[dx::Tested]),
    dofs: &[Dof],
    (c, figs): (Candidate, Vec<Figure>),
) -> anyhow::Result<Settled> {
    let before: Vec<&str> = selected.iter().map(|(h, _)| h.name).collect();
    let (kept, c, figs, why) = joint_selection(plant, data, crit, selected, dofs, c, figs)?;
    let (kept, c, figs, back) =
        super::readmit::readmit(plant, data, crit, (kept, tested), dofs, (c, figs))?;
    // An effect just dropped beside the terms is not unmasked by them.
    let gone: Vec<&str> = (before.into_iter())
        .filter(|n| !kept.iter().any(|(k, _)| k.name == *n))
        .collect();
    let (kept, c, figs, taken) =
        super::readmit::unmasked(plant, data, crit, (kept, tested, &gone), dofs, (c, figs))?;
    // An effect taken beside the terms may explain one named before it.
    let (kept, c, figs, why) = if taken.is_empty() {
        (kept, c, figs, why)
    } else {
        let (kept, c, figs, more) = joint_selection(plant, data, crit, kept, dofs, c, figs)?;
        (kept, c, figs, why.into_iter().chain(more).collect())
    };
    let (kept, c, figs, note) = refit_beside(plant, data, crit, kept, dofs, c, figs)?;
    let notes = back.into_iter().chain(taken).chain(note).collect();
    Ok((kept, c, figs, (why, notes)))
}

/// The named effects `selected` refitted beside the discovered terms of `c`, and the terms
/// discovered again beside them. Fitted before discovery, a named effect takes up some of
/// what the terms explain: on a twin with a tether's drag and a thrust fading 10 % a minute,
/// the tether's drag came out 1.5 times the twin's with no slack, and the fade found beside
/// it was 20 % short. Kept where the held-out runs prove it better; says whether it was.
fn refit_beside(
    plant: &Plant,
    data: &Data,
    crit: &Criteria,
    selected: dx::Selection,
    dofs: &[Dof],
    c: Candidate,
    figs: Vec<Figure>,
) -> anyhow::Result<Chosen<Option<String>>> {
    if selected.is_empty() || c.model.is_empty() {
        return Ok((selected, c, figs, None));
    }
    // Refitted beside the terms with the kept effects' own forms taken out: a closed form that
    // took part of a named effect's figure gives it back. On a heavy twin with a forward lift
    // and 30 N of net buoyancy, the buoyancy was named at 22 N and the terms carried the rest as
    // a heave constant (`Z += 61.1 u^2 - 8.13`); refitted beside `Z += 61.2 u^2` it is 30.2 N.
    let others: Vec<Arc<Discovered>> = (c.model.iter())
        .filter_map(|t| {
            (selected.iter())
                .try_fold((**t).clone(), |t, (h, _)| {
                    t.without_form(h.name, &data.slots)
                })
                .map(Arc::new)
        })
        .collect();
    let refit = super::search::refine_all(plant, data, &selected, &others);
    // A refit that takes an effect to a search bound wants more than the effect can give.
    if refit
        .iter()
        .any(|(h, p)| !dx::select::at_bound(h, p, data.size).is_empty())
    {
        return Ok((selected, c, figs, None));
    }
    let aug = dx::augmentation(&refit);
    let Some((c2, figs2)) = super::discover::discover(plant, data, &aug, dofs, crit)? else {
        return Ok((selected, c, figs, None));
    };
    // No worse after the per-parameter penalty the search charges: the same fit with fewer
    // terms is taken.
    let (before, after) = (c.cost_after_all(), c2.cost_after_all());
    let penalty = crit.gain_per_parameter * before;
    if after + penalty * c2.params() >= before + penalty * c.params() {
        return Ok((selected, c, figs, None));
    }
    let moved: Vec<String> = selected
        .iter()
        .zip(&refit)
        .map(|((h, old), (_, new))| {
            let each = h.params.iter().zip(old.iter().zip(new));
            let each: Vec<String> = each
                .map(|(q, (a, b))| format!("{} {a:.3} -> {b:.3}", q.name))
                .collect();
            format!("{} {}", h.name, each.join(", "))
        })
        .collect();
    let note = format!(
        "Refitted beside the discovered terms ({}), the named effects moved ({}) and the held-out error cost fell from {before:.4} to {after:.4}",
        c2.expressions(),
        moved.join("; ")
    );
    Ok((refit, c2, figs2, Some(note)))
}

/// Joint selection of the named effects and the discovered term `c`: a named effect chosen
/// before discovery was considered stays only if, beside the terms (the better of those
/// discovered again without it and `c`'s own kept as they are), it still lowers the held-out
/// cost by the margin an effect needs. Returns the effects
/// kept, the term and its figures, and a sentence per effect dropped.
fn joint_selection(
    plant: &Plant,
    data: &Data,
    crit: &Criteria,
    mut selected: dx::Selection,
    dofs: &[Dof],
    mut c: Candidate,
    mut figs: Vec<Figure>,
) -> anyhow::Result<Chosen<Vec<String>>> {
    let mut dropped = Vec::new();
    for i in (0..selected.len()).rev() {
        let mut reduced = selected.clone();
        let (h, p) = reduced.remove(i);
        let aug = dx::augmentation(&reduced);
        let again = super::discover::discover(plant, data, &aug, dofs, crit)?;
        // Discovery without the effect finds the effect again (a constant heave force for
        // net buoyancy): the effect is confirmed, not explained away.
        if (again.iter()).any(|(c2, _)| {
            c2.parts()
                .any(|p| p.named_terms.iter().any(|n| n == h.name))
        }) {
            continue;
        }
        // The terms found beside the effect, without it, compete with the terms found again
        // without it: searched again, discovery can take another road (a surge `|u| u` where
        // a cross flow's terms, kept as they were, left `coupled_drag` nothing to do).
        let kept = super::discover::beside(plant, data, &aug, &c).map(|k| (k, figs.clone()));
        let Some((c2, figs2)) = [again, kept]
            .into_iter()
            .flatten()
            .min_by(|a, b| a.0.cost_after_all().total_cmp(&b.0.cost_after_all()))
        else {
            continue;
        };
        let (with, without) = (c.cost_after_all(), c2.cost_after_all());
        let gain = (without - with) / without.max(1e-300);
        let needed = crit.min_gain + crit.gain_per_parameter * h.free_params(&p);
        let floor = crit.min_noise_multiple * data.noise_cost;
        if gain < needed || without - with < floor {
            let change = if with > without {
                format!("raises the held-out error cost from {without:.4} to {with:.4}")
            } else if gain < needed {
                format!(
                    "lowers the held-out error cost only from {without:.4} to {with:.4} ({:.1} %, where {:.0} % is needed)",
                    100.0 * gain,
                    100.0 * needed
                )
            } else {
                // The share is enough but the drop is within what noise moves the cost by.
                format!(
                    "lowers the held-out error cost only from {without:.4} to {with:.4}, by {:.4}, where {floor:.4} ({} times the noise floor) is needed",
                    without - with,
                    crit.min_noise_multiple
                )
            };
            dropped.push(format!(
                "The named effect {} was dropped: beside the discovered terms ({}) it {change}",
                h.name,
                c2.expressions()
            ));
            selected = reduced;
            c = c2;
            figs = figs2;
        }
    }
    Ok((selected, c, figs, dropped))
}
