//! A thruster lag timed in the law it follows: the twin's force lag (an ESC that ramps the
//! thrust), where its motor lag has the thrust quadratic in a lagged speed
//! (`each_concealed_effect_is_named_first_with_its_parameter_and_the_held_out_error_drops`).

use super::*;

#[test]
fn a_lag_of_the_force_itself_is_timed_as_one() {
    for seed in [3, 4] {
        let e = Effect::ForceLag {
            time_constant_s: 0.4,
        };
        let d = scenario_diagnosis(std::slice::from_ref(&e), seed);
        assert_eq!(named(&d).first(), Some(&"thruster_lag"), "{}", d.verdict);
        let (truth, [lo, hi], got) = main_parameter(&e, &d);
        let exponent = d.effects[0].parameters["thrust_law_exponent"];
        assert!(
            (lo..=hi).contains(&got) && exponent < 1.3,
            "seed {seed}: lag {got} for {truth}, thrust law exponent {exponent}"
        );
    }
}
