use super::*;
use crate::cmd::scenario;
use crate::diagnose::{Diagnosis, diagnose};
use crate::twin::world::Effect;

mod attitude;
mod discovery;
mod drift;
mod forms;
mod guards;
mod joint;
mod lag;
mod nav_only;
mod piloted;
mod size;
use piloted::piloted_fast_runs;

fn run_scenario(effects: &[Effect], seed: u64) -> (Search, Data) {
    let runs = scenario::runs(effects, seed).unwrap();
    let data = Data::new(runs).unwrap();
    let plant = scenario::cfd_fit_plant(1).unwrap();
    let s = select(&plant, &data, &Criteria::default(), &|_| {});
    (s, data)
}

/// The full diagnosis of a generated scenario, against the CFD fit of the twin's STAR-CCM+ cases.
fn full(
    fused: &[crate::pool::fusion::run::FusedRun],
    plant: &crate::core::model::Plant,
) -> Diagnosis {
    full_of(&crate::core::model::Vehicle::reference(), fused, plant)
}

/// The full diagnosis of `vehicle`'s `fused` runs from its model `plant`, its verdict's words
/// checked against its numbers.
fn full_of(
    vehicle: &crate::core::model::Vehicle,
    fused: &[crate::pool::fusion::run::FusedRun],
    plant: &crate::core::model::Plant,
) -> Diagnosis {
    let d = diagnose(vehicle, "fit", plant, fused, &Criteria::default(), &|_| {})
        .unwrap()
        .0;
    words_agree_with_numbers(&d);
    d
}

/// The verdict's words agree with its numbers (every scenario's diagnosis passes here): "no
/// missing physics" only within the stated multiple of the noise floor and with nothing
/// found; every effect found, dropped or left unexplained is said.
fn words_agree_with_numbers(d: &Diagnosis) {
    let v = &d.verdict;
    let (cost, noise) = (d.baseline.validation_cost, d.baseline.noise_cost);
    if v.starts_with("No missing physics:") {
        assert!(
            cost <= d.criteria.within_noise * noise && d.effects.is_empty(),
            "{v}\ncost {cost} noise {noise}"
        );
        assert!(
            v.contains(&format!("{:.1} times the noise floor", cost / noise)),
            "{v}"
        );
    }
    for e in &d.effects {
        if e.name == "unexplained" {
            assert!(
                v.contains("unexplained") || v.contains("does not explain"),
                "{v}"
            );
            // Within the noise floor pooled, a structured DOF decided it: the verdict says
            // which, with figures at or above the multiples that count as structure.
            if e.validation_cost_before <= d.criteria.within_noise * noise {
                assert!(
                    v.contains("times its noise"),
                    "{v}
cost {cost} noise {noise}"
                );
            }
            for (multiple, why) in structured_figures(v) {
                let floor = if why.starts_with("with a line") {
                    super::unexplained::LINE_NOISE_MULTIPLE
                } else {
                    d.criteria.unexplained_noise_multiple
                };
                assert!(multiple > floor, "{v}");
            }
        } else {
            assert!(v.contains(&e.name), "{} not in: {v}", e.name);
        }
    }
    for dropped in &d.dropped {
        assert!(v.contains(dropped.as_str()), "{v}");
    }
}

/// Each "X times its noise, <why>" the verdict `v` quotes for a structured DOF.
fn structured_figures(v: &str) -> Vec<(f64, &str)> {
    v.match_indices(" times its noise, ")
        .map(|(i, m)| {
            let number = v[..i].rsplit(' ').next().unwrap();
            (number.parse().unwrap(), &v[i + m.len()..])
        })
        .collect()
}

/// The effects diagnosis `d` names, `unexplained` left out.
fn named(d: &Diagnosis) -> Vec<&str> {
    d.effects
        .iter()
        .map(|e| e.name.as_str())
        .filter(|n| *n != "unexplained")
        .collect()
}

/// Asserts that diagnosis `d` of a scenario with `e` concealed reports a structured residual,
/// never "no missing physics".
fn assert_reported(d: &Diagnosis, e: &Effect, seed: u64) {
    let ratio = d.baseline.validation_cost / d.baseline.noise_cost;
    assert!(
        !d.verdict.starts_with("No missing physics")
            && d.effects.iter().any(|x| x.name == "unexplained"),
        "{e:?} seed {seed} (cost {ratio:.1} times the noise floor): {}",
        d.verdict
    );
}

fn scenario_diagnosis(effects: &[Effect], seed: u64) -> Diagnosis {
    full(
        &scenario::fused_runs(effects, seed).unwrap(),
        &scenario::cfd_fit_plant(1).unwrap(),
    )
}

/// The effect's defining parameter as the diagnosis's own form expresses it, the range that the
/// twin's form (`crate::twin::world`, written apart) implies for it, and the diagnosis's value.
fn main_parameter(e: &Effect, d: &Diagnosis) -> (f64, [f64; 2], f64) {
    let got = |k: &str| d.effects[0].parameters.get(k).copied().unwrap_or(f64::NAN);
    let around = |x: f64, tol: f64| [x * (1.0 - tol), x * (1.0 + tol)];
    match e {
        // Same physics in both: a constant force.
        Effect::NetBuoyancy { force_n } => (*force_n, around(*force_n, 0.15), got("force_n")),
        // Thrust quadratic in a lagged motor speed, or the force itself lagged: the two ends of
        // the lag's thrust law, each timed at its own time constant (fitted as a force lag, the
        // motor's came out 20-25 % long).
        Effect::ThrusterLag { time_constant_s: t } | Effect::ForceLag { time_constant_s: t } => {
            (*t, around(*t, 0.1), got("time_constant_s"))
        }
        // The fade spans +-2 N of commands that reach tens of newtons.
        Effect::ReverseThrustLoss { loss } => (*loss, around(*loss, 0.2), got("loss")),
        // A dead zone with a rounded knee, fitted with a sharp one.
        Effect::ThrusterDeadband { force_n, .. } => {
            (*force_n, around(*force_n, 0.2), got("force_n"))
        }
        // Cable paid out vs straight-line distance plus slack: coefficient and slack trade
        // along a ridge, so what compares is the drag per unit |v| v where the runs go, 11 m
        // from the anchor at 1.5 m depth.
        Effect::TetherDrag {
            coefficient,
            slack_m,
        } => {
            let want = coefficient * (11.0 + 1.5 + slack_m);
            (
                want,
                around(want, 0.25),
                got("coefficient") * (11.0f64.hypot(1.5) + got("slack_m")),
            )
        }
        // +-30 % along the pool, averaging out over where the runs go.
        Effect::WaterCurrent { velocity_m_s } => {
            let v = velocity_m_s[0];
            (
                v,
                [v - 0.25 * v.abs(), v + 0.25 * v.abs()],
                got("current_x_m_s"),
            )
        }
        // Algebraic vs exponential fall-off: compared as the drag coefficient at the distances
        // the runs spend near a wall (2 m).
        Effect::WallEffect {
            coefficient,
            decay_m,
        } => {
            let want = coefficient / (1.0 + (2.0 / decay_m).powi(2));
            (
                want,
                around(want, 0.5),
                got("coefficient") * (-2.0 / got("decay_m")).exp(),
            )
        }
        // c (|V| - |u|) u against c' |v| u: equal at |u| = |v| for c' = (sqrt 2 - 1) c, and
        // smaller where one speed dominates, so c' lies in (0, 0.42 c].
        Effect::CoupledDrag { coefficient: c } => (*c, [0.1 * c, 0.5 * c], got("coefficient")),
        // A delay and a low-pass in both, but a smooth run tells only their sum: the total
        // latency.
        Effect::SensorDelay { delay_s, filter_s } => {
            let total = delay_s + filter_s;
            let latency = d.effects[0].lateness_s().unwrap_or(f64::NAN);
            (total, around(total, 0.25), latency)
        }
        // Outside the vocabulary: no named parameter (see `tests/discovery.rs` and `tests/forms.rs`).
        Effect::Wave { .. }
        | Effect::SkewedThruster { .. }
        | Effect::SurfaceDrag { .. }
        | Effect::TetherTorsion { .. }
        | Effect::BatterySag { .. }
        | Effect::ThrustSaturation { .. }
        | Effect::AsymmetricDrag { .. }
        | Effect::InflowLoss { .. }
        | Effect::MunkMoment { .. }
        | Effect::DepthBuoyancy { .. }
        | Effect::ForwardLift { .. }
        | Effect::YawBias { .. }
        | Effect::TetherSpring { .. }
        | Effect::CrossflowLoss { .. } => (f64::NAN, [f64::NAN; 2], f64::NAN),
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
        // A named effect the table holds leaves nothing for discovery to propose.
        if let Some(c) = d.effects.iter().find_map(|x| x.candidate.as_ref()) {
            failures.push(format!("{arg}: discovery proposed {}", c.expression));
        }
        let (truth, [lo, hi], got) = main_parameter(&e, &d);
        if !(lo.min(hi) <= got && got <= hi.max(lo)) {
            failures.push(format!(
                "{arg}: parameter {got} outside [{lo}, {hi}] implied by the twin's {truth}"
            ));
        }
        if !(first.validation_cost_after < 0.5 * first.validation_cost_before) {
            failures.push(format!(
                "{arg}: held-out cost {} -> {}",
                first.validation_cost_before, first.validation_cost_after
            ));
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
        assert!(
            d.effects.is_empty(),
            "seed {seed}: {:?}\n{}",
            d.effects.iter().map(|e| &e.name).collect::<Vec<_>>(),
            d.verdict
        );
        assert!(
            d.verdict.starts_with("No missing physics") && !d.baseline.parameters_reestimated,
            "{}",
            d.verdict
        );
    }
}

#[test]
fn two_concealed_effects_are_both_named() {
    for (args, seed) in [
        (["thruster_lag=0.25", "water_current=0.1"], 3),
        (["net_buoyancy=8", "coupled_drag=70"], 4),
        (["water_current=0.12", "coupled_drag=60"], 2),
    ] {
        // The last pair needs the swap step: neither effect alone fits, and tether drag stands in
        // for coupled drag in the first round.
        // The twin's forms are not the diagnosis's: what they leave may be reported as
        // `unexplained`, but no other effect may be named, and the two must explain the bulk.
        let effects: Vec<Effect> = args.iter().map(|a| Effect::from_arg(a).unwrap()).collect();
        let d = scenario_diagnosis(&effects, seed);
        let mut named: Vec<&str> = d
            .effects
            .iter()
            .map(|e| e.name.as_str())
            .filter(|n| *n != "unexplained")
            .collect();
        named.sort();
        let mut want: Vec<&str> = effects.iter().map(|e| e.name()).collect();
        want.sort();
        assert_eq!(named, want, "{}", d.verdict);
        let last = d.effects.iter().rfind(|e| e.name != "unexplained").unwrap();
        assert!(
            last.validation_cost_after < 0.1 * d.baseline.validation_cost,
            "{}",
            d.verdict
        );
    }
}

#[test]
fn drifted_drag_is_reported_as_drift_not_as_an_effect() {
    // The CFD model's quadratic drag 35 % too low in every DOF, nothing left out of the runs.
    let mut h = scenario::cfd_fit_plant(1).unwrap().hydro;
    for i in 0..6 {
        h.quad[i][i][i] *= 0.65;
    }
    let plant = crate::core::model::Plant::new(&crate::core::model::Vehicle::reference(), h);
    let d = full(&scenario::fused_runs(&[], 5).unwrap(), &plant);
    assert!(
        d.baseline.validation_cost > 3.0 * d.baseline.noise_cost,
        "the drift must show: {}",
        d.verdict
    );
    assert!(
        d.baseline.parameters_reestimated && d.effects.is_empty(),
        "{}\n{:?}",
        d.verdict,
        d.effects.iter().map(|e| &e.name).collect::<Vec<_>>()
    );
    let xuu = d
        .baseline
        .reestimated
        .parameters
        .iter()
        .find(|p| p.name == "X_uu")
        .unwrap()
        .value;
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
    assert_eq!(
        names,
        ["unexplained"],
        "effect-free runs with an out-of-vocabulary disturbance\n{}",
        d.verdict
    );
    assert!(
        d.effects
            .last()
            .unwrap()
            .dofs
            .contains(&crate::core::dof::Dof::Surge)
    );
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
    let seed: u64 = std::env::var("SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    for effects in list {
        let t = std::time::Instant::now();
        let (s, data) = run_scenario(&effects, seed);
        eprintln!(
            "truth {:?} seed {seed}: noise {:.5} costs {:?} ({:.1} s)",
            effects,
            data.noise_cost,
            s.costs,
            t.elapsed().as_secs_f64()
        );
        for r in &s.tested {
            eprintln!(
                "  r{} {:20} gain {:+.3} score {:+.3} val {:.5} train {:.5} {:?}{}",
                r.round,
                r.name,
                r.gain,
                r.score,
                r.validation_cost,
                r.train_cost,
                r.parameters,
                if r.accepted { "  <== kept" } else { "" }
            );
        }
        for (h, p) in &s.selected {
            eprintln!("  selected {} {:?}", h.name, p);
        }
        if std::env::var("FULL").is_ok() {
            let d = scenario_diagnosis(&effects, seed);
            eprintln!("  verdict: {}", d.verdict);
            for e in &d.effects {
                eprintln!(
                    "  found {} {:?} alike {:?}",
                    e.name,
                    e.parameters,
                    e.alike
                        .iter()
                        .map(|a| (&a.name, a.validation_cost))
                        .collect::<Vec<_>>()
                );
            }
        }
        if std::env::var("PER_RUN").is_ok() {
            let (plant, aug) = (
                scenario::cfd_fit_plant(1).unwrap(),
                augmentation(&s.selected),
            );
            for r in data.train.iter().chain(&data.validate) {
                let sim = simulate(&plant, &aug, r);
                let sm = sums(&sim, r, 0.0, &[f64::INFINITY; SLOTS]);
                eprintln!(
                    "  run {:12} validate {} cost {:.5} nmae {:?}",
                    r.name,
                    data.validate.iter().any(|v| v.name == r.name),
                    sm.cost(&data.scale),
                    sm.nmae().map(|x| (x * 1000.0).round() / 1000.0)
                );
                for (j, e) in residual(&sim, r, 0.0).iter().enumerate() {
                    let (k, m) = e.iter().enumerate().fold((0, 0.0f64), |b, (k, v)| {
                        if v.abs() > b.1 { (k, v.abs()) } else { b }
                    });
                    let rms = (e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64).sqrt();
                    eprintln!(
                        "     dof {j}: max |res| {m:.4} at sample {k} of {}, rms {rms:.4}, std there {:.4}",
                        e.len(),
                        r.std[j].get(k).copied().unwrap_or(f64::NAN)
                    );
                }
            }
        }
    }
}

/// The DOFs a diagnosis compares: the six slots, each on only where the model moves (a
/// six-DOF model in all six, its roll and pitch rates scored).
#[test]
fn a_model_is_compared_in_the_dofs_it_moves_in() {
    use crate::core::dof::Dof::*;
    let slots = |dofs: &[crate::core::dof::Dof]| {
        let mut v = crate::core::model::Vehicle::reference();
        v.dofs = dofs.to_vec();
        Slots::of(&Plant::new(&v, crate::core::model::Hydro::reference()))
    };
    // Six DOF: compared in all six, roll and pitch too.
    let all = slots(&[Surge, Sway, Heave, Roll, Pitch, Yaw]).unwrap();
    assert_eq!(all.active, [true; SLOTS]);
    // Slot j is the DOF of index j: per-slot arrays and body vectors are the same.
    assert!((0..SLOTS).all(|j| all.dof(j).index() == j));
    assert_eq!(all.slot(Roll), Some(3));
    let pool = slots(&[Surge, Sway, Heave, Yaw]).unwrap();
    assert_eq!(pool, Slots::POOL);
    assert_eq!(pool.slot(Roll), None);
    let rot = slots(&[Roll, Pitch, Yaw]).unwrap();
    assert_eq!(rot.active, [false, false, false, true, true, true]);
    assert_eq!(rot.slot(Heave), None);
    assert_eq!(rot.slot(Pitch), Some(4));
    assert_eq!(rot.nu_all(), [0, 1, 2, 3, 4, 5]);
    let with_heave = slots(&[Heave, Roll, Pitch, Yaw]).unwrap();
    assert_eq!(with_heave.active, [false, false, true, true, true, true]);
    let surge_yaw = slots(&[Surge, Yaw]).unwrap();
    assert_eq!(surge_yaw.active, [true, false, false, false, false, true]);
    // A run with u, w and r fused but no body rates lacks roll and pitch for the rotational
    // model, nothing for the one in surge and yaw.
    let n = 10;
    let some = || Some(vec![0.0; n]);
    let fused = crate::pool::fusion::Fused {
        t: (0..n).map(|k| k as f64 * 0.1).collect(),
        vel: [some(), None, some(), some()],
        std: [some(), None, some(), some()],
        x: vec![f64::NAN; n],
        y: vec![f64::NAN; n],
        z: vec![0.0; n],
        psi: vec![0.0; n],
        roll_pitch: Default::default(),
        tracked: Default::default(),
        stats: Default::default(),
    };
    assert_eq!(rot.missing(&fused), [Roll, Pitch]);
    assert!(surge_yaw.missing(&fused).is_empty());
    assert!(all.missing(&fused).contains(&Roll));
    assert!(Run::from_parts("r", false, vec![[0.0; SLOTS]; n], &fused, rot).is_none());
    assert!(Run::from_parts("r", false, vec![[0.0; SLOTS]; n], &fused, surge_yaw).is_some());
}
