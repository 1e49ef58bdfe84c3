//! Discovery beyond the vocabulary, on twin scenarios whose physics no named effect describes:
//! a wave's vertical force, a surge thruster mounted askew, drag that grows near the surface,
//! a tether that twists as the vehicle turns, a battery that drains, thrusters that saturate,
//! a hull bluffer astern, propellers losing thrust to the inflow. The twin conceals each with
//! its own code (`crate::twin::world`: a pure sine, a moment of the thrust delivered through
//! the thrusters' own dynamics, a Gaussian fall-off with depth, a moment against the turns
//! made, every thruster's force scaled down with time, the force clipped before the motors'
//! lag, extra drag when u < 0, the force scaled by the speed along its push), none of which is
//! a term of the discovery's library as written but the fourth, fifth and seventh: the
//! library counts the heading's turns itself off the fused log, multiplies each DOF's logged
//! command by the run's clock, and splits each DOF's `|x| x` into ahead and astern; its
//! clipped commands are clipped at shares of the largest command, not at the twin's level, and
//! its inflow term is Blanke's, not the twin's.

use super::*;
use crate::core::dof::Dof;

fn candidate(arg: &str, seed: u64) -> (Diagnosis, crate::diagnose::result::Candidate) {
    let e = Effect::from_arg(arg).unwrap();
    let d = scenario_diagnosis(std::slice::from_ref(&e), seed);
    let c = d
        .effects
        .iter()
        .find_map(|x| x.candidate.clone())
        .unwrap_or_else(|| {
            panic!(
                "{arg}: no closed form proposed; effects {:?}\n{}",
                d.effects.iter().map(|x| &x.name).collect::<Vec<_>>(),
                d.verdict
            )
        });
    (d, c)
}

/// The candidate lowers the held-out NMAE of its DOF and the held-out cost by the margin a
/// named effect needs.
fn proven(arg: &str, c: &crate::diagnose::result::Candidate) {
    let (b, a) = (
        c.validation_nmae_before[&c.dof],
        c.validation_nmae_after[&c.dof],
    );
    assert!(a < 0.9 * b, "{arg}: held-out {} NMAE {b} -> {a}", c.dof);
    assert!(
        c.validation_cost_after < 0.9 * c.validation_cost_before,
        "{arg}: held-out cost {} -> {}",
        c.validation_cost_before,
        c.validation_cost_after
    );
}

#[test]
fn a_wave_force_is_found_as_a_sine_at_its_frequency() {
    let arg = "wave=12";
    let (d, c) = candidate(arg, 2);
    assert_eq!(c.dof, Dof::Heave, "{}", c.expression);
    let sine = c
        .terms
        .iter()
        .find(|t| t.frequency_hz.is_some())
        .unwrap_or_else(|| panic!("no sine in {}", c.expression));
    let f = sine.frequency_hz.unwrap();
    assert!(
        (f - 0.42).abs() < 0.05 * 0.42,
        "frequency {f} Hz, twin 0.42"
    );
    assert!(
        (sine.coefficient - 12.0).abs() < 0.3 * 12.0,
        "amplitude {} N, twin 12",
        sine.coefficient
    );
    // On the logs' clock, as the twin's wave is (the fusion's small lag aside).
    let phase = sine.phase_rad.unwrap();
    assert!((phase - 0.3).abs() < 0.3, "phase {phase} rad, twin 0.3");
    assert_eq!(c.terms.len(), 1, "{}", c.expression);
    assert!(c.named_as.is_none(), "a wave is no named effect");
    assert!(
        d.effects.iter().any(|e| e.name == "unexplained"),
        "reported as unexplained with its expression"
    );
    proven(arg, &c);
}

#[test]
fn a_yaw_moment_that_follows_the_surge_command_is_found() {
    let arg = "skewed_thruster=0.06";
    let (_, c) = candidate(arg, 2);
    assert_eq!(c.dof, Dof::Yaw, "{}", c.expression);
    // N = arm X, and nothing else.
    assert_eq!(c.terms.len(), 1, "{}", c.expression);
    let t = &c.terms[0];
    assert_eq!(t.term, "X", "{}", c.expression);
    assert!(
        (t.coefficient - 0.06).abs() < 0.15 * 0.06,
        "arm {} m, twin 0.06 ({})",
        t.coefficient,
        c.expression
    );
    assert!(c.named_as.is_none());
    proven(arg, &c);
}

#[test]
fn drag_near_the_surface_is_found_with_depth_and_speed() {
    let arg = "surface_drag=400";
    let (_, c) = candidate(arg, 2);
    assert!(matches!(c.dof, Dof::Surge | Dof::Sway), "{}", c.expression);
    assert!(
        c.terms
            .iter()
            .any(|t| t.term.contains("exp(-z") && t.term.contains('|')),
        "the term reads depth and speed: {}",
        c.expression
    );
    proven(arg, &c);
}

/// A tether twisting as the vehicle turns (a yaw moment against the heading turned through,
/// -k psi) is no named effect: it is found as `N += c psi` with c within 15 % of -k, on the
/// pool's sensors and on a vehicle that logs only its navigation (its heading the AHRS's).
#[test]
fn a_yaw_moment_against_the_turns_made_is_found() {
    let arg = "tether_torsion=1.5";
    let check = |c: &crate::diagnose::result::Candidate, what: &str| {
        eprintln!(
            "{what}: {} (held-out cost {:.4} -> {:.4})",
            c.expression, c.validation_cost_before, c.validation_cost_after
        );
        assert_eq!(c.dof, Dof::Yaw, "{what}: {}", c.expression);
        let t = c
            .terms
            .iter()
            .find(|t| t.term == "psi")
            .unwrap_or_else(|| panic!("{what}: no heading term in {}", c.expression));
        assert!(
            (t.coefficient + 1.5).abs() < 0.15 * 1.5,
            "{what}: {} N m/rad, twin -1.5 ({})",
            t.coefficient,
            c.expression
        );
        assert!(c.named_as.is_none(), "{what}: {:?}", c.named_as);
        proven(arg, c);
    };
    let (_, c) = candidate(arg, 3);
    check(&c, "pool sensors");
    let e = Effect::from_arg(arg).unwrap();
    let fused = scenario::fused_runs_seen(
        std::slice::from_ref(&e),
        2,
        crate::twin::pool::Logs::Navigation,
    )
    .unwrap();
    let d = full(&fused, &scenario::cfd_fit_plant(1).unwrap());
    let c = d
        .effects
        .iter()
        .find_map(|x| x.candidate.clone())
        .unwrap_or_else(|| panic!("navigation log: no closed form\n{}", d.verdict));
    check(&c, "navigation log");
}

/// A battery draining over the run (every thruster's force falls by 15 % a minute) is no named
/// effect: it is found as `F += c t F` in each of the four DOFs, c within 25 % of the twin's
/// -0.15 / 60 s, with no effect name kept beside it and the held-out error down in each DOF.
/// Found one DOF at a time it was not: the exact surge term alone raised the held-out cost
/// while the yaw it couples into was unmodelled, and `thruster_deadband` was named instead.
#[test]
fn a_thrust_that_fades_over_the_run_is_found() {
    let arg = "battery_sag=0.15";
    let e = Effect::from_arg(arg).unwrap();
    faded_thrust_found(
        &scenario_diagnosis(std::slice::from_ref(&e), 2),
        "pool sensors",
        false,
        FADE,
    );
    let fused = scenario::fused_runs_seen(
        std::slice::from_ref(&e),
        3,
        crate::twin::pool::Logs::Navigation,
    )
    .unwrap();
    let d = full(&fused, &scenario::cfd_fit_plant(1).unwrap());
    faded_thrust_found(&d, "navigation log", true, FADE);
}

/// What [`a_thrust_that_fades_over_the_run_is_found`] asks of a fade of 15 % a minute: the
/// rate, the DOFs it is found in, and the share of the held-out cost left.
const FADE: Fade = Fade {
    per_minute: 0.15,
    dofs: 4,
    cost_left: 0.2,
};

/// A weak drain, 5 % a minute, is found too, with the look-alike it was taken for dropped.
/// It stands out only in yaw (the other DOFs' residuals stay under the structure mark), where
/// the exact term alone did not lower the held-out cost (0.0078 -> 0.0078: surge, sway and
/// heave still faded), so discovery found nothing and `reverse_thrust_loss` was named in
/// heave (17 % of the cost: the heave command is mostly one-signed). The thruster forms found
/// in one DOF are now tried in the model's other DOFs together with it
/// (`discover::search::siblings`). Measured: the rate found in 3 and 4 DOFs, -0.0008 per s in
/// each, the held-out cost 0.0097 -> 0.0043 and 0.0098 -> 0.0022 (noise floor about 0.0024).
#[test]
fn a_weak_fade_is_found_not_named_as_a_look_alike() {
    let e = Effect::from_arg("battery_sag=0.05").unwrap();
    let fade = Fade {
        per_minute: 0.05,
        dofs: 3,
        cost_left: 0.5,
    };
    for seed in [2, 3] {
        let d = scenario_diagnosis(std::slice::from_ref(&e), seed);
        faded_thrust_found(&d, &format!("seed {seed}, 5 % a minute"), false, fade);
        assert!(
            d.dropped.iter().any(|w| w.contains("reverse_thrust_loss")),
            "seed {seed}: {:?}\n{}",
            d.dropped,
            d.verdict
        );
    }
}

/// A thrust that fades: the share lost per minute, the fewest DOFs its term must be found in,
/// and the most of the held-out cost the terms may leave.
#[derive(Clone, Copy)]
struct Fade {
    per_minute: f64,
    dofs: usize,
    cost_left: f64,
}

/// The checks of [`a_thrust_that_fades_over_the_run_is_found`] on one diagnosis.
fn faded_thrust_found(d: &Diagnosis, what: &str, nav: bool, fade: Fade) {
    let want = -fade.per_minute / 60.0;
    eprintln!("{what}: {}", d.verdict);
    let c = d
        .effects
        .iter()
        .find_map(|x| x.candidate.as_ref())
        .unwrap_or_else(|| panic!("{what}: no closed form\n{}", d.verdict));
    assert!(c.named_as.is_none(), "{what}: {:?}", c.named_as);
    // No named effect beside it, but a navigation log's own lateness.
    let claimed = named_beside(d, nav);
    assert!(
        claimed.is_empty(),
        "{what}: a named effect claimed it: {claimed:?}"
    );
    // Found in every DOF the thrusters drive, each with the twin's rate.
    let dofs: Vec<Dof> = c.parts().map(|p| p.dof).collect();
    assert!(dofs.len() >= fade.dofs, "{what}: {}", d.verdict);
    for p in c.parts() {
        let own = format!("t {}", p.dof.force());
        let t = p.terms.iter().find(|t| t.term == own);
        let k = t.map_or(f64::NAN, |t| t.coefficient);
        assert!(
            (k - want).abs() < 0.25 * want.abs(),
            "{what}, {}: {k} per s, twin {want} ({})",
            p.dof,
            p.expression
        );
    }
    // Together they take the held-out cost down by most of it and every DOF's NMAE.
    let last = c.also.last().unwrap();
    assert!(
        c.cost_after_all() < fade.cost_left * c.validation_cost_before,
        "{what}: held-out cost {} -> {}",
        c.validation_cost_before,
        c.cost_after_all()
    );
    for d in &dofs {
        let (b, a) = (c.validation_nmae_before[d], last.validation_nmae_after[d]);
        assert!(a < 0.9 * b, "{what}, {d}: held-out NMAE {b} -> {a}");
    }
}

/// Named effects in `d` beside the discovered terms, a navigation log's own lateness (a lag
/// no longer than one DVL ping, each row carrying its last) aside.
pub(super) fn named_beside(d: &Diagnosis, nav: bool) -> Vec<String> {
    (d.effects.iter())
        .filter(|e| e.name != "unexplained")
        .filter(|e| {
            let late = e.lateness_s();
            !(nav && late.is_some_and(|t| t <= crate::twin::pool::NAV_DVL_PERIOD_S))
        })
        .map(|e| format!("{} {:?}", e.name, e.parameters))
        .collect()
}

/// Thrusters that cannot deliver more than 45 N (4.5 N m in yaw): what the runs ask beyond it
/// is clipped (the twin clips the force before the motors' lag). No named effect describes it,
/// and no term of the library is the twin's level: the library clips each DOF's command at
/// shares of its largest, and the level of a kept term is refined on the training rows. It is
/// found in surge as `X += c (clip(X, +-level) - X)`, c within 20 % of 1 and the level within
/// 8 % of 45 N, with no named effect beside it. Before the
/// clipped commands were in the library, a 40 N clip on seed 73 was left without a closed
/// form (held-out cost 0.0678 at 14 times the noise floor); with them, 0.0068.
#[test]
fn thrusters_that_saturate_are_found_as_a_clipped_command() {
    let arg = "thrust_saturation=45";
    let (d, c) = candidate(arg, 2);
    eprintln!("{}", d.verdict);
    let level = |t: &str| -> f64 {
        let after = t.split("+-").nth(1).unwrap_or("");
        after
            .split(')')
            .next()
            .unwrap_or("")
            .parse()
            .unwrap_or(f64::NAN)
    };
    let surge = (c.parts().filter(|p| p.dof == Dof::Surge))
        .flat_map(|p| p.terms.iter())
        .find(|t| t.term.starts_with("(clip(X"))
        .unwrap_or_else(|| panic!("no clipped surge command in {}", d.verdict));
    let l = level(&surge.term);
    assert!(
        (surge.coefficient - 1.0).abs() < 0.2 && (l - 45.0).abs() < 0.08 * 45.0,
        "{} {}, twin 1 (clip(X, +-45) - X)",
        surge.coefficient,
        surge.term
    );
    let claimed = named_beside(&d, false);
    assert!(claimed.is_empty(), "a named effect claimed it: {claimed:?}");
    proven(arg, &c);
}

/// A hull bluffer astern: backing up meets the extra drag -120 |u| u, going ahead none. Its
/// look-alike is a reverse thrust loss (less force astern: the same steady speed, another
/// transient). It is found as `X += c |u| u [u < 0]`, c within 15 % of -120, with no named
/// effect beside it, on the pool's sensors and on a navigation log. Before the one-sided drag
/// was in the library, seed 73 named `reverse_thrust_loss` with `tether_drag` or
/// `wall_effect` for a third of the mismatch and left the rest without a closed form.
#[test]
fn drag_that_is_larger_astern_is_found_one_sided() {
    let arg = "asymmetric_drag=120";
    let e = Effect::from_arg(arg).unwrap();
    let nav = scenario::fused_runs_seen(
        std::slice::from_ref(&e),
        3,
        crate::twin::pool::Logs::Navigation,
    )
    .unwrap();
    let runs = [
        (
            "pool sensors",
            false,
            scenario_diagnosis(std::slice::from_ref(&e), 2),
        ),
        (
            "navigation log",
            true,
            full(&nav, &scenario::cfd_fit_plant(1).unwrap()),
        ),
    ];
    for (what, is_nav, d) in runs {
        eprintln!("{what}: {}", d.verdict);
        let c = (d.effects.iter())
            .find_map(|x| x.candidate.clone())
            .unwrap_or_else(|| panic!("{what}: no closed form\n{}", d.verdict));
        assert_eq!(c.dof, Dof::Surge, "{what}: {}", c.expression);
        let t = (c.terms.iter())
            .find(|t| t.term == "|u| u [u < 0]")
            .unwrap_or_else(|| panic!("{what}: no one-sided drag in {}", c.expression));
        assert!(
            (t.coefficient + 120.0).abs() < 0.15 * 120.0,
            "{what}: {} N s^2/m^2, twin -120 ({})",
            t.coefficient,
            c.expression
        );
        let claimed = named_beside(&d, is_nav);
        assert!(
            claimed.is_empty(),
            "{what}: a named effect claimed it: {claimed:?}"
        );
        proven(arg, &c);
    }
}

/// Propellers losing thrust to the inflow: moving at speed along a thruster's push, the twin
/// delivers F (1 - s / 2 m/s). The library's form is Blanke's (T_nu |n| u with |n| as
/// sqrt(|X|)), not the twin's, so the coefficient is only of the size sqrt(|X|) / V at the
/// runs' thrust (about 2.5-4): it is found in surge as `X += c sqrt(|X|) u` with c in
/// [-5, -2], no named effect beside it, the held-out error down. (On a navigation log the same
/// loss alone is taken for drifted parameters: re-estimating the drag leaves 4.3 times the
/// noise floor, under the drift's allowance, but discovery beats it: `nav_only`.)
#[test]
fn thrust_lost_to_the_inflow_is_found_with_speed_and_command() {
    let arg = "inflow_loss=2";
    let (d, c) = candidate(arg, 73);
    eprintln!("{}", d.verdict);
    surge_inflow_within(&d, &c, -5.0..-2.0, 2.0);
    let claimed = named_beside(&d, false);
    assert!(claimed.is_empty(), "a named effect claimed it: {claimed:?}");
    proven(arg, &c);
}

/// The inflow term the closed form `c` of diagnosis `d` holds in surge for the twin's loss
/// F (1 - s / `v_m_s`): the twin's own form `|u| X` (a command times its speed) with its
/// coefficient within 25 % of -1 / V, or Blanke's `sqrt(|X|) u` inside `blanke` (of the size
/// sqrt(|X|) / V at the runs' thrust).
pub(super) fn surge_inflow_within(
    d: &Diagnosis,
    c: &crate::diagnose::result::Candidate,
    blanke: std::ops::Range<f64>,
    v_m_s: f64,
) {
    let surge = || (c.parts().filter(|p| p.dof == Dof::Surge)).flat_map(|p| p.terms.iter());
    if let Some(t) = surge().find(|t| t.term == "|u| X") {
        let want = -1.0 / v_m_s;
        assert!(
            (t.coefficient - want).abs() < 0.25 * want.abs(),
            "{} |u| X, twin {want}: {}",
            t.coefficient,
            d.verdict
        );
        return;
    }
    let t = surge()
        .find(|t| t.term == "sqrt(|X|) u")
        .unwrap_or_else(|| panic!("no inflow term in surge: {}", d.verdict));
    assert!(
        blanke.contains(&t.coefficient),
        "{} sqrt(|X|) u, outside {blanke:?}",
        t.coefficient
    );
}
