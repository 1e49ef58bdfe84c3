//! The guards around the search: an unstable model on piloted runs, an effect at its bound,
//! an effect added to the registry, the bounded training cost and the evidence words.

use super::*;

#[test]
fn an_unstable_model_on_piloted_runs_is_not_read_as_missing_physics() {
    use crate::core::model::{Hydro, Plant, Vehicle};
    let fused = piloted_fast_runs(3);
    let plant = Plant::new(&Vehicle::reference(), Hydro::reference());
    // The default horizon: re-anchored where the model grows.
    let d = diagnose(
        &Vehicle::reference(),
        "fit",
        &plant,
        &fused,
        &Criteria::default(),
        &|_| {},
    )
    .unwrap()
    .0;
    let names: Vec<&str> = d.effects.iter().map(|e| e.name.as_str()).collect();
    assert!(
        names.is_empty(),
        "named {names:?} on effect-free piloted runs\n{}\nbase {} noise {} hyps {:?}",
        d.verdict,
        d.baseline.validation_cost,
        d.baseline.noise_cost,
        d.hypotheses
            .iter()
            .map(|h| (&h.name, h.validation_cost, &h.parameters))
            .collect::<Vec<_>>()
    );
    for (run, s) in &d.stability {
        assert!(
            s.growth_per_s > 1.0 && s.horizon_s.is_some_and(|h| h < 5.0),
            "{run}: {s:?}"
        );
    }
    // Simulated whole, the same runs drift apart: the error is far above the noise floor.
    let whole = Criteria {
        horizon_s: crate::core::model::stability::Horizon::WholeRun,
        ..Criteria::default()
    };
    let w = diagnose(
        &Vehicle::reference(),
        "fit",
        &plant,
        &fused,
        &whole,
        &|_| {},
    )
    .unwrap()
    .0;
    assert!(
        w.baseline.validation_cost > 20.0 * d.baseline.validation_cost.max(1e-9),
        "whole-run {} vs windowed {}",
        w.baseline.validation_cost,
        d.baseline.validation_cost
    );
}

/// A thruster lag twice as long as the search allows: the fitted lag ends on its bound, so it
/// is not a finding (the data want more than the effect can give), and what remains is
/// reported unexplained rather than patched by another effect.
#[test]
fn an_effect_pushed_to_its_bound_is_refused() {
    let d = scenario_diagnosis(
        &[Effect::ThrusterLag {
            time_constant_s: 3.0,
        }],
        2,
    );
    let lag = d
        .hypotheses
        .iter()
        .filter(|t| t.name == "thruster_lag")
        .max_by(|a, b| a.gain.total_cmp(&b.gain))
        .unwrap();
    assert!(
        lag.at_bound.iter().any(|p| p.contains("time_constant_s")),
        "{lag:?}"
    );
    assert!(!lag.accepted, "{lag:?}");
    assert!(
        d.effects.iter().all(|e| e.name != "thruster_lag"),
        "{:?}",
        d.effects.iter().map(|e| &e.name).collect::<Vec<_>>()
    );
    assert!(
        d.effects.iter().any(|e| e.name == "unexplained"),
        "{}",
        d.verdict
    );
}

/// An effect written here, outside the effects' own files: a constant sway force (a thruster
/// mounted askew, a steady side current on the tether). Adding it to the effects the diagnosis
/// tests is all it takes for the diagnosis to fit it, judge it and name it.
#[derive(Debug)]
struct SwayPush(f64);

impl effects::Term for SwayPush {
    fn add_force(&self, _env: &effects::Env, _s: &effects::State, f: &mut Vec6) {
        f[1] += self.0;
    }
}

static SWAY_PUSH: Hypothesis = Hypothesis {
    name: "sway_push",
    params: &[effects::Param {
        name: "force_n",
        lo: -30.0,
        hi: 30.0,
        unit: "N",
        limits: effects::Limits::Search,
    }],
    needs: effects::Needs::Nothing,
    build: |p| Arc::new(SwayPush(p[0])),
    main_dof: crate::core::dof::Dof::Sway,
    acts_in: &[],
    regime: "small_command",
    axis: effects::Axis {
        label: |_| "time (s)".into(),
        value: |r, k, _| r.t[k],
    },
};

#[test]
fn an_effect_added_to_the_registry_is_tested_and_found() {
    // Effect-free twin runs whose logged sway command is 4 N short of what the vehicle got:
    // to the model, an unexplained constant push of +4 N in sway.
    let mut runs = scenario::runs(&[], 8).unwrap();
    for r in &mut runs {
        for c in &mut r.cmd {
            c[1] -= 4.0;
        }
    }
    let mut data = Data::new(runs).unwrap();
    let mut with_push: Vec<&'static Hypothesis> = REGISTRY.to_vec();
    with_push.push(&SWAY_PUSH);
    data.effects = Box::leak(with_push.into_boxed_slice());
    let plant = scenario::cfd_fit_plant(1).unwrap();
    let s = select(&plant, &data, &Criteria::default(), &|_| {});
    assert!(
        s.tested.iter().any(|t| t.name == "sway_push"),
        "not tested: {:?}",
        s.tested.iter().map(|t| &t.name).collect::<Vec<_>>()
    );
    let (h, p) = s.selected.first().expect("an effect is named");
    assert_eq!(
        h.name,
        "sway_push",
        "named {:?}",
        s.selected.iter().map(|(h, _)| h.name).collect::<Vec<_>>()
    );
    assert!(
        (p[0] - 4.0).abs() < 0.8,
        "sway push {:.2} N, concealed 4 N",
        p[0]
    );
}

#[test]
fn a_bounded_training_cost_is_exact_below_its_bound_and_gives_up_above_it() {
    let data =
        Data::new(scenario::runs(&[Effect::NetBuoyancy { force_n: 6.0 }], 5).unwrap()).unwrap();
    let plant = scenario::cfd_fit_plant(1).unwrap();
    let lag = hypothesis("thruster_lag").unwrap();
    for tc in [0.0, 0.3, 1.2] {
        let aug = augmentation(&[(lag, vec![tc])]);
        let exact = data.cost(&plant, &aug, false);
        let below = |bound: f64| data.train_cost_below(&plant, &aug, bound);
        assert_eq!(below(f64::INFINITY).to_bits(), exact.to_bits(), "lag {tc}");
        assert_eq!(
            below(exact * (1.0 + 1e-9)).to_bits(),
            exact.to_bits(),
            "lag {tc}"
        );
        assert_eq!(
            below(0.5 * exact),
            f64::INFINITY,
            "lag {tc}: {exact} is over twice the bound"
        );
    }
}

#[test]
fn evidence_words_follow_their_numbers_with_the_effect_present_and_absent() {
    let plant = scenario::cfd_fit_plant(1).unwrap();
    let lag = hypothesis("thruster_lag").unwrap();
    let caption = |effects: &[Effect], tc: f64| {
        let data = Data::new(scenario::runs(effects, 11).unwrap()).unwrap();
        let after = augmentation(&[(lag, vec![tc])]);
        let figs = super::figures::evidence_figures(
            &plant,
            &data,
            lag,
            &Augmentation::default(),
            &after,
            &[],
        )
        .unwrap();
        figs.last().unwrap().caption.clone()
    };
    // Absent: effect-free runs, with a 0.6 s lag forced on them. The residual has no shape
    // along the time since a step, and the lag makes it worse.
    let c = caption(&[], 0.6);
    assert!(c.contains("Without the effect it stays about flat"), "{c}");
    assert!(c.contains("higher on average"), "{c}");
    // Present: a concealed motor lag, and the first-order lag it looks like.
    let c = caption(
        &[Effect::ThrusterLag {
            time_constant_s: 0.35,
        }],
        0.45,
    );
    assert!(c.contains("Without the effect it falls"), "{c}");
    assert!(c.contains("lower on average"), "{c}");
}
