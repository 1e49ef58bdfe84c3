//! The diagnosis's one-sentence verdict, from the costs it quotes and what it found.

use super::result::{Found, pct};
use super::unexplained::{Structured, describe};

/// The held-out error costs the verdict quotes.
pub(super) struct Costs {
    pub base: f64,
    pub after_effects: f64,
    pub reestimated: f64,
    pub noise: f64,
}

/// The one-sentence verdict.
///
/// `unexplained` holds the DOFs found structured when an `unexplained` entry is reported
/// (possibly none: the cost alone then decided it); the sentence quotes their figures, so a
/// pooled cost within the noise floor beside a structured DOF reads as what it is.
pub(super) fn verdict_sentence(
    effects: &[Found],
    unexplained: Option<&[Structured]>,
    drift: bool,
    c: &Costs,
    within_multiple: f64,
) -> String {
    let (base_cost, final_cost, re_cost) = (c.base, c.after_effects, c.reestimated);
    if let Some(left) = unexplained {
        // What decided it: the DOFs found structured, or else the pooled cost over the noise.
        let (residual, which) = match left.is_empty() {
            true => (
                "residual",
                format!(
                    " ({:.2} times the noise floor {:.4}, over the {within_multiple} times that counts as noise)",
                    final_cost / c.noise,
                    c.noise
                ),
            ),
            false => ("structured residual", format!(" (in {})", describe(left))),
        };
        if effects.len() == 1 {
            format!(
                "The model does not explain the held-out runs, re-estimating its parameters does not either, and no effect of the table does: the {residual} remains{which} and is reported as unexplained, with where it is."
            )
        } else {
            partly(effects, c, &format!("a {residual} remains{which}"))
        }
    } else if drift {
        format!(
            "No missing physics, but the parameters drifted: re-estimating the model's own parameters on the training runs explains the held-out runs better than any left-out effect (error cost {re_cost:.4}, noise floor {:.4}; the CFD model: {base_cost:.4}). Use the re-estimated parameters.",
            c.noise
        )
    } else if effects.is_empty() {
        format!(
            "No missing physics: the held-out error cost {base_cost:.4} is {:.1} times the noise floor {:.4}, within the {within_multiple} times that counts as noise, no DOF's residual is structured above its noise, and no effect improves it significantly.",
            base_cost / c.noise.max(1e-300),
            c.noise
        )
    } else {
        format!(
            "The model leaves out {}: adding {} lowers the held-out error cost from {base_cost:.4} to {final_cost:.4} ({} of the start; noise floor {:.4}); re-estimating its parameters instead {} {re_cost:.4} ({} of the start).",
            effects
                .iter()
                .map(Found::name_with_alike)
                .collect::<Vec<_>>()
                .join(" and "),
            if effects.len() > 1 { "them" } else { "it" },
            pct(final_cost / base_cost),
            c.noise,
            if re_cost > base_cost {
                "worsens it to"
            } else {
                "reaches"
            },
            pct(re_cost / base_cost)
        )
    }
}

/// The verdict when named effects are kept and a residual (`remains`, with its figures) is
/// left unexplained: what the effects alone do to the held-out cost, said as it is.
fn partly(effects: &[Found], c: &Costs, remains: &str) -> String {
    let (base_cost, final_cost) = (c.base, c.after_effects);
    let names = effects
        .iter()
        .filter(|e| e.name != "unexplained")
        .map(Found::name_with_alike)
        .collect::<Vec<_>>()
        .join(" and ");
    let plural = effects.len() > 2;
    let (ratio, floor) = (pct(final_cost / base_cost), final_cost / c.noise);
    if final_cost < base_cost {
        format!(
            "{names} {} part of the mismatch: the held-out error cost falls from {base_cost:.4} to {final_cost:.4} ({ratio} of the start, {floor:.1} times the noise floor); {remains} and is reported as unexplained.",
            if plural { "explain" } else { "explains" },
        )
    } else {
        // Kept beside the discovered terms, but alone no help: say so, not "explains".
        format!(
            "{names} {} named only beside the discovered terms: alone {} the held-out error cost from {base_cost:.4} to {final_cost:.4} ({ratio} of the start, {floor:.1} times the noise floor); {remains} and is reported as unexplained.",
            if plural { "are" } else { "is" },
            if plural { "they raise" } else { "it raises" },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::dof::Dof;
    use std::collections::BTreeMap;

    #[test]
    fn the_verdict_gives_costs_with_their_ratio_and_says_worse_when_it_is() {
        let found = |name: &str| Found {
            name: name.into(),
            dofs: vec![],
            parameters: BTreeMap::new(),
            evidence: String::new(),
            validation_nmae_before: BTreeMap::new(),
            validation_nmae_after: BTreeMap::new(),
            validation_cost_before: 0.0,
            validation_cost_after: 0.0,
            alike: Vec::new(),
            possibly_beside: Vec::new(),
            candidate: None,
        };
        let costs = Costs {
            base: 0.447,
            after_effects: 0.02,
            reestimated: 0.5203,
            noise: 0.005,
        };
        let v = verdict_sentence(&[found("thruster_lag")], None, false, &costs, 5.0);
        assert!(v.contains("from 0.4470 to 0.0200 (4 % of the start"), "{v}");
        assert!(
            v.contains("instead worsens it to 0.5203 (116 % of the start)"),
            "{v}"
        );
        let v = verdict_sentence(
            &[found("thruster_lag"), found("unexplained")],
            Some(&[]),
            false,
            &costs,
            5.0,
        );
        assert!(
            v.contains("(4 % of the start, 4.0 times the noise floor)"),
            "{v}"
        );
        // Effects kept only beside the discovered terms, which alone raise the cost, are not
        // said to explain anything.
        let raised = Costs {
            after_effects: 0.4783,
            ..costs
        };
        let v = verdict_sentence(
            &[
                found("coupled_drag"),
                found("tether_drag"),
                found("unexplained"),
            ],
            Some(&[]),
            false,
            &raised,
            5.0,
        );
        assert!(
            v.starts_with("coupled_drag and tether_drag are named only beside the discovered terms: alone they raise the held-out error cost from 0.4470 to 0.4783 (107 % of the start"),
            "{v}"
        );
        assert!(!v.contains(" explain"), "{v}");
        // A structured DOF beside a pooled cost within the noise floor: the figures that
        // decided it are quoted.
        let left = [
            Structured {
                dof: Dof::Yaw,
                multiple: 6.24,
                acf_outside: 0.45,
                line_hz: None,
            },
            Structured {
                dof: Dof::Heave,
                multiple: 2.5,
                acf_outside: 0.1,
                line_hz: Some(0.42),
            },
        ];
        let within = Costs {
            after_effects: 0.005,
            ..costs
        };
        let v = verdict_sentence(
            &[found("thruster_lag"), found("unexplained")],
            Some(&left),
            false,
            &within,
            5.0,
        );
        assert!(
            v.contains("1.0 times the noise floor); a structured residual remains (in yaw: 6.2 times its noise, autocorrelated (outside the 95 % band at 45 % of the lags up to 5 s); heave: 2.5 times its noise, with a line at 0.42 Hz that no command has) and is reported as unexplained."),
            "{v}"
        );
    }
}
