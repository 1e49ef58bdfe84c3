//! What a prediction-error fit says of each coefficient: a value on its prior, on its search
//! bound, or demanded beyond the prior by the runs.

use super::bounds::{self, BEYOND_PRIOR, FASTEST_S, dof_of, is_added_mass, rights};
use crate::core::model::terms::Term;
use crate::identify::refine::Bounds;
use crate::identify::{Options, Regression};

/// The note on parameter `j` at `value`, and whether it makes the value untrustworthy (a value
/// the runs demand beyond its prior is said, and flagged only where no added mass is that large).
pub(super) fn note(
    problem: &Regression,
    bounds: &Bounds,
    (j, value): (usize, f64),
    opts: &Options,
    beyond: Option<(f64, f64)>,
) -> (Option<String>, bool) {
    let term = problem.layout.terms[j];
    let i = dof_of(problem, j);
    let at_prior = bounds.at_prior(j, value);
    // Judged against the bounds it was freed in, an added mass on them is on the search bound.
    let at_search_bound = beyond.is_some() && at_prior;
    let name = problem.layout.name(j);
    let times = -value / opts.rigid_mass[i];
    match beyond {
        Some((held, freed)) if !at_search_bound => demanded(
            (&name, term),
            opts.added_mass_prior[i],
            opts.rigid_mass[i],
            (times, held, freed),
        ),
        _ if at_search_bound => (
            Some(format!(
                "{name} ran to {times:.0} times its rigid-body term: the runs push it without bound, so it stands in for something the model lacks (a lag, a filtered sensor, a command that delivers less force in this DOF than it asks: a thrust curve or allocation that is off there) or they cannot tell this inertia from the damping"
            )),
            true,
        ),
        _ if at_prior && matches!(term, Term::Moment(_)) => (
            Some(format!(
                "{name} sits on its stiffness bound (a natural frequency of {:.0} rad/s with the heaviest inertia the prior allows): a restoring moment this stiff pins the attitude, so it stands in for a moment the model lacks in {}: one that follows the motion (a coupling from another DOF, as a sway velocity's roll moment K_v or a surge velocity's pitch moment M_u in `custom_terms`), a constant moment (`constant_force`), or the runs' attitude does not follow their logged moments",
                1.0 / FASTEST_S,
                rights(term, &problem.layout)
                    .iter()
                    .map(|d| d.to_string())
                    .collect::<Vec<_>>()
                    .join(" and "),
            )),
            true,
        ),
        _ if at_prior && matches!(term, Term::Lever(_)) => (
            Some(format!(
                "{name} sits on its bound ({} m from the point the logged moments are taken about): the runs push the centre of gravity past any vehicle's, so it stands in for a moment the model lacks in {} or logged moments that are not the vehicle's",
                crate::core::model::terms::LEVER_BOUND_M,
                acts_in(term),
            )),
            true,
        ),
        _ if at_prior && !is_added_mass(problem, j) => (
            Some(format!(
                "{name} sits on its stiffness bound (a time constant of {FASTEST_S} s): the runs push the drag past any vehicle's, so it stands in for something the model lacks (a constant force in {}: `constant_force`, a lag) or the runs do not move in this DOF",
                term.dof()
            )),
            true,
        ),
        _ if at_prior => (
            Some(format!(
                "{name} sits on its plausibility bound ({} times the rigid-body term {:.3}): the runs cannot tell this inertia from the damping or a lag; runs with sharper changes of command in {} (steps, a PRBS) would",
                opts.added_mass_prior[i],
                opts.rigid_mass[i],
                term.dof()
            )),
            true,
        ),
        _ if value == 0.0 && term.physical_sign().is_some() => (
            Some(format!(
                "{name} held at 0: the output error pushes it past its physical sign; it stands in for something the model lacks or the runs do not excite it"
            )),
            true,
        ),
        _ => match term {
            Term::Lever(a) => (Some(bounds::lever_in_words(a, value)), false),
            _ => (None, false),
        },
    }
}

/// The note on an added mass the runs demand beyond its `prior` (times the rigid-body term
/// `rigid`): said, and flagged only past [`BEYOND_PRIOR`], where no vehicle's added mass is and
/// the value reads as the command's gain in its DOF.
fn demanded(
    (name, term): (&str, Term),
    prior: f64,
    rigid: f64,
    (times, held, freed): (f64, f64, f64),
) -> (Option<String>, bool) {
    let said = format!(
        "{name} is beyond its plausibility prior ({prior} times the rigid-body term {rigid:.3}): the runs demand it (output error {held:.4} held on the prior, {freed:.4} beyond it)"
    );
    if times <= BEYOND_PRIOR {
        return (Some(said), false);
    }
    // (m + a) dv = tau + f(v) is (m + a_prior) dv = g tau + g f(v): the same motion.
    let gain = (1.0 + prior) / (1.0 + times);
    (
        Some(format!(
            "{said}; no vehicle's added mass is {times:.1} times its rigid-body term: it stands in for a command that delivers about {:.0} % of what it asks in {} (the same motion with the added mass on its prior: a thrust curve, an allocation or a rigid-body term that is off there); the model predicts with it, but it is not a physical added mass",
            100.0 * gain,
            term.dof()
        )),
        true,
    )
}

/// The DOFs whose motion shows term `t`: its own, but for a component of the moment of weight
/// and buoyancy (eta), which turns the body about the other two axes as it tilts (eta_z rolls
/// and pitches the vehicle), and a component of r_g, which moves the two moments its logged
/// forces cross (z_g: roll and pitch).
pub(super) fn acts_in(t: Term) -> String {
    match t {
        Term::Moment(_) | Term::Lever(_) => {
            let axes: Vec<String> = t.equations().iter().map(|d| d.to_string()).collect();
            axes.join(" and ")
        }
        t => t.dof().to_string(),
    }
}
