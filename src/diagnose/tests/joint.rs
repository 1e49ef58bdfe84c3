//! One selection over named effects and discovered terms, and one rule for "explained", on
//! twin scenarios written apart from the diagnosis's forms.

use super::*;
use crate::core::dof::Dof;

/// A yaw moment that follows the surge thrust (a thruster mounted askew): `coupled_drag` may
/// win the first round on part of it, but once discovery finds the thrust term, the named
/// effect no longer earns its margin and is dropped, said in the verdict.
#[test]
fn a_named_look_alike_is_dropped_beside_the_discovered_term() {
    let mut dropped = 0;
    for (arg, seed, arm) in [
        ("skewed_thruster=0.0434", 1, 0.0434),
        ("skewed_thruster=0.06", 4, 0.06),
    ] {
        let e = Effect::from_arg(arg).unwrap();
        let d = scenario_diagnosis(std::slice::from_ref(&e), seed);
        let c = d
            .effects
            .iter()
            .find_map(|x| x.candidate.clone())
            .unwrap_or_else(|| panic!("seed {seed}: no closed form: {}", d.verdict));
        assert_eq!(c.dof, Dof::Yaw, "seed {seed}: {}", c.expression);
        let got = c
            .terms
            .iter()
            .find(|t| t.term == "X")
            .map(|t| t.coefficient);
        assert!(
            got.is_some_and(|a: f64| (a - arm).abs() < 0.2 * arm),
            "seed {seed}: {}",
            c.expression
        );
        assert!(
            named(&d).is_empty(),
            "seed {seed}: named {:?} beside the discovered term: {}",
            named(&d),
            d.verdict
        );
        dropped += d.dropped.len();
    }
    // The second chooses coupled_drag before discovery runs: the joint selection is what
    // removes it.
    assert!(dropped > 0, "no named effect was ever chosen and dropped");
}

/// Net buoyancy (3 N) beside thrusters losing thrust to the inflow (F (1 - s / 3 m/s)), on
/// the pool's sensors, seed 74. The greedy rounds named `net_buoyancy`, then `coupled_drag`
/// and `reverse_thrust_loss` for parts of the loss, and discovery found nothing on top of the
/// three: the verdict named all three and left 6.2 times the floor without a closed form.
/// Discovery beside the first effect named alone finds the inflow's form, the two
/// look-alikes are dropped (said in the verdict), the buoyancy stays within 10 %, and the
/// held-out cost is under a sixth of the model's.
#[test]
fn look_alikes_named_after_an_effect_give_way_to_the_discovered_form() {
    let (d, c) = inflow_beside("net_buoyancy=3", "force_n", 3.0, 0.3);
    assert!(
        d.verdict
            .contains("The named effect coupled_drag was dropped"),
        "{}",
        d.verdict
    );
    assert!(
        c.cost_after_all() < d.baseline.validation_cost / 6.0,
        "held-out cost {} -> {}",
        d.baseline.validation_cost,
        c.cost_after_all()
    );
}

/// An inflow loss (3 m/s) beside a thruster lag of 0.3 s, pool sensors, seed 74: the joint
/// selection dropped `coupled_drag` beside the discovered inflow terms (it raised the held-out
/// cost), then the search for effects the terms unmasked took it back for a gain of 0.59
/// times the noise floor, and the verdict said both. An effect dropped beside the terms is
/// not taken back by them: the lag alone is named, every effect dropped stays dropped, and
/// the held-out cost ends under a twentieth of the model's.
///
/// With the thrusters started from rest as the twin's are, the lag beside the loss comes out
/// 13 % long and takes the loss's transient share, and discovery finds the heave share of the
/// loss only (`Z += -0.08 Z`), not its surge form: see docs/diagnosis.md, Known limits.
#[test]
fn an_effect_dropped_beside_the_terms_is_not_taken_back_by_them() {
    let effects = ["inflow_loss=3", "thruster_lag=0.3"].map(|e| Effect::from_arg(e).unwrap());
    let d = scenario_diagnosis(&effects, 74);
    assert_eq!(named(&d), ["thruster_lag"], "{}", d.verdict);
    assert!(!d.dropped.is_empty(), "nothing was dropped: {}", d.verdict);
    let c = (d.effects.iter())
        .find_map(|x| x.candidate.clone())
        .unwrap_or_else(|| panic!("no closed form: {}", d.verdict));
    assert!(
        c.cost_after_all() < d.baseline.validation_cost / 20.0,
        "held-out cost {} -> {}",
        d.baseline.validation_cost,
        c.cost_after_all()
    );
}

/// Seed 74 on the pool's sensors with an inflow loss (3 m/s) and `other` concealed: `other`
/// alone is named, its parameter `param` within `tol` of `truth`, and the inflow's form
/// found in surge ([`super::discovery::surge_inflow_within`]). The diagnosis and its closed
/// form.
fn inflow_beside(
    other: &str,
    param: &str,
    truth: f64,
    tol: f64,
) -> (Diagnosis, crate::diagnose::result::Candidate) {
    let other = Effect::from_arg(other).unwrap();
    let effects = [Effect::from_arg("inflow_loss=3").unwrap(), other.clone()];
    let d = scenario_diagnosis(&effects, 74);
    assert_eq!(named(&d), [other.name()], "{}", d.verdict);
    let x = d.effects[0].parameters[param];
    assert!((x - truth).abs() < tol, "{} {param} {x}", other.name());
    let c = (d.effects.iter())
        .find_map(|x| x.candidate.clone())
        .unwrap_or_else(|| panic!("no closed form: {}", d.verdict));
    super::discovery::surge_inflow_within(&d, &c, -3.5..-1.5, 3.0);
    (d, c)
}

/// A periodic heave force two to five times the noise floor is never "within noise", at the
/// twin's 0.42 Hz and at another frequency; effect-free runs stay clean
/// ([`super::nothing_is_claimed_on_effect_free_data`]).
#[test]
fn a_periodic_force_above_the_noise_is_always_reported() {
    let wave = |force_n: f64, frequency_hz: f64| Effect::Wave {
        force_n,
        frequency_hz,
        phase_rad: 0.3,
    };
    for (e, seed) in [
        (wave(5.0, 0.42), 6),
        (wave(8.0, 0.42), 3),
        (wave(6.0, 0.545), 4),
        (wave(13.0, 0.545), 5),
    ] {
        let d = scenario_diagnosis(std::slice::from_ref(&e), seed);
        assert_reported(&d, &e, seed);
    }
}

/// Without a horizontal position (a navigation log's velocities alone), the effects that read
/// it are listed as untested with what is missing, never scored on a made-up tether length.
#[test]
fn effects_that_need_a_position_are_untested_without_one() {
    let mut runs = scenario::runs(&[], 2).unwrap();
    for r in &mut runs {
        for p in &mut r.pos[..2] {
            p.iter_mut().for_each(|x| *x = f64::NAN);
        }
    }
    let data = Data::new(runs).unwrap();
    let untested = crate::diagnose::untested(&data);
    for name in ["tether_drag", "wall_effect"] {
        let u = untested
            .iter()
            .find(|u| u.name == name)
            .unwrap_or_else(|| panic!("{name} not listed as untested: {untested:?}"));
        assert!(u.missing.contains("horizontal position"), "{}", u.missing);
    }
    let plant = scenario::cfd_fit_plant(1).unwrap();
    let s = select(&plant, &data, &Criteria::default(), &|_| {});
    assert!(
        s.tested
            .iter()
            .all(|t| t.name != "tether_drag" && t.name != "wall_effect"),
        "tested without a position"
    );
    assert!(
        s.tested.iter().all(|t| t.validation_cost.is_finite()),
        "a hypothesis scored with a non-finite input"
    );
}

/// A named effect beside an out-of-table one is refitted once the table's effect has a
/// discovered term beside it: a tether's drag with a thrust fading 10 % a minute, where the
/// tether fitted first took up part of the fade (its drag at 11 m 1.2 times the twin's).
#[test]
fn a_named_effect_is_refitted_beside_the_discovered_terms() {
    let effects = ["battery_sag=0.1", "tether_drag=1"].map(|a| Effect::from_arg(a).unwrap());
    let d = scenario_diagnosis(&effects, 8);
    assert_eq!(named(&d), ["tether_drag"], "{}", d.verdict);
    let (want, [lo, hi], got) = main_parameter(&effects[1], &d);
    let close = [want * 0.85, want * 1.15];
    assert!(
        (lo..=hi).contains(&got) && (close[0]..=close[1]).contains(&got),
        "tether drag at 11 m {got} for {want}: {}",
        d.verdict
    );
    let c = d
        .effects
        .iter()
        .find_map(|x| x.candidate.as_ref())
        .unwrap_or_else(|| panic!("no closed form: {}", d.verdict));
    let fade = -0.1 / 60.0;
    for t in c.parts().flat_map(|p| &p.terms) {
        assert!(
            (t.coefficient - fade).abs() < 0.15 * fade.abs(),
            "{}: {}",
            c.expressions(),
            d.verdict
        );
    }
    assert!(
        d.verdict.contains("Refitted beside the discovered terms"),
        "{}",
        d.verdict
    );
}

/// A named effect masked by one outside the table is taken back beside the discovered term:
/// with a tether twisting as the vehicle turns (yaw residual thousands of times its noise), a
/// thruster lag of 0.3 s lowered the held-out cost by 9 % alone, under the 12 % its two
/// parameters need, and was not named; discovery then found the lag's own form in every DOF
/// beside the tether's `N += c psi`, and the verdict named nothing (seed 60). Now the lag is
/// named (its time constant within 15 % of the twin's) beside the discovered torsion term
/// (within 10 % of the twin's 0.8 N m/rad), and nothing else is named. Measured on seeds 2 and
/// 60: lag 0.307 and 0.305 s, `N += -0.803 psi` and `-0.799 psi`.
#[test]
fn a_masked_named_effect_is_taken_back_beside_the_discovered_term() {
    let effects = ["tether_torsion=0.8", "thruster_lag=0.3"].map(|a| Effect::from_arg(a).unwrap());
    for seed in [2, 60] {
        let d = scenario_diagnosis(&effects, seed);
        assert_eq!(named(&d), ["thruster_lag"], "seed {seed}: {}", d.verdict);
        let lag = d.effects[0].parameters["time_constant_s"];
        assert!((lag - 0.3).abs() < 0.15 * 0.3, "seed {seed}: lag {lag} s");
        let c = d
            .effects
            .iter()
            .find_map(|x| x.candidate.clone())
            .unwrap_or_else(|| panic!("seed {seed}: no closed form: {}", d.verdict));
        let psi = c
            .parts()
            .flat_map(|p| &p.terms)
            .find(|t| t.term == "psi")
            .map_or(f64::NAN, |t| t.coefficient);
        assert!(
            (psi + 0.8).abs() < 0.1 * 0.8,
            "seed {seed}: {}",
            c.expressions()
        );
    }
}
