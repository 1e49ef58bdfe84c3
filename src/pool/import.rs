//! A free-running pool test folder (docs/formats.md): `run.yaml`, `thrust.csv` and whichever of
//! `uwb.csv`, `sonar.csv`, `imu.csv`, `depth.csv`, `nav.csv` were recorded. A sensor file may
//! hold a subset of its columns (missing ones are NaN and named in the notes). Angles become
//! radians and accelerations m/s^2 on import; the command log's receive-time bursts are
//! repaired (see [`timing`]).

pub mod actuators;
pub mod csvlog;
pub mod frames;
pub mod from_log;
pub mod log_spec;
mod repairs;
mod stacks;
pub mod timing;

use crate::core::diag::InputError;
use crate::core::model::Pool;
use crate::core::model::thrusters::Thrusters;
use csvlog::Log;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub use crate::core::model::G;

pub use crate::core::run::Role;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunMeta {
    pub role: Role,
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub pool: Option<Pool>,
    #[serde(default)]
    pub tether_anchor_m: Option<[f64; 3]>,
    /// Where the vehicle was at the run's start, [x, y] in metres in the frame of `pool` and
    /// `tether_anchor_m`: a run without a position sensor is then dead-reckoned from its
    /// navigation log's velocity and heading, for the effects that need a position.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_m: Option<[f64; 2]>,
    /// The log the vehicle wrote, when the run's signals come from it rather than from CSV
    /// files (`log: {file: dive.bag, ...}`, see [`log_spec`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub log: Option<log_spec::LogSpec>,
}

/// One run's logs, SI units (radians, m/s^2), pool and body frames as in docs/formats.md.
#[derive(Debug, Clone)]
pub struct PoolRun {
    pub name: String,
    pub meta: RunMeta,
    /// t, X, Y, Z, N, and K, M when the vehicle is commanded in roll and pitch.
    pub thrust: Log,
    /// t, x, y, z.
    pub uwb: Option<Log>,
    /// t, x, y.
    pub sonar: Option<Log>,
    /// t, roll, pitch, yaw (rad), p, q, r (rad/s), ax, ay, az (m/s^2, specific force).
    pub imu: Option<Log>,
    /// t, depth.
    pub depth: Option<Log>,
    /// t, u, v, w (m/s), roll, pitch, yaw (rad), p, q, r (rad/s): a vehicle's navigation log.
    pub nav: Option<Log>,
    /// The actuator command log (fin and plane angles, propeller speed), when recorded.
    pub actuators: Option<actuators::Actuators>,
    /// Whether `thrust.csv` was recorded. A run steered by its actuators alone has none: its
    /// `thrust` is then zero on the actuator log's clock, and the force-driven stages (fit,
    /// validate, diagnose) refuse it.
    pub force_logged: bool,
    pub notes: Vec<String>,
    /// What was done to the logs' timing (receive-time bursts, spans trimmed to the overlap).
    pub repairs: Vec<String>,
    /// The vehicle's log the signals came from, when they came from one.
    pub log_source: Option<from_log::LogSource>,
    /// Where the command came from (`thrust.csv`, or the log and its topic), for messages.
    pub command_path: String,
    /// The `design.json` of a run `hydrofit design` proposed, as written (the report holds
    /// the flown run to its prediction).
    pub design: Option<serde_json::Value>,
}

pub const THRUST: [&str; 7] = ["t", "X_N", "Y_N", "Z_N", "N_Nm", "K_Nm", "M_Nm"];
/// The thrust log's columns every run has (K and M only a vehicle actuated in roll and pitch).
const THRUST_REQUIRED: usize = 5;
pub const UWB: [&str; 4] = ["t", "x_m", "y_m", "z_m"];
pub const SONAR: [&str; 3] = ["t", "x_m", "y_m"];
pub const IMU: [&str; 10] = [
    "t",
    "roll_deg",
    "pitch_deg",
    "yaw_deg",
    "p_dps",
    "q_dps",
    "r_dps",
    "ax_g",
    "ay_g",
    "az_g",
];
pub const DEPTH: [&str; 2] = ["t", "depth_m"];
pub const NAV: [&str; 10] = [
    "t",
    "u_m_s",
    "v_m_s",
    "w_m_s",
    "roll_deg",
    "pitch_deg",
    "yaw_deg",
    "p_dps",
    "q_dps",
    "r_dps",
];
/// What `hydrofit design` writes beside the command: part of a designed run's folder.
const DESIGN_FILES: [&str; 4] = [
    "design.json",
    "plan.csv",
    "trajectory.svg",
    "prbs_thrust.csv",
];
const KNOWN: [&str; 8] = [
    "run.yaml",
    "actuators.csv",
    "thrust.csv",
    "uwb.csv",
    "sonar.csv",
    "imu.csv",
    "depth.csv",
    "nav.csv",
];

fn read(root: &Path, rel: &str) -> Result<String, InputError> {
    Ok(crate::core::input::read(
        root,
        rel,
        "export the log as CSV text, not a binary or spreadsheet file",
    )?
    .text)
}

/// A folder named like one of the run's files: it would otherwise count as a missing file.
fn check_no_folders(root: &Path, dir: &str) -> Result<(), InputError> {
    for n in KNOWN {
        let rel = format!("{dir}/{n}");
        if root.join(&rel).is_dir() {
            return Err(InputError::file(
                rel,
                "is a folder, where the run's file of that name is expected",
                "rename or remove the folder (put the file itself there, or nothing)",
            ));
        }
    }
    Ok(())
}

/// Loads the run in folder `dir` (relative to `root`, `/`-separated) whose files are `files`;
/// per-thruster commands in a log become the wrench through `thrusters`. The command log's
/// timing is repaired ([`timing`]) and every repair said.
pub fn load(
    root: &Path,
    dir: &str,
    files: &[String],
    thrusters: Option<&Thrusters>,
) -> Result<PoolRun, InputError> {
    let mut run = load_as_logged(root, dir, files, thrusters)?;
    let path = run.command_path.clone();
    // A stop first: a regular clock is fitted to a stretch without one.
    run.cut_at_stops(dir);
    if let Some(r) = timing::repair_command_clock(&mut run.thrust) {
        run.repairs.push(format!("{path}: {r}"));
    }
    // Rows still sharing a time stamp (no regular clock could be fitted): the last of each.
    run.thrust.dedupe_times(&path);
    let from_log = run.meta.log.is_some();
    let spread: Vec<String> = (run.sensors_mut().into_iter())
        .filter_map(|(name, log)| {
            let r = timing::spread_bursts(log)?;
            Some(match from_log {
                true => format!("{dir}: the log's {name} signal: {r}"),
                false => format!("{dir}/{name}.csv: {r}"),
            })
        })
        .collect();
    run.repairs.extend(spread);
    let actuators = run.actuators.iter().map(|a| &a.log);
    let logs = (std::iter::once(&run.thrust).chain(actuators)).chain(run.sensor_logs());
    let notes: Vec<String> = logs.flat_map(|l| l.notes.iter().cloned()).collect();
    run.notes.extend(notes);
    run.trim_command_to_sensors();
    if let Some(idle) = run.force_logged.then(|| idle_note(&run.thrust)).flatten() {
        run.notes.push(format!("{path}: {idle}"));
    }
    if let Some(slow) = from_log
        .then(|| timing::slow_command_note(&run.thrust))
        .flatten()
    {
        run.notes.push(format!("{path}: {slow}"));
    }
    Ok(run)
}

/// A command log that asks for no force or moment over at least half of its time (every
/// thruster at neutral: a vehicle disarmed, idle or waiting at the surface, as a whole dive
/// log is at its start and end), said with its share: a fit learns little from such a stretch.
fn idle_note(thrust: &csvlog::Log) -> Option<String> {
    let n = thrust.len();
    let span = thrust.t.last()? - thrust.t.first()?;
    if n < 2 || span <= 0.0 {
        return None;
    }
    let zero = |k: usize| (thrust.cols.iter()).all(|c| c.get(k).is_none_or(|x| *x == 0.0));
    let idle_s: f64 = (0..n - 1)
        .filter(|&k| zero(k))
        .map(|k| thrust.t[k + 1] - thrust.t[k])
        .sum();
    let share = idle_s / span;
    (share >= 0.5).then(|| match share >= 1.0 - 1e-9 {
        true => "no force or moment is commanded anywhere in the run (every thruster at neutral: a vehicle disarmed or idle); nothing drives it, so a fit learns nothing from its commands: set the run's span to where the vehicle is driven".to_string(),
        false => format!(
            "no force or moment is commanded for {:.0} % of the run ({idle_s:.1} of {span:.1} s: every thruster at neutral, a vehicle disarmed, idle or waiting at the surface); a fit learns little from that stretch: set the run's span to where the vehicle is driven",
            100.0 * share
        ),
    })
}

/// The run as its files (or its log) hold it, in SI units, before any timing repair: what a
/// writer of the same run in another format must reproduce.
pub fn load_as_logged(
    root: &Path,
    dir: &str,
    files: &[String],
    thrusters: Option<&Thrusters>,
) -> Result<PoolRun, InputError> {
    let name = dir.rsplit('/').next().unwrap_or(dir).to_string();
    check_no_folders(root, dir)?;
    let mut notes = unknown_files(files);
    let meta = read_meta(root, dir, files)?;
    let mut logged = match &meta.log {
        Some(spec) => from_log::read(root, dir, spec, thrusters)?,
        None => from_log::FromLog::default(),
    };
    notes.append(&mut logged.notes);
    let csv =
        (find(files, "actuators.csv").map(|p| read(root, &p).map(|text| (p, text)))).transpose()?;
    let actuators = actuators::of_run(csv, logged.actuators.take())?;
    let (command_path, thrust, force_logged) =
        command_log(root, dir, files, &mut logged, &actuators)?;
    let mut sensors = read_sensors(root, dir, files, meta.log.is_none(), &mut notes)?;
    check_positions(dir, &sensors)?;
    sensors.convert_units();
    sensors.merge(&mut logged, dir)?;
    let Sensors {
        uwb,
        sonar,
        imu,
        depth,
        nav,
    } = sensors;
    Ok(PoolRun {
        name,
        meta,
        thrust,
        uwb,
        sonar,
        imu,
        depth,
        nav,
        actuators,
        force_logged,
        notes,
        repairs: Vec::new(),
        log_source: logged.source,
        command_path,
        design: read_design(root, files)?,
    })
}

/// The run's `design.json`, when `hydrofit design` proposed it: any JSON object (its fields
/// are read by the report, which says when they are not what a design writes).
fn read_design(root: &Path, files: &[String]) -> Result<Option<serde_json::Value>, InputError> {
    let Some(p) = find(files, "design.json") else {
        return Ok(None);
    };
    let text =
        crate::core::input::read(root, &p, "keep the design.json `hydrofit design` wrote")?.text;
    match serde_json::from_str::<serde_json::Value>(&text) {
        Ok(v) if v.is_object() => Ok(Some(v)),
        Ok(_) => Err(InputError::file(
            p,
            "is not a JSON object",
            "keep the design.json `hydrofit design` wrote, or remove it",
        )),
        Err(e) => Err(InputError::file(
            p,
            format!("is not JSON: line {}, column {}: {e}", e.line(), e.column()),
            "keep the design.json `hydrofit design` wrote, or remove it",
        )),
    }
}

/// The command log, where it came from, and whether forces were logged: `thrust.csv`, the
/// vehicle's log, or (a vehicle steered by fins) zeros on the actuator log's clock.
fn command_log(
    root: &Path,
    dir: &str,
    files: &[String],
    logged: &mut from_log::FromLog,
    actuators: &Option<actuators::Actuators>,
) -> Result<(String, Log, bool), InputError> {
    let csv = find(files, "thrust.csv");
    if let Some(log) = logged.thrust.take() {
        let source = logged.source.as_ref().expect("a log was read");
        if let Some(p) = csv {
            return Err(InputError::file(
                p,
                format!(
                    "the run has both thrust.csv and a command in its log ({})",
                    source.path
                ),
                "keep one: remove thrust.csv, or the command from run.yaml's `log:`",
            ));
        }
        let topic = source.topics.get("command").or(source.topics.get("wrench"));
        let path = format!("{}:{}", source.path, topic.map_or("", String::as_str));
        return Ok((path, log, true));
    }
    if csv.is_some() || actuators.is_none() {
        let (p, log) = read_thrust(root, dir, files)?;
        return Ok((p, log, true));
    }
    let a = &actuators.as_ref().expect("checked").log;
    let zeros = vec![0.0; a.len()];
    let log = Log {
        t: a.t.clone(),
        cols: vec![zeros; THRUST.len() - 1],
        notes: vec![format!(
            "{dir}: no thrust.csv; the actuator log is the command clock"
        )],
        present: vec![false; THRUST.len() - 1],
    };
    let path = match (logged.source.as_ref()).filter(|_| find(files, "actuators.csv").is_none()) {
        Some(s) => format!(
            "{}:{}",
            s.path,
            s.topics.get("actuators").map_or("", String::as_str)
        ),
        None => format!("{dir}/actuators.csv"),
    };
    Ok((path, log, false))
}

/// The path of the run's file named `n`, if it has one.
fn find(files: &[String], n: &str) -> Option<String> {
    files
        .iter()
        .find(|f| f.rsplit('/').next() == Some(n))
        .cloned()
}

/// A note for each file of the run that is not a pool log.
fn unknown_files(files: &[String]) -> Vec<String> {
    files
        .iter()
        .filter(|f| {
            let n = f.rsplit('/').next().unwrap_or("");
            !KNOWN.contains(&n) && !DESIGN_FILES.contains(&n)
        })
        .map(|f| format!("{f}: not a pool log hydrofit reads; ignored"))
        .collect()
}

/// The run's `run.yaml`, which every run needs.
fn read_meta(root: &Path, dir: &str, files: &[String]) -> Result<RunMeta, InputError> {
    let meta_path = find(files, "run.yaml").ok_or_else(|| {
        InputError::file(
            format!("{dir}/run.yaml"),
            "the run has no run.yaml",
            "add run.yaml with at least `role: train` or `role: validate`",
        )
    })?;
    let text = read(root, &meta_path)?;
    let meta: RunMeta = crate::core::input::yaml(
        &meta_path,
        &text,
        "run.yaml takes role (train | validate), description, pool {length_m, width_m, depth_m}, tether_anchor_m [x, y, z], start_m [x, y] and log",
    )?;
    meta.check(&meta_path, &text)?;
    Ok(meta)
}

impl RunMeta {
    /// Every number is finite and the pool's sizes are positive.
    fn check(&self, path: &str, text: &str) -> Result<(), InputError> {
        let index = crate::core::input::locate::KeyIndex::new(text);
        let err = |key: &str, what: String, fix: &str| {
            let e = InputError::file(path, what, fix);
            match index.find(key) {
                Some((l, c)) => e.at(l, Some(c)).with_source(text),
                None => e,
            }
        };
        if let Some(p) = &self.pool {
            for (k, v) in [
                ("length_m", p.length_m),
                ("width_m", p.width_m),
                ("depth_m", p.depth_m),
            ] {
                if !(v.is_finite() && v > 0.0) {
                    return Err(err(
                        &format!("pool.{k}"),
                        format!("pool.{k} is {v}; a pool's size is a positive number of metres"),
                        "write the pool's inside length, width and water depth in metres",
                    ));
                }
            }
        }
        if let Some(a) = self.tether_anchor_m
            && a.iter().any(|x| !x.is_finite())
        {
            return Err(err(
                "tether_anchor_m",
                format!("tether_anchor_m is {a:?}; it must be three finite coordinates"),
                "write where the tether enters the water, [x, y, z] in metres in the pool frame",
            ));
        }
        if let Some(a) = self.start_m
            && a.iter().any(|x| !x.is_finite())
        {
            return Err(err(
                "start_m",
                format!("start_m is {a:?}; it must be two finite coordinates"),
                "write where the vehicle was when the run started, [x, y] in metres in the pool frame",
            ));
        }
        Ok(())
    }
}

/// The thrust log and its path, which every run needs. Its repeated time stamps are kept
/// for the clock repair.
fn read_thrust(root: &Path, dir: &str, files: &[String]) -> Result<(String, Log), InputError> {
    let thrust_path = find(files, "thrust.csv").ok_or_else(|| {
        InputError::file(format!("{dir}/thrust.csv"), "the run has no command log", "add thrust.csv (t,X_N,Y_N,Z_N,N_Nm), or actuators.csv (t,<name>_deg,...) for a vehicle steered by fins and propeller speed")
    })?;
    let mut thrust = csvlog::parse_keeping_repeats(
        &thrust_path,
        &read(root, &thrust_path)?,
        &THRUST,
        THRUST_REQUIRED,
        "thrust log",
        10,
    )?;
    // A 4-DOF vehicle's log has no roll and pitch moments; that is not worth a note.
    if !thrust.has(4) && !thrust.has(5) {
        thrust
            .notes
            .retain(|n| !n.contains("no K_Nm, M_Nm columns"));
    }
    Ok((thrust_path, thrust))
}

/// The sensor logs of a run, each when it was recorded.
struct Sensors {
    uwb: Option<Log>,
    sonar: Option<Log>,
    imu: Option<Log>,
    depth: Option<Log>,
    nav: Option<Log>,
}

type Parser = fn(&str, &str, &[&str], &str, usize) -> Result<Log, InputError>;

/// Reads the sensor logs the run has; each one it lacks is noted in `notes`.
fn read_sensors(
    root: &Path,
    dir: &str,
    files: &[String],
    note_missing: bool,
    notes: &mut Vec<String>,
) -> Result<Sensors, InputError> {
    let mut optional =
        |n: &str, cols: &[&str], what: &str, parse: Parser| -> Result<Option<Log>, InputError> {
            match find(files, n) {
                None => {
                    if note_missing {
                        notes.push(format!("{dir}: no {n}"));
                    }
                    Ok(None)
                }
                Some(p) => parse(&p, &read(root, &p)?, cols, what, 2).map(Some),
            }
        };
    Ok(Sensors {
        uwb: optional("uwb.csv", &UWB, "UWB log", csvlog::parse_subset)?,
        sonar: optional("sonar.csv", &SONAR, "sonar log", csvlog::parse_subset)?,
        imu: optional("imu.csv", &IMU, "IMU log", csvlog::parse_subset)?,
        depth: optional("depth.csv", &DEPTH, "depth log", csvlog::parse_subset)?,
        // A navigation log may have gaps (a DVL without bottom lock writes empty or nan values).
        nav: optional(
            "nav.csv",
            &NAV,
            "navigation log",
            csvlog::parse_subset_with_gaps,
        )?,
    })
}

/// A position log (UWB, sonar) needs both horizontal coordinates.
fn check_positions(dir: &str, sensors: &Sensors) -> Result<(), InputError> {
    for (log, n) in [(&sensors.uwb, "uwb.csv"), (&sensors.sonar, "sonar.csv")] {
        if log.as_ref().is_some_and(|l| !(l.has(0) && l.has(1))) {
            return Err(InputError::file(
                format!("{dir}/{n}"),
                "a position log needs both x_m and y_m",
                "write both horizontal coordinates (pool frame); z_m is optional",
            ));
        }
    }
    Ok(())
}

impl Sensors {
    /// The logs read from the vehicle's log, where no CSV file gives them; one given twice is
    /// an error.
    fn merge(&mut self, logged: &mut from_log::FromLog, dir: &str) -> Result<(), InputError> {
        let pairs = [
            (&mut self.uwb, logged.uwb.take(), "uwb.csv", "position"),
            (&mut self.sonar, logged.sonar.take(), "sonar.csv", "sonar"),
            (
                &mut self.imu,
                logged.imu.take(),
                "imu.csv",
                "attitude, rates or acceleration",
            ),
            (&mut self.depth, logged.depth.take(), "depth.csv", "depth"),
            (&mut self.nav, logged.nav.take(), "nav.csv", "velocity"),
        ];
        for (slot, from_log, file, signal) in pairs {
            match (slot.is_some(), from_log) {
                (true, Some(_)) => {
                    return Err(InputError::file(
                        format!("{dir}/{file}"),
                        format!("the run has both {file} and the {signal} in its log"),
                        format!("keep one: remove {file}, or the log's {signal} from run.yaml"),
                    ));
                }
                (false, Some(l)) => *slot = Some(l),
                _ => {}
            }
        }
        Ok(())
    }

    /// Angles and rates to radians, accelerations from g to m/s^2.
    fn convert_units(&mut self) {
        if let Some(imu) = &mut self.imu {
            for c in &mut imu.cols[..6] {
                c.iter_mut().for_each(|x| *x = x.to_radians());
            }
            for c in &mut imu.cols[6..] {
                c.iter_mut().for_each(|x| *x *= G);
            }
        }
        if let Some(nav) = &mut self.nav {
            for c in &mut nav.cols[3..] {
                c.iter_mut().for_each(|x| *x = x.to_radians());
            }
        }
    }
}

#[cfg(test)]
mod tests;
