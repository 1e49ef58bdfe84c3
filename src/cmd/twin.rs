//! `hydrofit twin ...`: write synthetic inputs from the reference vehicle.

use crate::diagnose::result::Diagnosis;
use crate::twin;
use crate::twin::world::{Effect, NAMES};
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

/// Says what a twin command wrote, and where.
fn wrote(what: &str, n: usize, out: &Path, truth: &Path, seed: u64) -> anyhow::Result<ExitCode> {
    eprintln!(
        "hydrofit: wrote {n} {what} to {} and their truth to {} (seed {seed})",
        out.display(),
        truth.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// `p` as given when absolute, else inside the project folder `root`.
fn under(root: &Path, p: &Path) -> std::path::PathBuf {
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        root.join(p)
    }
}

pub fn starccm(root: &Path, out: &Path, seed: u64) -> anyhow::Result<ExitCode> {
    let dir = under(root, out);
    let cases = twin::cfd::default_cases();
    let written = twin::cfd::write_cases(&dir, &cases, seed)?;
    eprintln!(
        "hydrofit: wrote {} STAR-CCM+ exports of the reference vehicle to {} (seed {seed})",
        written.len(),
        dir.display()
    );
    Ok(ExitCode::SUCCESS)
}

pub fn pool(
    root: &Path,
    out: &Path,
    truth: &Path,
    seed: u64,
    effects: &[String],
) -> anyhow::Result<ExitCode> {
    let abs = |p: &Path| under(root, p);
    let effects = if effects.is_empty() {
        twin::pool::default_effects()
    } else if effects.iter().any(|e| e == "none") {
        Vec::new()
    } else {
        effects
            .iter()
            .map(|e| crate::twin::world::Effect::from_arg(e))
            .collect::<Result<Vec<_>, _>>()
            .map_err(anyhow::Error::msg)?
    };
    let runs = twin::pool::default_runs();
    let written = twin::pool::write_runs(&abs(out), &abs(truth), &runs, &effects, seed)?;
    let names: Vec<&str> = effects.iter().map(|e| e.name()).collect();
    eprintln!(
        "hydrofit: wrote {} pool runs to {} and their truth to {} (seed {seed}, concealed: {})",
        written.len(),
        abs(out).display(),
        abs(truth).display(),
        if names.is_empty() {
            "nothing".into()
        } else {
            names.join(", ")
        }
    );
    Ok(ExitCode::SUCCESS)
}

pub fn field(root: &Path, out: &Path, truth: &Path, seed: u64) -> anyhow::Result<ExitCode> {
    let abs = |p: &Path| under(root, p);
    let hidden = twin::field::Hidden::default();
    let written = twin::field::write_runs(
        &abs(out),
        &abs(truth),
        &twin::field::default_runs(),
        &hidden,
        seed,
    )?;
    eprintln!(
        "hydrofit: wrote {} field runs to {} and their truth to {} (seed {seed})",
        written.len(),
        abs(out).display(),
        abs(truth).display()
    );
    Ok(ExitCode::SUCCESS)
}

pub fn six_dof(root: &Path, out: &Path, truth: &Path, seed: u64) -> anyhow::Result<ExitCode> {
    let (out, truth) = (under(root, out), under(root, truth));
    let trials = twin::six::default_trials();
    let written = twin::six::render::write_trials(&out, &truth, &trials, seed)?;
    wrote("six-DOF trials", written.len(), &out, &truth, seed)
}

pub fn auv(root: &Path, out: &Path, truth: &Path, seed: u64) -> anyhow::Result<ExitCode> {
    let (out, truth) = (under(root, out), under(root, truth));
    let written = twin::auv::write_runs(&out, &truth, seed)?;
    wrote("AUV dives", written.len(), &out, &truth, seed)
}

pub fn dsrv(root: &Path, out: &Path, truth: &Path, seed: u64) -> anyhow::Result<ExitCode> {
    let (out, truth) = (under(root, out), under(root, truth));
    let written = twin::dsrv::write_runs(&out, &truth, seed)?;
    wrote("DSRV runs", written.len(), &out, &truth, seed)
}

pub fn tank(root: &Path, out: &Path, truth: &Path, seed: u64) -> anyhow::Result<ExitCode> {
    let (out, truth) = (under(root, out), under(root, truth));
    let written = twin::tank::write_runs(&out, &truth, seed)?;
    wrote("tank runs", written.len(), &out, &truth, seed)
}

/// `hydrofit twin check-diagnosis`: the diagnosis on generated scenarios, each effect concealed
/// alone at two magnitudes, pairs of effects, and nothing, for each seed; prints every verdict
/// and the confusion table (concealed vs named).
pub fn check_diagnosis(seeds: &[u64]) -> anyhow::Result<ExitCode> {
    use crate::twin::scenario;
    let scenarios = diagnosis_scenarios()?;
    let vehicle = crate::core::model::Vehicle::reference();
    let plant = scenario::cfd_fit_plant(1)?;
    let mut tally = Tally::new();
    for &seed in seeds {
        for effects in &scenarios {
            let fused = scenario::fused_runs(effects, seed)?;
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
            let named: Vec<&str> = d.effects.iter().map(|e| e.name.as_str()).collect();
            let truth: Vec<&str> = effects.iter().map(|e| e.name()).collect();
            let ok = tally.count(&truth, &named);
            print_verdict(seed, effects, &d, ok, t);
        }
    }
    tally.print();
    Ok(if tally.right == tally.total {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The check's scenarios: nothing concealed, each effect alone at two magnitudes, then pairs.
fn diagnosis_scenarios() -> anyhow::Result<Vec<Vec<Effect>>> {
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
    let mut scenarios: Vec<Vec<Effect>> = vec![vec![]];
    for (name, mags) in singles {
        for m in mags {
            scenarios.push(vec![
                Effect::from_arg(&format!("{name}={m}")).map_err(anyhow::Error::msg)?,
            ]);
        }
    }
    for pair in [
        ["thruster_lag=0.35", "tether_drag=1.2"],
        ["net_buoyancy=10", "sensor_delay=0.2"],
        ["water_current=0.12", "coupled_drag=60"],
        ["reverse_thrust_loss=0.3", "wall_effect=200"],
    ] {
        scenarios.push(
            pair.iter()
                .map(|a| Effect::from_arg(a))
                .collect::<Result<_, _>>()
                .map_err(anyhow::Error::msg)?,
        );
    }
    Ok(scenarios)
}

/// What the check found so far: the confusion table (rows: concealed, columns: named), how
/// many scenarios were exactly right, and the slowest diagnosis.
struct Tally {
    /// `nothing`, every effect, `unexplained`.
    labels: Vec<&'static str>,
    table: Vec<Vec<usize>>,
    right: usize,
    total: usize,
    worst_s: f64,
}

impl Tally {
    fn new() -> Tally {
        let mut labels: Vec<&str> = vec!["nothing"];
        labels.extend(NAMES);
        labels.push("unexplained");
        Tally {
            table: vec![vec![0usize; labels.len()]; labels.len()],
            labels,
            right: 0,
            total: 0,
            worst_s: 0.0,
        }
    }

    /// Counts one scenario, `truth` concealed and `named` found; whether the two are the same
    /// effects.
    fn count(&mut self, truth: &[&str], named: &[&str]) -> bool {
        let row = |n: &str| self.labels.iter().position(|l| *l == n).unwrap_or(0);
        if truth.is_empty() {
            self.table[0][named.first().map_or(0, |n| row(n))] += 1;
        }
        for (i, tn) in truth.iter().enumerate() {
            // Each concealed effect counts once: named anywhere, else what took its place.
            let col = if named.contains(tn) {
                row(tn)
            } else {
                named.get(i).map_or(0, |n| row(n))
            };
            self.table[row(tn)][col] += 1;
        }
        let ok = {
            let mut a = truth.to_vec();
            let mut b: Vec<&str> = named.to_vec();
            a.sort();
            b.sort();
            a == b
        };
        self.right += usize::from(ok);
        self.total += 1;
        ok
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
            "\n{} of {} scenarios exactly right; slowest diagnosis {:.1} s",
            self.right, self.total, self.worst_s
        );
    }
}

/// One scenario's line: what was concealed, what was named with its parameters, whether
/// that is right, the held-out cost before and after, and the time since `t`.
fn print_verdict(seed: u64, effects: &[Effect], d: &Diagnosis, ok: bool, t: Instant) {
    let params: Vec<String> = d
        .effects
        .iter()
        .map(|e| {
            format!(
                "{} {:?}",
                e.name,
                e.parameters
                    .values()
                    .map(|v| (v * 1000.0).round() / 1000.0)
                    .collect::<Vec<_>>()
            )
        })
        .collect();
    println!(
        "seed {seed} concealed [{}] named [{}] {} held-out cost {:.4} -> {:.4} (noise {:.4}) {:.1} s",
        effects
            .iter()
            .map(|e| format!("{e:?}"))
            .collect::<Vec<_>>()
            .join(", "),
        params.join("; "),
        if ok { "ok" } else { "WRONG" },
        d.baseline.validation_cost,
        d.effects
            .last()
            .map_or(d.baseline.validation_cost, |e| e.validation_cost_after),
        d.baseline.noise_cost,
        t.elapsed().as_secs_f64()
    );
}
