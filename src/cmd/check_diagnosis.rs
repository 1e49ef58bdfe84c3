//! `hydrofit twin check-diagnosis`: the diagnosis on scenarios the pool twin conceals effects
//! in, with the confusion table of concealed against named effects.

use crate::diagnose::result::Diagnosis;
use crate::twin::world::{Effect, NAMES, OUTSIDE};
use std::process::ExitCode;
use std::time::Instant;

/// `hydrofit twin check-diagnosis`: the diagnosis on generated scenarios, for each seed: those
/// `given` (each `name=magnitude` effects, `,`-separated, concealed together), or else each
/// effect of the table alone at two magnitudes, pairs of effects, and nothing; prints every
/// verdict and the confusion table (concealed vs named). An effect outside the table is right
/// when it is reported `unexplained` (and the table's concealed beside it named).
pub fn check_diagnosis(
    seeds: &[u64],
    navigation_log: bool,
    given: &[String],
    vehicle: &str,
) -> anyhow::Result<ExitCode> {
    use crate::cmd::scenario;
    use crate::twin::pool::{Craft, Logs};
    let craft = Craft::named(vehicle).map_err(anyhow::Error::msg)?;
    let scenarios = if given.is_empty() {
        diagnosis_scenarios(craft.force_scale())?
    } else {
        given_scenarios(given)?
    };
    // The reference vehicle starts from its twin CFD cases' fit; another, with no CFD twin,
    // from its true coefficients moved as much as such a fit is off.
    let plant = if vehicle == "reference" {
        scenario::cfd_fit_plant(1)?
    } else {
        scenario::cfd_plant_of(&craft)
    };
    let vehicle = craft.vehicle.clone();
    let logs = if navigation_log {
        Logs::Navigation
    } else {
        Logs::Sensors
    };
    let mut tally = Tally::new(&scenarios);
    for &seed in seeds {
        for effects in &scenarios {
            let fused = scenario::fused_runs_of(&craft, effects, seed, logs)?;
            let t = Instant::now();
            let (d, _) = crate::diagnose::diagnose(
                &vehicle,
                "fit",
                &plant,
                &fused,
                &Default::default(),
                &|_| {},
            )?;
            tally.worst_s = tally.worst_s.max(t.elapsed().as_secs_f64());
            let truth: Vec<&str> = effects.iter().map(|e| e.name()).collect();
            let named: Vec<&str> = d
                .effects
                .iter()
                .filter(|e| !(navigation_log && logs_own_lateness(e, &truth)))
                .map(|e| e.name.as_str())
                .collect();
            let ok = tally.count(&truth, &named);
            print_verdict(seed, effects, &d, ok, t);
            // The verdict's words, for reading why a scenario went as it did.
            if let Some(v) = std::env::var_os("HYDROFIT_CHECK_VERDICT") {
                print_details(&d, v == "tested");
            }
        }
    }
    tally.print();
    Ok(if tally.right == tally.total {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The verdict, the sentences of the effects dropped and, with `tested`, every hypothesis
/// each round tried (`HYDROFIT_CHECK_VERDICT=1` or `=tested`).
fn print_details(d: &Diagnosis, tested: bool) {
    println!("  verdict: {}", d.verdict);
    for why in &d.dropped {
        println!("  dropped: {why}");
    }
    if !tested {
        return;
    }
    for h in &d.hypotheses {
        println!(
            "  tested: round {} {} {:?} held-out {:.4} gain {:.3} score {:.3}{}{}",
            h.round,
            h.name,
            h.parameters,
            h.validation_cost,
            h.gain,
            h.score,
            if h.accepted { " accepted" } else { "" },
            if h.at_bound.is_empty() {
                String::new()
            } else {
                format!(" at bound {:?}", h.at_bound)
            }
        );
    }
}

/// Whether named effect `e` is a navigation log's own lateness rather than a finding: each
/// row carries the DVL's last ping (8 Hz, up to 125 ms old), which the diagnosis sees as a
/// thruster lag or a sensor delay no longer than one ping period. Only when neither is
/// concealed (`truth`).
fn logs_own_lateness(e: &crate::diagnose::result::Found, truth: &[&str]) -> bool {
    let concealed = truth.contains(&"thruster_lag") || truth.contains(&"sensor_delay");
    !concealed
        && e.lateness_s()
            .is_some_and(|t| t <= crate::twin::pool::NAV_DVL_PERIOD_S)
}

/// The scenarios `--scenario` gives: each `name=magnitude` effects, `,`-separated.
fn given_scenarios(given: &[String]) -> anyhow::Result<Vec<Vec<Effect>>> {
    given
        .iter()
        .map(|s| {
            (s.split(',')
                .filter(|a| !a.trim().is_empty() && a.trim() != "none"))
            .map(|a| Effect::from_arg(a.trim()))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| anyhow::anyhow!("--scenario {s}: {e}"))
        })
        .collect()
}

/// The check's scenarios: nothing concealed, each effect alone at two magnitudes, then pairs.
/// The check's set, its force-like magnitudes (a force, a drag coefficient) times `force`
/// for a vehicle other than the reference ([`crate::twin::pool::Craft::force_scale`]).
fn diagnosis_scenarios(force: f64) -> anyhow::Result<Vec<Vec<Effect>>> {
    let singles = [
        ("net_buoyancy", [6.0, -20.0]),
        ("thruster_lag", [0.2, 0.6]),
        ("reverse_thrust_loss", [0.2, 0.5]),
        ("thruster_deadband", [5.0, 15.0]),
        ("tether_drag", [0.5, 2.0]),
        ("water_current", [0.08, -0.2]),
        ("wall_effect", [120.0, 300.0]),
        ("coupled_drag", [40.0, 120.0]),
        ("sensor_delay", [0.15, 0.5]),
    ];
    let scaled = |name: &str, m: f64| {
        let forceful = [
            "net_buoyancy",
            "thruster_deadband",
            "tether_drag",
            "wall_effect",
            "coupled_drag",
        ];
        let m = if forceful.contains(&name) {
            m * force
        } else {
            m
        };
        Effect::from_arg(&format!("{name}={m:.4}")).map_err(anyhow::Error::msg)
    };
    let mut scenarios: Vec<Vec<Effect>> = vec![vec![]];
    for (name, mags) in singles {
        for m in mags {
            scenarios.push(vec![scaled(name, m)?]);
        }
    }
    for pair in [
        [("thruster_lag", 0.35), ("tether_drag", 1.2)],
        [("net_buoyancy", 10.0), ("sensor_delay", 0.2)],
        [("water_current", 0.12), ("coupled_drag", 60.0)],
        [("reverse_thrust_loss", 0.3), ("wall_effect", 200.0)],
        [("sensor_delay", 0.3), ("thruster_lag", 0.3)],
    ] {
        scenarios.push(
            pair.iter()
                .map(|(n, m)| scaled(n, *m))
                .collect::<anyhow::Result<_>>()?,
        );
    }
    Ok(scenarios)
}

/// What the check found so far: the confusion table (rows: concealed, columns: named), how
/// many scenarios named the concealed effects (and how many of those with a remainder), and
/// the slowest diagnosis.
struct Tally {
    /// `nothing`, every effect of the table, those outside it the scenarios conceal,
    /// `unexplained`.
    labels: Vec<&'static str>,
    table: Vec<Vec<usize>>,
    /// Scenarios whose named effects are the concealed ones.
    right: usize,
    /// Of those, the ones with an `unexplained` remainder beside them.
    remainders: usize,
    total: usize,
    worst_s: f64,
}

/// How one scenario's diagnosis compares with what was concealed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    Right,
    /// The concealed effects named, and a structured remainder reported `unexplained`.
    RightWithRemainder,
    Wrong,
}

impl Outcome {
    fn word(self) -> &'static str {
        match self {
            Outcome::Right => "ok",
            Outcome::RightWithRemainder => "ok (remainder unexplained)",
            Outcome::Wrong => "WRONG",
        }
    }
}

impl Tally {
    fn new(scenarios: &[Vec<Effect>]) -> Tally {
        let mut labels: Vec<&str> = vec!["nothing"];
        labels.extend(NAMES);
        labels.extend(
            OUTSIDE
                .iter()
                .filter(|o| scenarios.iter().flatten().any(|e| e.name() == **o)),
        );
        labels.push("unexplained");
        Tally {
            table: vec![vec![0usize; labels.len()]; labels.len()],
            labels,
            right: 0,
            remainders: 0,
            total: 0,
            worst_s: 0.0,
        }
    }

    /// Counts one scenario, `truth` concealed and `named` found: right when the named effects
    /// are the concealed ones, and whether an `unexplained` remainder is reported beside them
    /// (the twin's forms are not the diagnosis's, and a structured remainder above its noise
    /// is reported, never "within noise"). On effect-free runs `unexplained` is wrong.
    fn count(&mut self, truth: &[&str], named: &[&str]) -> Outcome {
        let row = |n: &str| self.labels.iter().position(|l| *l == n).unwrap_or(0);
        if truth.is_empty() {
            self.table[0][named.first().map_or(0, |n| row(n))] += 1;
        }
        let outside = |n: &str| OUTSIDE.contains(&n);
        let remainder = named.contains(&"unexplained");
        for (i, tn) in truth.iter().enumerate() {
            // Each concealed effect counts once: named anywhere (an effect outside the table
            // as `unexplained`), else what took its place.
            let col = if named.contains(tn) {
                row(tn)
            } else if outside(tn) && remainder {
                row("unexplained")
            } else {
                named.get(i).map_or(0, |n| row(n))
            };
            self.table[row(tn)][col] += 1;
        }
        let beyond = truth.iter().any(|t| outside(t));
        let mut a: Vec<&str> = truth.iter().copied().filter(|t| !outside(t)).collect();
        let mut b: Vec<&str> = named
            .iter()
            .copied()
            .filter(|n| *n != "unexplained" || truth.is_empty())
            .collect();
        a.sort();
        b.sort();
        self.total += 1;
        if a != b || (beyond && !remainder) {
            return Outcome::Wrong;
        }
        self.right += 1;
        if remainder && !beyond {
            self.remainders += 1;
            Outcome::RightWithRemainder
        } else {
            Outcome::Right
        }
    }

    /// The confusion table (rows nobody concealed left out) and the summary line.
    fn print(&self) {
        println!(
            "\nconfusion (rows: concealed, columns: named; pairs count each concealed effect once)"
        );
        let short = |s: &str| s.chars().take(8).collect::<String>();
        print!("{:>20}", "");
        for l in &self.labels {
            print!(" {:>8}", short(l));
        }
        println!();
        for (i, l) in self.labels.iter().enumerate() {
            if self.table[i].iter().sum::<usize>() == 0 {
                continue;
            }
            print!("{l:>20}");
            for c in &self.table[i] {
                print!(" {c:>8}");
            }
            println!();
        }
        println!(
            "\n{} of {} scenarios name exactly the concealed effects ({} of them with a remainder the table's simpler forms leave, reported unexplained); slowest diagnosis {:.1} s",
            self.right, self.total, self.remainders, self.worst_s
        );
    }
}

/// One scenario's line: what was concealed, what was named with its parameters (and its
/// look-alikes), whether
/// that is right, the held-out cost before and after, and the time since `t`.
fn print_verdict(seed: u64, effects: &[Effect], d: &Diagnosis, ok: Outcome, t: Instant) {
    let params: Vec<String> = d
        .effects
        .iter()
        .map(|e| {
            let alike: Vec<&str> = e.alike.iter().map(|a| a.name.as_str()).collect();
            let rounded = |p: &std::collections::BTreeMap<String, f64>| {
                (p.values())
                    .map(|v| (v * 1000.0).round() / 1000.0)
                    .collect::<Vec<_>>()
            };
            let beside: Vec<String> = (e.possibly_beside.iter())
                .map(|b| {
                    format!(
                        " (possibly beside: {} {:?})",
                        b.name,
                        rounded(&b.parameters)
                    )
                })
                .collect();
            format!(
                "{} {:?}{}{}",
                e.name,
                rounded(&e.parameters),
                match alike.is_empty() {
                    true => String::new(),
                    false => format!(" (or {})", alike.join(" or ")),
                },
                beside.concat()
            )
        })
        .collect();
    let forms: Vec<String> = (d.effects.iter())
        .filter_map(|e| Some(e.candidate.as_ref()?.expressions()))
        .collect();
    let forms = match forms.is_empty() {
        true => String::new(),
        false => format!(" closed form [{}]", forms.join("; ")),
    };
    println!(
        "seed {seed} concealed [{}] named [{}]{forms} {} held-out cost {:.4} -> {:.4} (noise {:.4}) {:.1} s",
        effects
            .iter()
            .map(|e| format!("{e:?}"))
            .collect::<Vec<_>>()
            .join(", "),
        params.join("; "),
        ok.word(),
        d.baseline.validation_cost,
        d.effects
            .last()
            .map_or(d.baseline.validation_cost, |e| e.validation_cost_after),
        d.baseline.noise_cost,
        t.elapsed().as_secs_f64()
    );
    // A wrong verdict in its own words, so the reason can be read off the check.
    if matches!(ok, Outcome::Wrong) {
        println!("    verdict: {}", d.verdict);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The concealed effects named is right, with or without a remainder reported
    /// `unexplained` beside them; a wrong or missing name is wrong, and so is `unexplained`
    /// on effect-free runs.
    #[test]
    fn the_check_counts_a_remainder_beside_the_right_names_as_right() {
        let mut t = Tally::new(&[]);
        assert_eq!(
            t.count(&["thruster_lag"], &["thruster_lag"]),
            Outcome::Right
        );
        assert_eq!(
            t.count(&["thruster_lag"], &["thruster_lag", "unexplained"]),
            Outcome::RightWithRemainder
        );
        assert_eq!(
            t.count(&["thruster_lag"], &["sensor_delay", "unexplained"]),
            Outcome::Wrong
        );
        assert_eq!(t.count(&["thruster_lag"], &["unexplained"]), Outcome::Wrong);
        assert_eq!(t.count(&[], &[]), Outcome::Right);
        assert_eq!(t.count(&[], &["unexplained"]), Outcome::Wrong);
        assert_eq!((t.right, t.remainders, t.total), (3, 1, 6));
    }

    /// An effect outside the table is right only as `unexplained`, beside the table's effects
    /// concealed with it; a named look-alike in its place is wrong, and so is nothing.
    #[test]
    fn the_check_wants_an_effect_outside_the_table_unexplained() {
        let scenarios = given_scenarios(&["battery_sag=0.05,tether_drag=1".into()]).unwrap();
        assert_eq!(scenarios[0].len(), 2);
        let mut t = Tally::new(&scenarios);
        assert!(t.labels.contains(&"battery_sag"));
        let truth = ["battery_sag", "tether_drag"];
        let right = ["tether_drag", "unexplained"];
        assert_eq!(t.count(&truth, &right), Outcome::Right);
        assert_eq!(t.count(&truth, &["tether_drag"]), Outcome::Wrong);
        let look_alike = ["tether_drag", "reverse_thrust_loss", "unexplained"];
        assert_eq!(t.count(&truth, &look_alike), Outcome::Wrong);
        assert_eq!(t.count(&["battery_sag"], &["unexplained"]), Outcome::Right);
        assert_eq!(t.count(&["battery_sag"], &[]), Outcome::Wrong);
        assert_eq!((t.right, t.remainders, t.total), (2, 0, 5));
        let sag = t.labels.iter().position(|l| *l == "battery_sag").unwrap();
        let unexplained = t.labels.len() - 1;
        assert_eq!(t.table[sag][unexplained], 3);
        assert!(given_scenarios(&["battery_sag".into()]).is_err());
    }
}
