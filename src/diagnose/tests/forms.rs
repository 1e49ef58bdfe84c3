//! Discovery of physics whose form is a polynomial of the velocities or a pull in body axes,
//! none of it a named effect: an extra Munk moment (`N += c u v`, added mass, not drag), a
//! trimmed hull's lift (`Z += c u^2`, down whichever way the vehicle goes), a tether's weight
//! pulling the vehicle back to its anchor (a pool-frame spring, felt in body axes as the
//! heading turns), tunnel thrusters losing thrust in a cross flow, and a constant yaw
//! moment. The twin writes each apart (`crate::twin::world`). Before the signed product
//! stopped counting as `coupled_drag`, the squares and the anchor's offset were in the
//! library, seed 75 named `coupled_drag` beside the Munk moment, `net_buoyancy` for the lift
//! with no closed form (held-out cost 0.0807 -> 0.0366, 16 times the noise floor) and
//! `water_current` for the pull (0.486 -> 0.388, 170 times).

use super::discovery::named_beside;
use super::*;
use crate::core::dof::Dof;
use crate::diagnose::result::Candidate;

/// The closed form of diagnosis `d`, or a panic with its verdict.
fn closed_form(d: &Diagnosis, what: &str) -> Candidate {
    eprintln!("{what}: {}", d.verdict);
    (d.effects.iter())
        .find_map(|x| x.candidate.clone())
        .unwrap_or_else(|| panic!("{what}: no closed form\n{}", d.verdict))
}

/// The coefficient of `term` in `dof` of candidate `c`, asserted within `tol` of `truth`.
fn term_near(c: &Candidate, dof: Dof, term: &str, truth: f64, tol: f64) {
    let t = (c.parts().filter(|p| p.dof == dof))
        .flat_map(|p| p.terms.iter())
        .find(|t| t.term == term)
        .unwrap_or_else(|| panic!("no `{term}` in {dof}: {}", c.expression));
    assert!(
        (t.coefficient - truth).abs() < tol * truth.abs(),
        "{dof} {} {term}, twin {truth} ({})",
        t.coefficient,
        c.expression
    );
}

/// The held-out cost falls below twice the noise floor: the form is the whole mismatch.
fn explains(d: &Diagnosis, c: &Candidate, what: &str) {
    let floor = d.baseline.noise_cost;
    assert!(
        c.cost_after_all() < 2.0 * floor,
        "{what}: held-out cost {} -> {} (noise floor {floor})",
        c.validation_cost_before,
        c.cost_after_all()
    );
}

/// Scenario `effect` on seed 76 gives a closed form with `term` in `dof` within 10 % of
/// `truth`, no named effect beside it, and the held-out cost near the noise floor.
fn found_alone(effect: &str, dof: Dof, term: &str, truth: f64) {
    let d = scenario_diagnosis(&[Effect::from_arg(effect).unwrap()], 76);
    let c = closed_form(&d, effect);
    term_near(&c, dof, term, truth, 0.1);
    let claimed = named_beside(&d, false);
    assert!(
        claimed.is_empty(),
        "{effect}: a named effect claimed it: {claimed:?}"
    );
    explains(&d, &c, effect);
}

/// `N += 10 u v` hidden: found in yaw within 10 %, with no named effect beside it. The cross
/// flow in surge and sway it stirs (a yaw rate off the model's) is no drag of theirs.
#[test]
fn an_extra_munk_moment_is_found_not_named_coupled_drag() {
    found_alone("munk_moment=10", Dof::Yaw, "u v", 10.0);
}

/// `Z += 25 u^2` hidden: found in heave within 10 %, not named net buoyancy (its mean).
#[test]
fn a_lift_that_goes_with_the_speed_squared_is_found() {
    found_alone("forward_lift=25", Dof::Heave, "u^2", 25.0);
}

/// A constant yaw moment of 0.4 N m (a tether's twist, a thruster pair out of balance):
/// `N += c` within 10 %. On seed 76 a run at a steady depth chose `Depth` for it (within one
/// run the same column), two of the four runs did, the constant failed the runs' majority and
/// no closed form was proposed, 6.5 times the noise floor left.
#[test]
fn a_constant_yaw_moment_is_found_though_a_steady_depth_looks_the_same() {
    found_alone("yaw_bias=0.4", Dof::Yaw, "1", 0.4);
}

/// A pull of 1.5 N per metre toward the tether's anchor: found in surge and sway as
/// `-k (p - p_a)` in body axes, within 10 %, on the pool's sensors (UWB) and on a navigation
/// log (its position dead-reckoned from the DVL and the heading), never named a current.
#[test]
fn a_tether_pulling_toward_its_anchor_is_found_in_body_axes() {
    let e = Effect::from_arg("tether_spring=1.5").unwrap();
    let nav = scenario::fused_runs_seen(
        std::slice::from_ref(&e),
        76,
        crate::twin::pool::Logs::Navigation,
    )
    .unwrap();
    let runs = [
        (
            "pool sensors",
            false,
            scenario_diagnosis(std::slice::from_ref(&e), 76),
        ),
        (
            "navigation log",
            true,
            full(&nav, &scenario::cfd_fit_plant(1).unwrap()),
        ),
    ];
    for (what, is_nav, d) in runs {
        let c = closed_form(&d, what);
        term_near(&c, Dof::Surge, "(p - p_a)_x", -1.5, 0.1);
        term_near(&c, Dof::Sway, "(p - p_a)_y", -1.5, 0.1);
        let claimed = named_beside(&d, is_nav);
        assert!(claimed.is_empty(), "{what}: named {claimed:?}");
        explains(&d, &c, what);
    }
}

/// Tunnel thrusters losing thrust in a cross flow, F (1 - |u| / 2 m/s) on the sway force and
/// the yaw moment: found as `Y += c |u| Y` and `N += c |u| N` with c within 15 % of -0.5, no
/// named effect beside them. Before a command times a speed was in the library, seed 75
/// found only a lower gain (`Y += -0.139 Y`, `N += -0.249 N`, 30 times the noise floor left)
/// or, for 3 m/s, named `thruster_deadband`.
#[test]
fn thrust_lost_in_a_cross_flow_is_found_with_the_surge_speed() {
    let d = scenario_diagnosis(&[Effect::from_arg("crossflow_loss=2").unwrap()], 76);
    cross_flow_found(&d, false, "crossflow_loss=2", (2.0, 0.15));
}

/// The same loss on a navigation log, seed 93 (four training runs): every resample took
/// `|u| Y` and two of the four runs alone did, the other two each another term. While a tie
/// counted against a term, it was refused, `coupled_drag` was named in its place and 9.6
/// times the noise floor was left, with `N += -0.503 |u| N` alone.
#[test]
fn thrust_lost_in_a_cross_flow_is_found_on_a_navigation_log() {
    let d = navigation_diagnosis("crossflow_loss=2", 93);
    let what = "crossflow_loss=2 on a navigation log";
    cross_flow_found(&d, true, what, (2.0, 0.15));
}

/// A weaker loss, F (1 - |u| / 3 m/s), on seed 77's navigation log: `coupled_drag` was named
/// before discovery, and discovery searched again without it took a surge `|u| u` (0.0313
/// against 0.0059), so it stayed beside the cross flow's terms with `tether_drag` taken back.
/// The terms found beside it, kept as they are without it, now compete. The sway term was
/// fitted beside `coupled_drag` and is not refitted: 25 %.
#[test]
fn a_weaker_cross_flow_loss_leaves_no_look_alike_named() {
    let d = navigation_diagnosis("crossflow_loss=3", 77);
    let what = "crossflow_loss=3 on a navigation log";
    cross_flow_found(&d, true, what, (3.0, 0.25));
}

/// The diagnosis of scenario `effect` on seed `seed`'s navigation-log runs.
fn navigation_diagnosis(effect: &str, seed: u64) -> Diagnosis {
    let e = Effect::from_arg(effect).unwrap();
    let logs = crate::twin::pool::Logs::Navigation;
    let nav = scenario::fused_runs_seen(std::slice::from_ref(&e), seed, logs).unwrap();
    full(&nav, &scenario::cfd_fit_plant(1).unwrap())
}

/// The cross flow's two terms within `tol` of -1 / `speed`, no named effect beside them, and
/// the held-out cost near the noise floor.
fn cross_flow_found(d: &Diagnosis, is_nav: bool, what: &str, (speed, tol): (f64, f64)) {
    let c = closed_form(d, what);
    term_near(&c, Dof::Sway, "|u| Y", -1.0 / speed, tol);
    term_near(&c, Dof::Yaw, "|u| N", -1.0 / speed, tol);
    let claimed = named_beside(d, is_nav);
    assert!(
        claimed.is_empty(),
        "{what}: a named effect claimed it: {claimed:?}"
    );
    explains(d, &c, what);
}
