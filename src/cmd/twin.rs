//! `hydrofit twin ...`: write synthetic inputs from the reference vehicle.

use crate::twin;
use crate::twin::world::Effect;
use std::path::Path;
use std::process::ExitCode;

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
    (out, truth, seed): (&Path, &Path, u64),
    effects: &[String],
    logs: twin::pool::Logs,
) -> anyhow::Result<ExitCode> {
    let abs = |p: &Path| under(root, p);
    let effects = pool_effects(effects)?;
    let runs = twin::pool::default_runs();
    let written = twin::pool::write_runs_seen(&abs(out), &abs(truth), &runs, &effects, seed, logs)?;
    eprintln!(
        "hydrofit: wrote {} pool runs ({}) to {} and their truth to {} (seed {seed}, concealed: {})",
        written.len(),
        logged(logs),
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
    /// What the run folder holds: the pool's sensors or the vehicle's navigation log.
    pub logs: twin::pool::Logs,
}

/// The twin's logs: the vehicle's own navigation log when asked, else the pool's sensors.
pub fn logs(navigation_log: bool) -> twin::pool::Logs {
    if navigation_log {
        twin::pool::Logs::Navigation
    } else {
        twin::pool::Logs::Sensors
    }
}

/// What the run folders hold, in words.
fn logged(logs: twin::pool::Logs) -> &'static str {
    match logs {
        twin::pool::Logs::Sensors => "thrust, UWB, sonar, IMU and depth",
        twin::pool::Logs::Navigation => "thrust, navigation log and depth",
    }
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
    let dirs = (abs(f.out), abs(f.truth));
    let dir = twin::pool::write_truth(
        (&dirs.0, &dirs.1),
        &spec,
        &truth,
        (&effects, f.seed),
        f.logs,
    )?;
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
