use super::*;
use crate::model::effects::Effect;
use crate::stage::diagnose::{diagnose, Diagnosis};

fn run_scenario(effects: &[Effect], seed: u64) -> (Search, Data) {
    let runs = scenario::runs(effects, seed).unwrap();
    let data = Data::new(runs).unwrap();
    let plant = scenario::cfd_fit_plant(1).unwrap();
    let s = select(&plant, &data, &Criteria::default(), &|_| {});
    (s, data)
}

/// The full diagnosis of a generated scenario, against the CFD fit of the twin's STAR-CCM+ cases.
fn full(fused: &[crate::stage::pool::FusedRun], plant: &crate::model::Plant) -> Diagnosis {
    diagnose(&crate::model::Vehicle::reference(), "fit", plant, fused, &Criteria::default(), &|_| {}).unwrap().0
}

fn scenario_diagnosis(effects: &[Effect], seed: u64) -> Diagnosis {
    full(&scenario::fused_runs(effects, seed).unwrap(), &scenario::cfd_fit_plant(1).unwrap())
}

/// The effect's defining parameter and the diagnosis' value of it.
fn main_parameter(e: &Effect, d: &Diagnosis) -> (f64, f64) {
    let got = |k: &str| d.effects[0].parameters.get(k).copied().unwrap_or(f64::NAN);
    match e {
        Effect::NetBuoyancy { force_n } => (*force_n, got("force_n")),
        Effect::ThrusterLag { time_constant_s } => (*time_constant_s, got("time_constant_s")),
        Effect::ReverseThrustLoss { loss } => (*loss, got("loss")),
        Effect::ThrusterDeadband { force_n, .. } => (*force_n, got("force_n")),
        Effect::TetherDrag { coefficient, .. } => (*coefficient, got("coefficient")),
        Effect::WaterCurrent { velocity_m_s } => (velocity_m_s[0], got("current_x_m_s")),
        Effect::WallEffect { coefficient, decay_m } => (coefficient * decay_m, got("coefficient") * got("decay_m")),
        Effect::CoupledDrag { coefficient } => (*coefficient, got("coefficient")),
        Effect::SensorDelay { delay_s } => (*delay_s, got("delay_s")),
    }
}

#[test]
// `!(a < b)` is meant: a NaN must count as a failure.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn each_concealed_effect_is_named_first_with_its_parameter_and_the_held_out_error_drops() {
    // Magnitudes and a seed other than the shipped runs' (seed 1): the manoeuvres' random parts,
    // the sensor noise and biases all differ.
    let cases = [
        "net_buoyancy=-14",
        "thruster_lag=0.45",
        "reverse_thrust_loss=0.35",
        "thruster_deadband=10",
        "tether_drag=0.8",
        "water_current=-0.12",
        "wall_effect=220",
        "coupled_drag=80",
        "sensor_delay=0.3",
    ];
    let mut failures = Vec::new();
    for arg in cases {
        let e = Effect::from_arg(arg).unwrap();
        let d = scenario_diagnosis(std::slice::from_ref(&e), 2);
        let Some(first) = d.effects.first() else {
            failures.push(format!("{arg}: nothing named ({})", d.verdict));
            continue;
        };
        if first.name != e.name() {
            failures.push(format!("{arg}: named {} first", first.name));
            continue;
        }
        let (want, got) = main_parameter(&e, &d);
        // Wall drag trades its coefficient against its decay length: their product is what the runs pin down.
        let tol = if e.name() == "wall_effect" { 0.4 } else { 0.15 };
        if !((got - want).abs() <= tol * want.abs()) {
            failures.push(format!("{arg}: parameter {got} vs truth {want}"));
        }
        if !(first.validation_cost_after < 0.5 * first.validation_cost_before) {
            failures.push(format!("{arg}: held-out cost {} -> {}", first.validation_cost_before, first.validation_cost_after));
        }
        for dof in &first.dofs {
            if !(first.validation_nmae_after[dof] < first.validation_nmae_before[dof]) {
                failures.push(format!("{arg}: {dof} NMAE did not drop"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn nothing_is_claimed_on_effect_free_data() {
    // Seed 4's held-out run `mixed` holds a short burst no effect models: held-out gains from
    // tiny parameters there must not be claimed (the training runs do not corroborate them).
    for seed in [2, 3, 4] {
        let d = scenario_diagnosis(&[], seed);
        assert!(d.effects.is_empty(), "seed {seed}: {:?}\n{}", d.effects.iter().map(|e| &e.name).collect::<Vec<_>>(), d.verdict);
        assert!(d.verdict.starts_with("No missing physics") && !d.baseline.parameters_reestimated, "{}", d.verdict);
    }
}

#[test]
fn two_concealed_effects_are_both_named() {
    for (args, seed) in [(["thruster_lag=0.25", "water_current=0.1"], 3), (["net_buoyancy=8", "coupled_drag=70"], 4), (["water_current=0.12", "coupled_drag=60"], 2)] {
        // The last pair needs the swap step: neither effect alone fits, and tether drag stands in
        // for coupled drag in the first round.
        let effects: Vec<Effect> = args.iter().map(|a| Effect::from_arg(a).unwrap()).collect();
        let d = scenario_diagnosis(&effects, seed);
        let mut named: Vec<&str> = d.effects.iter().map(|e| e.name.as_str()).collect();
        named.sort();
        let mut want: Vec<&str> = effects.iter().map(|e| e.name()).collect();
        want.sort();
        assert_eq!(named, want, "{}", d.verdict);
        let last = d.effects.last().unwrap();
        assert!(last.validation_cost_after < 3.0 * d.baseline.noise_cost, "{}", d.verdict);
    }
}

#[test]
fn drifted_drag_is_reported_as_drift_not_as_an_effect() {
    // The CFD model's quadratic drag 35 % too low in every DOF, nothing left out of the runs.
    let mut plant = scenario::cfd_fit_plant(1).unwrap();
    for q in plant.hydro.quad.iter_mut() {
        *q *= 0.65;
    }
    let d = full(&scenario::fused_runs(&[], 5).unwrap(), &plant);
    assert!(d.baseline.validation_cost > 3.0 * d.baseline.noise_cost, "the drift must show: {}", d.verdict);
    assert!(d.baseline.parameters_reestimated && d.effects.is_empty(), "{}\n{:?}", d.verdict, d.effects.iter().map(|e| &e.name).collect::<Vec<_>>());
    let xuu = d.baseline.reestimated.parameters.iter().find(|p| p.name == "X_uu").unwrap().value;
    assert!((xuu + 44.17).abs() < 0.1 * 44.17, "X_uu re-estimated {xuu}");
}

#[test]
fn a_residual_no_effect_explains_is_unexplained_not_named() {
    // A slow oscillation in the recorded surge velocity (a seiche, a sensor artefact): nothing
    // in the table makes velocity oscillate with no command behind it.
    let mut fused = scenario::fused_runs(&[], 6).unwrap();
    for r in &mut fused {
        let t = r.fused.t.clone();
        if let Some(v) = r.fused.vel[0].as_mut() {
            for (x, t) in v.iter_mut().zip(&t) {
                *x += 0.1 * (2.0 * std::f64::consts::PI * t / 17.0).sin();
            }
        }
    }
    let d = full(&fused, &scenario::cfd_fit_plant(1).unwrap());
    let names: Vec<&str> = d.effects.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(names.last(), Some(&"unexplained"), "{names:?}\n{}", d.verdict);
    assert!(d.effects.last().unwrap().dofs.contains(&crate::dof::Dof::Surge));
}

/// Prints every hypothesis of every round for one scenario, for working on the search:
/// `EFFECTS=thruster_lag=0.3,tether_drag=1 SEED=2 cargo test --release experiment -- --ignored --nocapture`
/// (`PER_RUN=1` adds each run's cost and largest residual under the selected effects).
#[test]
#[ignore]
fn experiment() {
    let list: Vec<Vec<Effect>> = match std::env::var("EFFECTS") {
        Ok(v) if v == "none" => vec![vec![]],
        Ok(v) => vec![v.split(',').map(|a| Effect::from_arg(a).unwrap()).collect()],
        Err(_) => vec![vec![]],
    };
    let seed: u64 = std::env::var("SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
    for effects in list {
        let t = std::time::Instant::now();
        let (s, data) = run_scenario(&effects, seed);
        eprintln!("truth {:?} seed {seed}: noise {:.5} costs {:?} ({:.1} s)", effects, data.noise_cost, s.costs, t.elapsed().as_secs_f64());
        for r in &s.tested {
            eprintln!("  r{} {:20} gain {:+.3} score {:+.3} val {:.5} train {:.5} {:?}{}", r.round, r.name, r.gain, r.score, r.validation_cost, r.train_cost, r.parameters, if r.accepted { "  <== kept" } else { "" });
        }
        for (h, p) in &s.selected {
            eprintln!("  selected {} {:?}", h.name, p);
        }
        if std::env::var("PER_RUN").is_ok() {
            let (plant, aug) = (scenario::cfd_fit_plant(1).unwrap(), augmentation(&s.selected));
            for r in data.train.iter().chain(&data.validate) {
                let sim = simulate(&plant, &aug, r);
                let sm = sums(&sim, r, 0.0);
                eprintln!("  run {:12} validate {} cost {:.5} nmae {:?}", r.name, data.validate.iter().any(|v| v.name == r.name), sm.cost(&data.scale), sm.nmae().map(|x| (x * 1000.0).round() / 1000.0));
                for (j, e) in residual(&sim, r, 0.0).iter().enumerate() {
                    let (k, m) = e.iter().enumerate().fold((0, 0.0f64), |b, (k, v)| if v.abs() > b.1 { (k, v.abs()) } else { b });
                    let rms = (e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64).sqrt();
                    eprintln!("     dof {j}: max |res| {m:.4} at sample {k} of {}, rms {rms:.4}, std there {:.4}", e.len(), r.std[j].get(k).copied().unwrap_or(f64::NAN));
                }
            }
        }
    }
}
