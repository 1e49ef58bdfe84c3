//! The run that tells two look-alike effects apart. When the diagnosis keeps an effect and
//! lists another that fits the held-out runs within their noise (a thruster lag and a late
//! velocity log), the design flies each candidate twice on paper, the model with the one and
//! with the other (the other effects found kept in both), and scores how far the two predicted
//! recordings differ: the normalised mean square difference over the DOFs, as a multiple of
//! the noise floor the diagnosis compares held-out costs with. A run on which that multiple
//! is above the diagnosis's own margin is one its held-out cost can decide on. An effect the
//! diagnosis lists as possibly beside a named one (fitted together with it, a gain too small
//! to name) makes a pair too: the named effects alone against the named effects at their joint
//! fit with it beside them.

use crate::core::model::Plant;
use crate::diagnose::result::{Diagnosis, Found};
use crate::diagnose::{self, Run, SLOTS, Selection};

/// Two effects the diagnosis could not tell apart, each with the other effects it kept; or a
/// named effect alone against it with an effect possibly beside it (`beside`).
pub struct Pair {
    pub kept: String,
    /// The look-alike, or for an effect possibly beside `kept`, "kept with it beside it".
    pub alike: String,
    /// The effect possibly beside `kept`, when that is the question.
    pub beside: Option<String>,
    with_kept: Selection,
    with_alike: Selection,
}

/// The recorded runs' scale of each DOF (mean square velocity) and noise (mean variance of
/// the fused velocity), as the diagnosis normalises its costs.
#[derive(Debug, Clone, Copy)]
pub struct Noise {
    pub scale: [f64; SLOTS],
    pub variance: [f64; SLOTS],
}

impl Noise {
    pub fn of(runs: &[Run]) -> Noise {
        let mean = |f: &dyn Fn(&Run) -> &Vec<f64>| {
            let (s, n) = runs.iter().fold((0.0, 0.0), |(s, n), r| {
                let v = f(r);
                (s + v.iter().map(|x| x * x).sum::<f64>(), n + v.len() as f64)
            });
            s / n.max(1.0)
        };
        Noise {
            scale: std::array::from_fn(|j| mean(&|r: &Run| &r.vel[j]).max(1e-12)),
            variance: diagnose::noise_per_dof(runs, &[1.0; SLOTS]),
        }
    }

    /// The noise floor of the normalised cost.
    pub fn floor(&self) -> f64 {
        (0..SLOTS).map(|j| self.variance[j] / self.scale[j]).sum()
    }
}

/// The effects a found effect's parameters name, as a selection.
fn selection(found: &[(&str, &std::collections::BTreeMap<String, f64>)]) -> Option<Selection> {
    found
        .iter()
        .map(|(name, params)| {
            let h = diagnose::hypothesis(name)?;
            let p = h
                .params
                .iter()
                .map(|q| params.get(q.name).copied())
                .collect::<Option<Vec<f64>>>()?;
            Some((h, p))
        })
        .collect()
}

/// Whether a found effect is one of the table's, with its parameters (not a discovered closed
/// form in an effect's form, not the unexplained residual).
pub fn named(f: &Found) -> bool {
    selection(&[(f.name.as_str(), &f.parameters)]).is_some()
}

impl Pair {
    /// Every look-alike pair of a diagnosis, then every effect possibly beside a named one
    /// (effects it cannot rebuild are left out).
    pub fn of(d: &Diagnosis) -> Vec<Pair> {
        let mut out = Pair::alike(&d.effects);
        out.extend(Pair::beside(&d.effects));
        out
    }

    /// Each effect possibly beside a named one: the named effects as found, against the same
    /// at their parameters in the joint fit with it and it beside them.
    fn beside(effects: &[Found]) -> Vec<Pair> {
        let named: Vec<&Found> = effects.iter().filter(|f| named(f)).collect();
        let mut out = Vec::new();
        for f in &named {
            for b in &f.possibly_beside {
                let found: Vec<_> = (named.iter())
                    .map(|o| (o.name.as_str(), &o.parameters))
                    .collect();
                let joint: Vec<_> = (named.iter())
                    .map(|o| {
                        let p = b.beside_parameters.get(&o.name).unwrap_or(&o.parameters);
                        (o.name.as_str(), p)
                    })
                    .chain([(b.name.as_str(), &b.parameters)])
                    .collect();
                if let (Some(with_kept), Some(with_alike)) = (selection(&found), selection(&joint))
                {
                    out.push(Pair {
                        kept: f.name.clone(),
                        alike: format!("{} with {} beside it", f.name, b.name),
                        beside: Some(b.name.clone()),
                        with_kept,
                        with_alike,
                    });
                }
            }
        }
        out
    }

    /// Every look-alike pair among `effects`.
    fn alike(effects: &[Found]) -> Vec<Pair> {
        let mut out = Vec::new();
        for (i, f) in effects.iter().enumerate() {
            for a in &f.alike {
                // The other effects found are kept in both; a discovered closed form or an
                // unexplained residual cannot be rebuilt as an effect, and is left out of both.
                let others = effects
                    .iter()
                    .enumerate()
                    .filter(|(k, o)| {
                        *k != i && selection(&[(o.name.as_str(), &o.parameters)]).is_some()
                    })
                    .map(|(_, o)| (o.name.as_str(), &o.parameters));
                let kept: Vec<_> = others
                    .clone()
                    .chain([(f.name.as_str(), &f.parameters)])
                    .collect();
                let alike: Vec<_> = others.chain([(a.name.as_str(), &a.parameters)]).collect();
                if let (Some(with_kept), Some(with_alike)) = (selection(&kept), selection(&alike)) {
                    out.push(Pair {
                        kept: f.name.clone(),
                        alike: a.name.clone(),
                        beside: None,
                        with_kept,
                        with_alike,
                    });
                }
            }
        }
        out
    }

    /// How far the recordings predicted with either effect differ on `run`, in multiples of
    /// the noise floor.
    pub fn separation(&self, plant: &Plant, run: &Run, noise: &Noise) -> f64 {
        let predict = |sel: &Selection| {
            let aug = diagnose::augmentation(sel);
            diagnose::residual(&diagnose::simulate(plant, &aug, run), run, aug.delay_s)
        };
        let (a, b) = (predict(&self.with_kept), predict(&self.with_alike));
        let cost: f64 = (0..SLOTS)
            .map(|j| {
                let (s, n) = a[j]
                    .iter()
                    .zip(&b[j])
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .fold((0.0f64, 0.0f64), |(s, n), (x, y)| {
                        (s + (x - y).powi(2), n + 1.0)
                    });
                s / n.max(1.0) / noise.scale[j]
            })
            .sum();
        cost / noise.floor().max(1e-12)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::model::{Hydro, Vehicle};

    /// A run of the reference vehicle under `cmd(t)` at 20 Hz, its velocities simulated.
    fn run(plant: &Plant, cmd: impl Fn(f64) -> [f64; 4]) -> Run {
        let t: Vec<f64> = (0..1200).map(|k| k as f64 * 0.05).collect();
        let c: Vec<[f64; 4]> = t.iter().map(|&x| cmd(x)).collect();
        let tau: Vec<[f64; 6]> = c
            .iter()
            .map(|c| [c[0], c[1], c[2], 0.0, 0.0, c[3]])
            .collect();
        let nu = plant.simulate(&t, &tau, [0.0; 6], 0.01);
        let col = |i: usize| nu.iter().map(|v| v[i]).collect::<Vec<f64>>();
        Run {
            name: "r".into(),
            validate: true,
            slots: diagnose::Slots::POOL,
            cmd: tau,
            vel: std::array::from_fn(col),
            std: std::array::from_fn(|_| vec![0.01; t.len()]),
            noise_share: [1.0; SLOTS],
            pos: std::array::from_fn(|_| vec![1.0; t.len()]),
            psi: vec![0.0; t.len()],
            t,
            pool: None,
            anchor: None,
            dead_reckoned: false,
            att: Default::default(),
            anchors_s: Vec::new(),
        }
    }

    /// A 20 s square wave of surge force: slow enough that a lag and a delay look alike.
    fn slow_steps(plant: &Plant) -> Run {
        run(plant, |t| {
            let s = if (t / 20.0).fract() < 0.5 { 1.0 } else { -1.0 };
            [40.0 * s, 0.0, 0.0, 0.0]
        })
    }

    /// Sines at 0.6-1.1 Hz in surge, sway and yaw: fast enough to tell them apart.
    fn fast_sines(plant: &Plant) -> Run {
        run(plant, |t| {
            let w = 2.0 * std::f64::consts::PI;
            [
                40.0 * (0.8 * w * t).sin(),
                30.0 * (1.1 * w * t).sin(),
                0.0,
                3.0 * (0.6 * w * t).sin(),
            ]
        })
    }

    /// A lag of the thrust and a delay of the log are alike on slow steps and apart on a fast
    /// command: the criterion sees it, and the pair's order does not matter.
    #[test]
    fn fast_commands_tell_a_thruster_lag_from_a_sensor_delay_and_slow_steps_do_not() {
        let plant = Plant::new(&Vehicle::reference(), Hydro::reference());
        let sel = |name: &str, p: f64| -> Selection {
            vec![(diagnose::hypothesis(name).unwrap(), vec![p])]
        };
        let pair = Pair {
            kept: "thruster_lag".into(),
            alike: "sensor_delay".into(),
            beside: None,
            with_kept: sel("thruster_lag", 0.3),
            with_alike: sel("sensor_delay", 0.3),
        };
        let slow = slow_steps(&plant);
        let fast = fast_sines(&plant);
        let noise = Noise::of(std::slice::from_ref(&slow));
        let (a, b) = (
            pair.separation(&plant, &slow, &noise),
            pair.separation(&plant, &fast, &noise),
        );
        assert!(a.is_finite() && b > 5.0 * a, "slow {a}, fast {b}");
        let swapped = Pair {
            kept: pair.alike.clone(),
            alike: pair.kept.clone(),
            beside: None,
            with_kept: pair.with_alike.clone(),
            with_alike: pair.with_kept.clone(),
        };
        assert!((swapped.separation(&plant, &fast, &noise) - b).abs() < 1e-9 * b);
    }

    /// An effect the diagnosis lists as possibly beside a named one makes a pair: the named
    /// effect as found against the same at its joint fit with the other beside it (a 0.35 s
    /// delay found as 0.46 s filtered at 0.27 s, jointly 0.34 s at 0.20 s with a 0.15 s
    /// lag). A fast command tells the two apart by more than the diagnosis's margin.
    #[test]
    fn an_effect_possibly_beside_a_named_one_is_a_pair_to_tell_apart() {
        use crate::diagnose::result::PossiblyBeside;
        use std::collections::BTreeMap;
        let m = |kv: &[(&str, f64)]| -> BTreeMap<String, f64> {
            kv.iter().map(|(k, v)| (k.to_string(), *v)).collect()
        };
        let lag = PossiblyBeside {
            name: "thruster_lag".into(),
            parameters: m(&[("time_constant_s", 0.15), ("thrust_law_exponent", 2.0)]),
            beside_parameters: [(
                "sensor_delay".to_string(),
                m(&[("delay_s", 0.34), ("filter_s", 0.20)]),
            )]
            .into(),
            validation_cost_without: 0.0067,
            validation_cost_with: 0.0050,
        };
        let delay = Found {
            name: "sensor_delay".into(),
            dofs: vec![],
            parameters: m(&[("delay_s", 0.46), ("filter_s", 0.27)]),
            evidence: String::new(),
            validation_nmae_before: BTreeMap::new(),
            validation_nmae_after: BTreeMap::new(),
            validation_cost_before: 0.0,
            validation_cost_after: 0.0,
            alike: vec![],
            possibly_beside: vec![lag],
            candidate: None,
        };
        let pairs = Pair::beside(std::slice::from_ref(&delay));
        assert_eq!(pairs.len(), 1);
        let p = &pairs[0];
        assert_eq!(p.beside.as_deref(), Some("thruster_lag"));
        let names = |s: &Selection| s.iter().map(|(h, _)| h.name).collect::<Vec<_>>();
        assert_eq!(names(&p.with_kept), ["sensor_delay"]);
        assert_eq!(names(&p.with_alike), ["sensor_delay", "thruster_lag"]);
        assert_eq!(p.with_kept[0].1, [0.46, 0.27]);
        assert_eq!(p.with_alike[0].1, [0.34, 0.20]);
        let plant = Plant::new(&Vehicle::reference(), Hydro::reference());
        let fast = fast_sines(&plant);
        // The noise floor as recorded runs would set it: slow steps.
        let slow = slow_steps(&plant);
        let noise = Noise::of(std::slice::from_ref(&slow));
        let apart = p.separation(&plant, &fast, &noise);
        assert!(apart.is_finite() && apart > 0.5, "{apart} noise floors");
    }
}
