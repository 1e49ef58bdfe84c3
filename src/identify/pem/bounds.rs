//! The range each coefficient of a prediction-error fit may take: what is physically
//! plausible for an open-frame vehicle, said as bounds on the refinement.

use super::super::refine::Bounds;
use crate::core::dof::Dof;
use crate::core::model::params::Group;
use crate::core::model::terms::Term;

/// The range of every coefficient: its physical sign, the added mass of each DOF at most
/// `prior` times its rigid-body term, the diagonal drag no stiffer than a time constant of
/// [`FASTEST_S`] (at [`SPEED_REF`] for the quadratic term) with the largest plausible mass,
/// and a restoring moment (eta) no stiffer than a natural frequency of 1 / [`FASTEST_S`] in
/// the lightest of the rotations it rights, with that rotation's largest plausible inertia.
pub fn plausible(
    layout: &crate::core::model::ParamLayout,
    rigid_mass: &[f64; 6],
    prior: &[f64; 6],
) -> Bounds {
    let mut b = Bounds::signs(layout);
    let heaviest = |i: usize| (1.0 + prior[i]) * rigid_mass[i];
    for (j, t) in layout.terms.iter().enumerate() {
        let i = t.dof().index();
        match (t, t.group()) {
            (_, Group::AddedMass) if t.is_diagonal() => b.lo[j] = -prior[i] * rigid_mass[i],
            (_, Group::LinearDrag) if t.is_diagonal() => b.lo[j] = -heaviest(i) / FASTEST_S,
            (_, Group::QuadraticDrag) if t.is_diagonal() => {
                b.lo[j] = -heaviest(i) / (FASTEST_S * SPEED_REF)
            }
            (Term::Moment(_), _) => {
                let stiffest = rights(*t, layout)
                    .iter()
                    .map(|d| heaviest(d.index()) / (FASTEST_S * FASTEST_S))
                    .fold(f64::INFINITY, f64::min);
                if stiffest.is_finite() && stiffest > 0.0 {
                    (b.lo[j], b.hi[j]) = (-stiffest, stiffest);
                }
            }
            (Term::Lever(_), _) => {
                let r = crate::core::model::terms::LEVER_BOUND_M;
                (b.lo[j], b.hi[j]) = (-r, r);
            }
            _ => {}
        }
    }
    b
}

/// The rotations of `layout` that restoring moment `t` rights (eta_z: roll and pitch).
pub(super) fn rights(t: Term, layout: &crate::core::model::ParamLayout) -> Vec<Dof> {
    let mut dofs = t.equations();
    dofs.retain(|d| layout.dofs.contains(d));
    dofs
}

/// The fastest a vehicle's velocity may settle under its drag alone, s: a drag fitted stiffer
/// stands in for something the model lacks (a constant force it cannot otherwise explain
/// makes the output error prefer a velocity pinned at zero), and stiffer than the simulator's
/// step it would not even integrate.
pub const FASTEST_S: f64 = 0.1;

/// The speed at which a quadratic drag's time constant is taken, m/s or rad/s.
const SPEED_REF: f64 = 2.0;

/// What a component of r_g says: where the centre of gravity is from the point the logged
/// moments are taken about, and what that means for the thrusters' lever arms.
pub(super) fn lever_in_words(a: usize, value: f64) -> String {
    let side = match (a, value >= 0.0) {
        (0, true) => "ahead of",
        (0, false) => "behind",
        (1, true) => "to starboard of",
        (1, false) => "to port of",
        (_, true) => "below",
        (_, false) => "above",
    };
    format!(
        "the centre of gravity {:.1} cm {side} the point the logged moments are taken about (the thrusters' layout origin): each thrust's lever arm about it is its position there less r_g",
        100.0 * value.abs()
    )
}

/// How far a freed added mass may go, in multiples of the rigid-body term: the population
/// methods' search bound.
pub(super) const BEYOND_PRIOR: f64 = 5.0;

/// Whether parameter `j` is a diagonal added mass (the terms with a plausibility prior).
pub(super) fn is_added_mass(problem: &crate::identify::Regression, j: usize) -> bool {
    let t = problem.layout.terms[j];
    t.group() == Group::AddedMass && t.is_diagonal()
}

/// The DOF (index) of parameter `j`'s equation.
pub(super) fn dof_of(problem: &crate::identify::Regression, j: usize) -> usize {
    problem.layout.terms[j].dof().index()
}
