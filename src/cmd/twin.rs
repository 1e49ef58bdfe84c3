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
    let effects = pool_effects(effects)?;
    let runs = twin::pool::default_runs();
    let written = twin::pool::write_runs(&abs(out), &abs(truth), &runs, &effects, seed)?;
    eprintln!(
        "hydrofit: wrote {} pool runs to {} and their truth to {} (seed {seed}, concealed: {})",
        written.len(),
        abs(out).display(),
        abs(truth).display(),
        concealed(&effects)
    );
    Ok(ExitCode::SUCCESS)
}

/// `--effect` of the pool twins: none given, the default set; `none`, nothing.
fn pool_effects(effects: &[String]) -> anyhow::Result<Vec<Effect>> {
    if effects.is_empty() {
        Ok(twin::pool::default_effects())
    } else if effects.iter().any(|e| e == "none") {
        Ok(Vec::new())
    } else {
        effects
            .iter()
            .map(|e| Effect::from_arg(e))
            .collect::<Result<Vec<_>, _>>()
            .map_err(anyhow::Error::msg)
    }
}

fn concealed(effects: &[Effect]) -> String {
    let names: Vec<&str> = effects.iter().map(|e| e.name()).collect();
    if names.is_empty() {
        "nothing".into()
    } else {
        names.join(", ")
    }
}

/// What `twin fly` is asked.
pub struct Flight<'a> {
    pub thrust: &'a Path,
    pub name: &'a str,
    /// None: the design's (its run.yaml beside the command), else train.
    pub role: Option<&'a str>,
    pub out: &'a Path,
    pub truth: &'a Path,
    pub seed: u64,
    pub effects: &'a [String],
}

/// The role `hydrofit design` gave the run (the run.yaml beside its thrust.csv: a run to tell
/// two effects apart is held out), else train.
fn design_role(thrust: &Path) -> String {
    std::fs::read_to_string(thrust.with_file_name("run.yaml"))
        .ok()
        .and_then(|t| serde_yaml_ng::from_str::<serde_yaml_ng::Value>(&t).ok())
        .and_then(|v| v.get("role")?.as_str().map(String::from))
        .unwrap_or_else(|| "train".into())
}

/// Flies a designed command (a thrust.csv at 20 Hz) with the pool twin, open loop from the
/// start its design.json gives (else the pool's middle at half depth, heading +x).
pub fn fly(root: &Path, f: &Flight) -> anyhow::Result<ExitCode> {
    let abs = |p: &Path| under(root, p);
    let effects = pool_effects(f.effects)?;
    let path = abs(f.thrust);
    let cmd = read_thrust(&path)?;
    let start = design_start(&path)?;
    let world = twin::pool::world(&effects);
    let truth = twin::pool::fly(&world, &cmd, start);
    let spec = twin::pool::RunSpec {
        name: f.name.to_string(),
        role: match f.role {
            Some(r) => r.to_string(),
            None => design_role(&path),
        },
        manoeuvre: twin::pool::Manoeuvre::Designed,
        duration_s: (cmd.len().saturating_sub(1)) as f64 * 0.05,
        sonar: true,
    };
    let dir = twin::pool::write_truth(&abs(f.out), &abs(f.truth), &spec, &truth, &effects, f.seed)?;
    // The design travels with its run (as when the folder `hydrofit design` wrote is copied
    // into cases/pool/ and the logs added), so the report can hold the run to it.
    let design = path.with_file_name("design.json");
    if path.file_name().is_some_and(|n| n == "thrust.csv") && design.exists() {
        std::fs::copy(&design, dir.join("design.json"))?;
    }
    let p = twin::pool::POOL;
    let left = truth.states.iter().any(|s| {
        p.wall_distance(s.pos[0], s.pos[1]) < 0.0 || s.pos[2] < 0.0 || s.pos[2] > p.depth_m
    });
    eprintln!(
        "hydrofit: flew {} ({:.0} s, concealed: {}) into {}{}",
        path.display(),
        spec.duration_s,
        concealed(&effects),
        dir.display(),
        if left {
            "; warning: the twin left the pool on the way (the model the design flew differs from the twin)"
        } else {
            ""
        }
    );
    Ok(ExitCode::SUCCESS)
}

/// `t,X_N,Y_N,Z_N,N_Nm` at 20 Hz, as `hydrofit design` writes it.
fn read_thrust(path: &Path) -> anyhow::Result<Vec<[f64; 4]>> {
    let text =
        std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        let v: Vec<f64> = line
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| anyhow::anyhow!("{}:{}: {e}", path.display(), i + 1))?;
        anyhow::ensure!(
            v.len() == 5 && v.iter().all(|x| x.is_finite()),
            "{}:{}: expected five finite numbers t,X_N,Y_N,Z_N,N_Nm",
            path.display(),
            i + 1
        );
        anyhow::ensure!(
            (v[0] - out.len() as f64 * 0.05).abs() < 1e-3,
            "{}:{}: t = {} s, expected {:.2} s (the twin flies a 20 Hz command from t = 0)",
            path.display(),
            i + 1,
            v[0],
            out.len() as f64 * 0.05
        );
        out.push([v[1], v[2], v[3], v[4]]);
    }
    anyhow::ensure!(out.len() >= 10, "{}: fewer than 10 rows", path.display());
    Ok(out)
}

/// The start of the design whose `design.json` sits beside the command.
fn design_start(thrust: &Path) -> anyhow::Result<twin::world::State> {
    let p = twin::pool::POOL;
    let file = thrust.with_file_name("design.json");
    let [x, y, z, psi_deg] = if file.exists() {
        crate::core::fsutil::read_json::<crate::design::written::Written>(&file)?.start
    } else {
        [p.length_m / 2.0, p.width_m / 2.0, p.depth_m / 2.0, 0.0]
    };
    Ok(twin::world::State {
        pos: [x, y, z],
        psi: psi_deg.to_radians(),
        ..Default::default()
    })
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
pub fn check_diagnosis(seeds: &[u64], navigation_log: bool) -> anyhow::Result<ExitCode> {
    use crate::cmd::scenario;
    use crate::twin::pool::Logs;
    let scenarios = diagnosis_scenarios()?;
    let vehicle = crate::core::model::Vehicle::reference();
    let plant = scenario::cfd_fit_plant(1)?;
    let logs = if navigation_log {
        Logs::Navigation
    } else {
        Logs::Sensors
    };
    let mut tally = Tally::new();
    for &seed in seeds {
        for effects in &scenarios {
            let fused = scenario::fused_runs_seen(effects, seed, logs)?;
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
        }
    }
    tally.print();
    Ok(if tally.right == tally.total {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
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
        ["sensor_delay=0.3", "thruster_lag=0.3"],
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
/// many scenarios named the concealed effects (and how many of those with a remainder), and
/// the slowest diagnosis.
struct Tally {
    /// `nothing`, every effect, `unexplained`.
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
    fn new() -> Tally {
        let mut labels: Vec<&str> = vec!["nothing"];
        labels.extend(NAMES);
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
        for (i, tn) in truth.iter().enumerate() {
            // Each concealed effect counts once: named anywhere, else what took its place.
            let col = if named.contains(tn) {
                row(tn)
            } else {
                named.get(i).map_or(0, |n| row(n))
            };
            self.table[row(tn)][col] += 1;
        }
        let remainder = named.contains(&"unexplained");
        let mut a = truth.to_vec();
        let mut b: Vec<&str> = named
            .iter()
            .copied()
            .filter(|n| *n != "unexplained" || truth.is_empty())
            .collect();
        a.sort();
        b.sort();
        self.total += 1;
        if a != b {
            return Outcome::Wrong;
        }
        self.right += 1;
        if remainder {
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

/// One scenario's line: what was concealed, what was named with its parameters, whether
/// that is right, the held-out cost before and after, and the time since `t`.
fn print_verdict(seed: u64, effects: &[Effect], d: &Diagnosis, ok: Outcome, t: Instant) {
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
        ok.word(),
        d.baseline.validation_cost,
        d.effects
            .last()
            .map_or(d.baseline.validation_cost, |e| e.validation_cost_after),
        d.baseline.noise_cost,
        t.elapsed().as_secs_f64()
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The concealed effects named is right, with or without a remainder reported
    /// `unexplained` beside them; a wrong or missing name is wrong, and so is `unexplained`
    /// on effect-free runs.
    #[test]
    fn the_check_counts_a_remainder_beside_the_right_names_as_right() {
        let mut t = Tally::new();
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
}
