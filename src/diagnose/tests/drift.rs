//! Drift: a model whose own coefficients are a little off, nothing left out. The verdict is
//! that the parameters drifted, with coefficients re-estimated closer to the truth, not an
//! effect of the table standing in for them.

use super::*;
use crate::twin::pool::Logs;

/// A BlueROV2 Heavy-sized vehicle (`twin::pool::Craft::small`, 11.5 kg, I_zz 0.16 kg m^2) on
/// the pool's sensors, diagnosed from its true coefficients each moved 1-2.5 %. Its yaw
/// inertia is small enough that the added masses moved apart (X_udot +1.5 %, Y_vdot -2 %)
/// turn the yaw through their Munk moment: the starting model's held-out cost is 16 times
/// the noise floor, and `coupled_drag` (-0.64 N s^2/m^2) was named for it while the
/// re-estimate, by equation error, reached 0.0308 of its 0.0348. Re-estimated by output error
/// it reaches the floor; the heave, which these runs barely excite, keeps the model's drag
/// (re-estimated, its linear drag rose 3.4 times and its quadratic fell to a tenth, and its
/// held-out NMAE from 0.02 to 0.15).
#[test]
fn a_small_vehicle_whose_coefficients_are_slightly_off_is_called_drift() {
    let craft = crate::twin::pool::Craft::small();
    let plant = scenario::cfd_plant_of(&craft);
    let fused = scenario::fused_runs_of(&craft, &[], 92, Logs::Sensors).unwrap();
    let d = small_diagnosis(&craft, &plant, &fused);
    let b = &d.baseline;
    assert!(b.parameters_reestimated, "{}", d.verdict);
    assert!(d.effects.is_empty(), "{}", d.verdict);
    let re = &b.reestimated;
    assert!(
        re.validation_cost < 2.0 * b.noise_cost && re.validation_cost < 0.2 * b.validation_cost,
        "re-estimated {} against the noise floor {} and the model's {}",
        re.validation_cost,
        b.noise_cost,
        b.validation_cost
    );
    for (dof, nmae) in &re.validation_nmae {
        assert!(
            *nmae <= b.validation_nmae[dof] * 1.001,
            "{dof}: re-estimated NMAE {nmae} against the model's {}",
            b.validation_nmae[dof]
        );
    }
    let truth = craft.hydro.added_diag();
    let start = plant.hydro.added_diag();
    for (name, i) in [("X_udot", 0), ("Y_vdot", 1)] {
        let p = re.parameters.iter().find(|p| p.name == name).unwrap();
        assert!(
            (p.value - truth[i]).abs() < 0.5 * (start[i] - truth[i]).abs(),
            "{name} re-estimated {} from {} (truth {})",
            p.value,
            start[i],
            truth[i]
        );
    }
}

/// The same vehicle with a net buoyancy concealed: on the model as it is, the greedy rounds
/// named the right buoyancy and `coupled_drag` (-0.62) beside it for the added masses' Munk
/// moment, and left the yaw unexplained at 17 times its noise. With the model's own
/// coefficients re-estimated beside the named effects, the buoyancy alone is named, within
/// 10 % of the twin's, `coupled_drag` is dropped with the reason, and the held-out cost
/// reaches the floor.
#[test]
fn a_net_buoyancy_beside_slightly_off_coefficients_is_named_alone() {
    let craft = crate::twin::pool::Craft::small();
    let plant = scenario::cfd_plant_of(&craft);
    let hidden = 5.0;
    let effects = [Effect::NetBuoyancy { force_n: hidden }];
    let fused = scenario::fused_runs_of(&craft, &effects, 92, Logs::Sensors).unwrap();
    let d = small_diagnosis(&craft, &plant, &fused);
    let names: Vec<&str> = d.effects.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(names, ["net_buoyancy"], "{}", d.verdict);
    let f = d.effects[0].parameters["force_n"];
    assert!(
        (f - hidden).abs() < 0.1 * hidden,
        "force {f} (hidden {hidden})"
    );
    assert!(
        d.dropped.iter().any(|s| s.contains("coupled_drag")) || !d.verdict.contains("coupled"),
        "{}",
        d.verdict
    );
    let b = &d.baseline;
    assert!(b.parameters_reestimated, "{}", d.verdict);
    assert_eq!(b.reestimated.beside, ["net_buoyancy"]);
    assert!(
        b.reestimated.validation_cost < 1.5 * b.noise_cost,
        "held-out cost {} against the noise floor {}",
        b.reestimated.validation_cost,
        b.noise_cost
    );
}

/// The same vehicle with a short sensor delay (0.15 s, filtered at 0.075 s) concealed: on the
/// model as it is, the greedy rounds named `thruster_lag` (0.19 s) for it, the re-estimated
/// model beside the lag still leaving the yaw at 116 times its noise. One more round on the
/// re-estimated model puts the delay in the lag's place; the verdict never names the lag
/// alone.
#[test]
fn a_short_sensor_delay_beside_slightly_off_coefficients_is_not_called_a_lag() {
    let craft = crate::twin::pool::Craft::small();
    let plant = scenario::cfd_plant_of(&craft);
    let effects = [Effect::SensorDelay {
        delay_s: 0.15,
        filter_s: 0.075,
    }];
    let fused = scenario::fused_runs_of(&craft, &effects, 92, Logs::Sensors).unwrap();
    let d = small_diagnosis(&craft, &plant, &fused);
    let delay = d.effects.iter().find(|e| e.name == "sensor_delay");
    let lag_with_delay_alike = d
        .effects
        .iter()
        .any(|e| e.name == "thruster_lag" && e.alike.iter().any(|a| a.name == "sensor_delay"));
    assert!(delay.is_some() || lag_with_delay_alike, "{}", d.verdict);
    if let Some(e) = delay {
        let t = e.parameters["delay_s"];
        assert!((t - 0.15).abs() < 0.05, "delay {t} s (hidden 0.15 s)");
    }
    assert!(
        d.baseline.reestimated.validation_cost < 2.0 * d.baseline.noise_cost,
        "held-out cost {} against the noise floor {}",
        d.baseline.reestimated.validation_cost,
        d.baseline.noise_cost
    );
}

/// The diagnosis of the small craft's `fused` runs from its model `plant`, its verdict's words
/// checked against its numbers.
fn small_diagnosis(
    craft: &crate::twin::pool::Craft,
    plant: &crate::core::model::Plant,
    fused: &[crate::pool::fusion::run::FusedRun],
) -> Diagnosis {
    let d = full_of(&craft.vehicle, fused, plant);
    eprintln!("{}", d.verdict);
    d
}
