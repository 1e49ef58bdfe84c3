//! A model whose roll or pitch feels a translational velocity's drag (K_v, a roll moment from
//! the sway velocity; M_u, a pitch moment from the surge velocity) is fitted in two stages.
//!
//! An open frame's centre of lateral resistance is rarely level with its centre of gravity:
//! at a height `z_c` below it the sway drag rolls the vehicle, K_v = -z_c Y_v, and likewise
//! the surge drag pitches it, M_u = z_c X_u. On a piloted vehicle that no one commands in
//! roll or pitch, these are most of what moves the attitude. Fitted jointly with the rest,
//! though, the coupling lets the roll and pitch errors pull the sway and surge coefficients:
//! each run and DOF counts by its relative error, and the small attitude rates weigh as much
//! as the large translations. On the BlueROV2 Heavy's tank runs (scripts/smarc) K_v and M_u
//! fitted jointly took held-out roll NMAE from 1.00 to 0.77 and pitch from 0.99 to 0.90, and
//! sway from 0.30 to 0.65 and surge from 0.21 to 0.43.
//!
//! So the model is first fitted with the couplings held at zero (the translations fitted as
//! without them), then roll's and pitch's own coefficients and the couplings are refitted
//! with every other coefficient held: a cascade, as an engineer fits the attitude's response
//! to a translation already fitted ([`super::refine::output_error_lm_within`]). Held out, on
//! those runs with both couplings kept: roll 0.88 and sway 0.30 (1.00 and 0.30 without the
//! couplings).
//!
//! The price is paid where the model is right. On a twin whose truth has K_v = 1 and a net
//! buoyancy that the roll tilts into sway, the joint fit finds Y_v exactly (-6.23 for -6.22)
//! and the cascade keeps the sway drag of the model without K_v (-7.88), whose roll, and so
//! whose tilted buoyancy, is wrong. A real log is never the model, and a coupling that can
//! only move roll and pitch cannot make the translations worse: the test
//! `pem::tests::a_roll_moment_from_sway_is_found_after_the_sway_drag` holds it to that.

use crate::core::dof::Dof;
use crate::core::model::Term;

/// Whether `t` is a coupling into roll or pitch from a translation: a translational
/// velocity's drag (K_v, M_u), or the height z_g of the centre of gravity from the thrusters'
/// origin, on which the surge and sway thrust's roll and pitch moments hang.
pub(super) fn is_attitude_coupling(t: Term) -> bool {
    matches!(t, Term::Linear(i, j) if (3..5).contains(&i) && j < 3) || t == Term::Lever(2)
}

/// Whether `t` acts in roll or pitch alone (their added inertia, drag, constant and
/// couplings, and the restoring moment eta_z that rights both).
pub(super) fn in_attitude_rows(t: Term) -> bool {
    (t.equations().iter()).all(|d| matches!(d, Dof::Roll | Dof::Pitch))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_couplings_are_the_translations_drag_in_roll_and_pitch() {
        assert!(is_attitude_coupling(Term::Linear(3, 1)), "K_v");
        assert!(is_attitude_coupling(Term::Linear(4, 0)), "M_u");
        assert!(!is_attitude_coupling(Term::Linear(5, 1)), "N_v acts in yaw");
        assert!(is_attitude_coupling(Term::Lever(2)), "z_g");
        assert!(!is_attitude_coupling(Term::Lever(0)), "x_g acts in yaw too");
        assert!(
            !is_attitude_coupling(Term::Linear(3, 3)),
            "K_p is roll's own"
        );
        assert!(
            in_attitude_rows(Term::Moment(2)),
            "eta_z rights roll and pitch"
        );
        assert!(!in_attitude_rows(Term::Moment(0)), "eta_x acts in yaw too");
        assert!(in_attitude_rows(Term::Linear(3, 1)));
        assert!(!in_attitude_rows(Term::Linear(1, 1)));
    }
}
