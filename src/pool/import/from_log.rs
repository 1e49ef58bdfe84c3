//! A run read from the log the vehicle wrote (`log:` in `run.yaml`, see [`super::log_spec`]):
//! each signal's topic read once, cut to the run's span, its time taken from the header stamp
//! or the receive time, converted to SI units and the body frame hydrofit uses (x forward,
//! y starboard, z down), and laid out as the CSV logs of a run folder are, so that the fusion
//! cannot tell a log from its CSV export. Per-thruster commands become the body wrench here,
//! through `vehicle.thrusters`.

use super::csvlog::Log;
use super::log_spec::{Frame, LogSpec, Source, Stack, TimeSource, Unit};
use super::{DEPTH, IMU, NAV, SONAR, THRUST, UWB};
use crate::core::diag::InputError;
use crate::core::model::thrusters::Thrusters;
use hydrofit_logs::{Format, Log as VehicleLog, Selector};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Standard gravity, for pressure to depth and g to m/s^2.
const G: f64 = 9.80665;

/// Where a run's logs came from, for its provenance: the log by content, the topics read and
/// the span used.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogSource {
    /// As written in `run.yaml`, resolved: relative to the project root when inside it.
    pub path: String,
    pub format: String,
    /// signal -> topic.
    pub topics: BTreeMap<String, String>,
    /// The span read, seconds from the log's first message.
    pub span_s: [f64; 2],
}

/// The run's logs as read from the vehicle's log.
#[derive(Debug, Default)]
pub struct FromLog {
    /// The command as `thrust.csv` holds it (X, Y, Z, N, K, M).
    pub thrust: Option<Log>,
    pub nav: Option<Log>,
    pub imu: Option<Log>,
    pub depth: Option<Log>,
    pub uwb: Option<Log>,
    pub sonar: Option<Log>,
    pub notes: Vec<String>,
    pub source: Option<LogSource>,
}

/// One signal's samples: time from the span's start and one value per field.
struct Samples {
    topic: String,
    t: Vec<f64>,
    rows: Vec<Vec<f64>>,
    /// How many samples took their header stamp, and how many the log's own time.
    stamped: usize,
    received: usize,
}

/// A message's time: its header stamp where it has one (and `time` allows it), else the time
/// the log recorded it. A stamp more than 5 s from the recording time is another clock (a
/// sensor's own, unsynchronised): the recording time is taken then.
fn message_time(time: TimeSource, m: &hydrofit_logs::Message) -> (f64, bool) {
    match (time, m.stamp_s) {
        (TimeSource::Receive, _) | (_, None) => (m.log_time_s, false),
        (TimeSource::Auto, Some(s)) if (s - m.log_time_s).abs() > 5.0 => (m.log_time_s, false),
        (_, Some(s)) => (s, true),
    }
}

/// Reads the log of `spec` for the run in `dir` (relative to `root`).
pub fn read(
    root: &Path,
    dir: &str,
    spec: &LogSpec,
    thrusters: Option<&Thrusters>,
) -> Result<FromLog, InputError> {
    let (abs, mut shown) = resolve(root, dir, &spec.file);
    let log = VehicleLog::open(&abs).map_err(|e| {
        let at = e.offset.map_or(String::new(), |o| format!(" (byte {o})"));
        InputError::file(&shown, format!("{}{at}", e.what), e.fix)
    })?;
    // A rosbag2 folder was opened through its storage file: that file is the input.
    if log.path != abs
        && let Some(name) = log.path.file_name()
    {
        shown = format!("{}/{}", shown.trim_end_matches('/'), name.to_string_lossy());
    }
    let mut out = FromLog::default();
    let sources = sources(&log, spec, thrusters, &mut out.notes);
    let (start, end) = span(&log, spec, &shown)?;
    let samples = read_signals(&log, &sources, spec.time, start, end, &shown)?;
    for n in log.notes() {
        out.notes.push(format!("{shown}: {n}"));
    }
    build(&mut out, &sources, &samples, thrusters, &shown)?;
    out.source = Some(LogSource {
        path: shown,
        format: log.format.name().into(),
        topics: sources
            .iter()
            .map(|(k, s)| (k.to_string(), s.source.topic.clone()))
            .collect(),
        span_s: [start, end].map(|x| ((x - log_start(&log)) * 1e6).round() / 1e6),
    });
    Ok(out)
}

/// The log's absolute path and the path shown to the user and recorded (relative to the
/// project root when the log is inside it).
pub fn resolve(root: &Path, dir: &str, file: &str) -> (PathBuf, String) {
    let p = Path::new(file);
    let abs = if p.is_absolute() {
        p.to_path_buf()
    } else {
        root.join(dir).join(p)
    };
    let abs = normalise(&abs);
    let shown = abs
        .strip_prefix(normalise(root))
        .map(|r| r.to_string_lossy().replace('\\', "/"))
        .unwrap_or_else(|_| abs.to_string_lossy().into_owned());
    (abs, shown)
}

/// `a/b/../c` as `a/c`, without touching the file system.
fn normalise(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            std::path::Component::ParentDir => {
                out.pop();
            }
            std::path::Component::CurDir => {}
            c => out.push(c),
        }
    }
    out
}

/// A signal's source and whether the user named it (then a missing topic is an error) or a
/// stack's default gave it (then a missing topic leaves the signal out, with a note).
struct Chosen {
    source: Source,
    explicit: bool,
}

/// The source of every signal: the stack's defaults, overridden by the spec.
fn sources(
    log: &VehicleLog,
    spec: &LogSpec,
    thrusters: Option<&Thrusters>,
    notes: &mut Vec<String>,
) -> Vec<(&'static str, Chosen)> {
    let stack = spec.stack.unwrap_or_else(|| default_stack(log));
    let n = thrusters.map_or(8, |t| t.units().len());
    let mut out: Vec<(&'static str, Chosen)> = Vec::new();
    let mut missing: Vec<(&'static str, String)> = Vec::new();
    for (k, source) in super::stacks::defaults(stack, n) {
        // The first candidate whose topic the log has.
        if out.iter().any(|(o, _)| *o == k) {
            continue;
        }
        if log.topic(&source.topic).is_some() {
            missing.retain(|(m, _)| *m != k);
            let explicit = false;
            out.push((k, Chosen { source, explicit }));
        } else {
            missing.push((k, source.topic));
        }
    }
    for (name, s) in spec.signals() {
        let Some(s) = s else { continue };
        out.retain(|(k, _)| *k != name && !(name == "wrench" && *k == "command"));
        missing.retain(|(m, _)| *m != name);
        let explicit = true;
        out.push((
            name,
            Chosen {
                source: s.clone(),
                explicit,
            },
        ));
    }
    if spec.wrench.is_some() {
        out.retain(|(k, c)| *k != "command" || c.explicit);
        missing.retain(|(m, _)| *m != "command");
    }
    missing.dedup_by(|a, b| a.0 == b.0);
    for (signal, topic) in missing {
        notes.push(format!(
            "no {signal}: the {stack:?} stack's topic `{topic}` is not in the log (name another in run.yaml's `log.{signal}`)"
        ));
    }
    out
}

fn default_stack(log: &VehicleLog) -> Stack {
    match log.format {
        Format::DataFlash => Stack::Ardusub,
        Format::Tlog => Stack::ArdusubTlog,
        _ if log.topics.iter().any(|t| t.name.starts_with("/mavros/")) => Stack::Mavros,
        _ => Stack::None,
    }
}

/// The time of the log's first timed message. A DataFlash log's format and parameter records
/// carry no time of their own (they read as the time of the message before them): only
/// messages with a `TimeUS` or `TimeMS` field count.
fn log_start(log: &VehicleLog) -> f64 {
    let timed = |t: &hydrofit_logs::Topic| {
        log.format != Format::DataFlash
            || t.schema
                .fields
                .iter()
                .any(|f| f.name == "TimeUS" || f.name == "TimeMS")
    };
    log.topics
        .iter()
        .filter(|t| t.count > 0 && timed(t))
        .map(|t| t.first_s)
        .fold(f64::INFINITY, f64::min)
}

/// The run's span in the log's clock.
fn span(log: &VehicleLog, spec: &LogSpec, shown: &str) -> Result<(f64, f64), InputError> {
    let start = log_start(log);
    if !start.is_finite() {
        return Err(InputError::file(
            shown,
            "the log holds no messages",
            "record the run again, or point `log.file` at the right log",
        ));
    }
    let end = log
        .topics
        .iter()
        .map(|t| t.last_s)
        .fold(f64::NEG_INFINITY, f64::max);
    let Some([a, b]) = spec.span_s else {
        return Ok((start, end));
    };
    if !(a.is_finite() && b.is_finite() && a >= 0.0 && b > a) || start + a >= end {
        return Err(InputError::file(
            shown,
            format!(
                "span_s [{a}, {b}] is not a span of this log, which lasts {:.2} s",
                end - start
            ),
            "give `span_s: [from, to]` in seconds from the log's first message, from < to, inside the log",
        ));
    }
    Ok((start + a, (start + b).min(end)))
}

/// A compiled signal: its topic's index and a selector per field.
struct Compiled<'a> {
    name: &'static str,
    topic: usize,
    selectors: Vec<Selector>,
    chosen: &'a Chosen,
}

/// Reads every signal's topic once and returns each signal's samples within the span.
fn read_signals<'a>(
    log: &VehicleLog,
    sources: &'a [(&'static str, Chosen)],
    time: TimeSource,
    start: f64,
    end: f64,
    shown: &str,
) -> Result<BTreeMap<&'static str, Samples>, InputError> {
    let compiled: Vec<Compiled<'a>> = sources
        .iter()
        .map(|(name, c)| compile(log, name, c, shown))
        .collect::<Result<_, _>>()?;
    let mut out: BTreeMap<&'static str, Samples> = compiled
        .iter()
        .map(|c| {
            (
                c.name,
                Samples {
                    topic: c.chosen.source.topic.clone(),
                    t: Vec::new(),
                    rows: Vec::new(),
                    stamped: 0,
                    received: 0,
                },
            )
        })
        .collect();
    let mut wanted: Vec<usize> = compiled.iter().map(|c| c.topic).collect();
    wanted.sort_unstable();
    wanted.dedup();
    let mut bad: Option<String> = None;
    log.read(&wanted, &mut |m| {
        let (t, stamped) = message_time(time, m);
        if t < start || t > end {
            return Ok(());
        }
        for c in compiled.iter().filter(|c| c.topic == m.topic) {
            let row: Vec<f64> = c
                .selectors
                .iter()
                .map(|s| s.get(&m.value).unwrap_or(f64::NAN))
                .collect();
            if bad.is_none() && row.iter().all(|x| x.is_nan()) {
                bad = Some(format!(
                    "{} on `{}` at {:.3} s",
                    c.name,
                    c.chosen.source.topic,
                    t - start
                ));
            }
            let s = out.get_mut(c.name).expect("every signal has samples");
            s.t.push(t - start);
            s.rows.push(row);
            *(if stamped {
                &mut s.stamped
            } else {
                &mut s.received
            }) += 1;
        }
        Ok(())
    })
    .map_err(|e| {
        let at = e.offset.map_or(String::new(), |o| format!(" (byte {o})"));
        InputError::file(shown, format!("{}{at}", e.what), e.fix)
    })?;
    if let Some(b) = bad {
        return Err(InputError::file(
            shown,
            format!(
                "{b}: none of the fields is in the message (an array shorter than the fields named?)"
            ),
            "check the fields against `hydrofit inspect` of the log",
        ));
    }
    for s in out.values_mut() {
        sort_by_time(s);
    }
    Ok(out)
}

/// Header stamps need not arrive in order: the samples sorted by time (stable).
fn sort_by_time(s: &mut Samples) {
    if s.t.windows(2).all(|w| w[0] <= w[1]) {
        return;
    }
    let mut idx: Vec<usize> = (0..s.t.len()).collect();
    idx.sort_by(|&a, &b| s.t[a].total_cmp(&s.t[b]));
    s.t = idx.iter().map(|&k| s.t[k]).collect();
    s.rows = idx.iter().map(|&k| s.rows[k].clone()).collect();
}

/// A signal's topic and fields checked against the log: a missing topic or field lists what
/// the log holds.
fn compile<'a>(
    log: &VehicleLog,
    name: &'static str,
    c: &'a Chosen,
    shown: &str,
) -> Result<Compiled<'a>, InputError> {
    let s = &c.source;
    let topic = log.topic(&s.topic).ok_or_else(|| {
        InputError::file(
            shown,
            format!("the log has no topic `{}` (for the {name})", s.topic),
            format!(
                "name one the log has in run.yaml's `log.{name}.topic`:\n{}",
                listing(log)
            ),
        )
    })?;
    let schema = &log.topics[topic].schema;
    let fields = match &s.quaternion {
        Some(q) => ["x", "y", "z", "w"]
            .iter()
            .map(|c| format!("{q}.{c}"))
            .collect(),
        None => s
            .expanded()
            .map_err(|e| InputError::file(shown, e, "name fewer fields"))?,
    };
    if fields.is_empty() {
        return Err(InputError::file(
            shown,
            format!("the {name} on `{}` names no field", s.topic),
            format!("add `fields: [...]` (the message has: {schema})"),
        ));
    }
    let selectors = fields
        .iter()
        .map(|f| {
            schema.select(f).map_err(|e| {
                InputError::file(
                    shown,
                    format!(
                        "the {name} on `{}` ({}): {e}",
                        s.topic, log.topics[topic].type_name
                    ),
                    format!("fix `log.{name}.fields` in run.yaml"),
                )
            })
        })
        .collect::<Result<_, _>>()?;
    Ok(Compiled {
        name,
        topic,
        selectors,
        chosen: c,
    })
}

/// What a log holds, a line per topic, as `hydrofit inspect` prints it.
pub fn listing(log: &VehicleLog) -> String {
    log.topics
        .iter()
        .map(|t| {
            format!(
                "  {}  {}  {} messages, {:.1} Hz",
                t.name,
                t.type_name,
                t.count,
                t.rate_hz()
            )
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// A vector signal in SI units and the body frame, on its own time base.
struct Series {
    topic: String,
    t: Vec<f64>,
    rows: Vec<[f64; 3]>,
}

/// The run's logs from the signals' samples.
fn build(
    out: &mut FromLog,
    sources: &[(&'static str, Chosen)],
    samples: &BTreeMap<&'static str, Samples>,
    thrusters: Option<&Thrusters>,
    shown: &str,
) -> Result<(), InputError> {
    let src = |n: &str| {
        sources
            .iter()
            .find(|(k, _)| *k == n)
            .map(|(_, c)| &c.source)
    };
    for (name, s) in samples {
        let clock = match (s.stamped, s.received) {
            (0, _) => "receive times",
            (_, 0) => "header stamps",
            _ => "header stamps where they agree with the receive times, else receive times",
        };
        out.notes.push(format!(
            "{shown}: the {name} from `{}` ({} samples, {clock})",
            s.topic,
            s.t.len()
        ));
    }
    out.thrust = match (samples.get("command"), samples.get("wrench")) {
        (_, Some(w)) => Some(wrench(w, src("wrench").expect("a source"), shown)?),
        (Some(c), None) => Some(per_thruster(c, thrusters, shown)?),
        (None, None) => None,
    };
    let series = |n: &str, q: Quantity| {
        samples
            .get(n)
            .map(|s| vector(s, src(n).expect("a source"), q))
    };
    let attitude = samples
        .get("attitude")
        .map(|s| attitude(s, src("attitude").expect("a source")));
    let rates = series("rates", Quantity::Rate);
    let accel = series("acceleration", Quantity::Acceleration);
    let velocity = series("velocity", Quantity::Velocity);
    let world = src("velocity")
        .and_then(|s| s.frame)
        .filter(|f| matches!(f, Frame::Ned | Frame::Enu));
    // What the navigation log carries itself (its AHRS's attitude and rates, on its own
    // messages) stays in it, as in nav.csv; the rest is the IMU's.
    let on_nav = |s: &Option<Series>| match (&velocity, s) {
        (Some(v), Some(s)) => world.is_none() && s.topic == v.topic && s.t == v.t,
        _ => false,
    };
    let (att_nav, rates_nav) = (on_nav(&attitude), on_nav(&rates));
    if let Some(v) = velocity {
        let nav_att = attitude.as_ref().filter(|_| att_nav);
        let nav_rates = rates.as_ref().filter(|_| rates_nav);
        out.nav = Some(nav(
            v,
            world,
            attitude.as_ref(),
            [nav_att, nav_rates],
            shown,
        )?);
    }
    let keep = |s: Option<Series>, on: bool| s.filter(|_| !on);
    out.imu = imu(keep(attitude, att_nav), keep(rates, rates_nav), accel);
    out.depth = samples
        .get("depth")
        .map(|s| depth(s, src("depth").expect("a source")));
    out.uwb = samples.get("position").map(|s| position(s, UWB.len() - 1));
    out.sonar = samples.get("sonar").map(|s| position(s, SONAR.len() - 1));
    Ok(())
}

/// A position log (x, y and, where there are `width` = 3 columns, z).
fn position(s: &Samples, width: usize) -> Log {
    let cols: Vec<Vec<f64>> = (0..width)
        .map(|j| {
            s.rows
                .iter()
                .map(|r| r.get(j).copied().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    log_of(&s.t, cols, width)
}

/// A log with the given columns (all-NaN columns marked absent), padded to `width`.
fn log_of(t: &[f64], mut cols: Vec<Vec<f64>>, width: usize) -> Log {
    cols.resize(width, vec![f64::NAN; t.len()]);
    let present = cols.iter().map(|c| c.iter().any(|x| !x.is_nan())).collect();
    Log {
        t: t.to_vec(),
        cols,
        notes: Vec::new(),
        present,
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Quantity {
    Rate,
    Acceleration,
    Velocity,
}

/// A vector's three fields in SI units, and in the body frame (FRD) when given in FLU.
fn vector(s: &Samples, src: &Source, q: Quantity) -> Series {
    let k = match (q, src.unit) {
        (Quantity::Rate, Some(Unit::DegPerS)) => std::f64::consts::PI / 180.0,
        (Quantity::Acceleration, Some(Unit::G)) => G,
        (Quantity::Velocity, Some(Unit::CmPerS)) => 0.01,
        _ => 1.0,
    };
    let flu = src.frame == Some(Frame::Flu);
    let rows = s
        .rows
        .iter()
        .map(|r| {
            let v = [0, 1, 2].map(|j| k * r.get(j).copied().unwrap_or(f64::NAN));
            if flu { [v[0], -v[1], -v[2]] } else { v }
        })
        .collect();
    Series {
        topic: s.topic.clone(),
        t: s.t.clone(),
        rows,
    }
}

/// Roll, pitch, yaw (rad, NED / FRD), from three angles or a quaternion.
fn attitude(s: &Samples, src: &Source) -> Series {
    let k = if src.unit == Some(Unit::Deg) {
        std::f64::consts::PI / 180.0
    } else {
        1.0
    };
    let rows = s
        .rows
        .iter()
        .map(|r| match &src.quaternion {
            Some(_) => super::frames::euler_from_quaternion([r[0], r[1], r[2], r[3]], src.frame),
            None => {
                let e = [0, 1, 2].map(|j| k * r.get(j).copied().unwrap_or(f64::NAN));
                super::frames::euler_to_ned(e, src.frame)
            }
        })
        .collect();
    Series {
        topic: s.topic.clone(),
        t: s.t.clone(),
        rows,
    }
}

/// `s` at the times `t`: linearly interpolated, yaw (column 2 of an attitude) unwrapped
/// first; NaN outside its span.
fn resample(s: &Series, t: &[f64], unwrap_yaw: bool) -> Vec<[f64; 3]> {
    if s.t == t {
        return s.rows.clone();
    }
    let mut rows = s.rows.clone();
    if unwrap_yaw {
        let tau = 2.0 * std::f64::consts::PI;
        let mut offset = 0.0;
        for (row, w) in rows.iter_mut().skip(1).zip(s.rows.windows(2)) {
            offset -= ((w[1][2] - w[0][2]) / tau).round() * tau;
            row[2] = w[1][2] + offset;
        }
    }
    t.iter()
        .map(|&x| {
            if s.t.is_empty() || x < s.t[0] || x > s.t[s.t.len() - 1] {
                return [f64::NAN; 3];
            }
            let k = s.t.partition_point(|v| *v <= x).clamp(1, s.t.len() - 1);
            let (t0, t1) = (s.t[k - 1], s.t[k]);
            let w = if t1 > t0 { (x - t0) / (t1 - t0) } else { 1.0 };
            std::array::from_fn(|j| rows[k - 1][j] + w * (rows[k][j] - rows[k - 1][j]))
        })
        .collect()
}

/// The IMU log (attitude, rates, specific force) on the time base of the rates, or of the
/// attitude when there are no rates, or of the accelerometer; the others interpolated.
fn imu(attitude: Option<Series>, rates: Option<Series>, accel: Option<Series>) -> Option<Log> {
    let base = rates.as_ref().or(attitude.as_ref()).or(accel.as_ref())?;
    let t = base.t.clone();
    let mut cols = Vec::new();
    for (s, yaw) in [(&attitude, true), (&rates, false), (&accel, false)] {
        let rows = s.as_ref().map(|s| resample(s, &t, yaw));
        for j in 0..3 {
            cols.push(match &rows {
                Some(r) => r.iter().map(|x| x[j]).collect(),
                None => vec![f64::NAN; t.len()],
            });
        }
    }
    Some(log_of(&t, cols, IMU.len() - 1))
}

/// The navigation log: the velocity (turned into the body frame with `attitude` when it was
/// logged in a world frame), with its `own` attitude and rates (those on its messages).
fn nav(
    v: Series,
    world: Option<Frame>,
    attitude: Option<&Series>,
    own: [Option<&Series>; 2],
    shown: &str,
) -> Result<Log, InputError> {
    let t = v.t.clone();
    let mut uvw = v.rows.clone();
    if let Some(frame) = world {
        let a = attitude.ok_or_else(|| {
            InputError::file(
                shown,
                format!("the velocity on `{}` is in a world frame, and the log gives no attitude to turn it into the body frame", v.topic),
                "name the attitude's topic in run.yaml's `log.attitude`, or log the body velocity",
            )
        })?;
        let e = resample(a, &t, true);
        uvw = uvw
            .iter()
            .zip(&e)
            .map(|(x, e)| super::frames::world_to_body(*x, *e, frame))
            .collect();
    }
    let mut cols: Vec<Vec<f64>> = (0..3).map(|j| uvw.iter().map(|r| r[j]).collect()).collect();
    for s in own {
        for j in 0..3 {
            cols.push(s.map_or(vec![f64::NAN; t.len()], |s| {
                s.rows.iter().map(|r| r[j]).collect()
            }));
        }
    }
    Ok(log_of(&t, cols, NAV.len() - 1))
}

/// Depth (m, positive down) from a depth, an altitude or a pressure.
fn depth(s: &Samples, src: &Source) -> Log {
    let rho_g = src.density_kg_m3.unwrap_or(1000.0) * G;
    // Absolute pressure: the standard atmosphere at the surface (the run's own surface
    // pressure is not logged; a constant offset in depth does not change the dynamics).
    const ATM_PA: f64 = 101_325.0;
    let f = |x: f64| match src.unit {
        Some(Unit::Cm) => 0.01 * x,
        Some(Unit::UpM) => -x,
        Some(Unit::Pa) => x / rho_g,
        Some(Unit::PaAbs) => (x - ATM_PA) / rho_g,
        Some(Unit::HpaAbs) => (100.0 * x - ATM_PA) / rho_g,
        _ => x,
    };
    let col = s
        .rows
        .iter()
        .map(|r| f(r.first().copied().unwrap_or(f64::NAN)))
        .collect();
    log_of(&s.t, vec![col], DEPTH.len() - 1)
}

/// The commanded body wrench logged as such: X, Y, Z, K, M, N (or X, Y, Z, N), in the body
/// frame (FLU turned into FRD).
fn wrench(s: &Samples, src: &Source, shown: &str) -> Result<Log, InputError> {
    let n = s.rows.first().map_or(0, Vec::len);
    if n != 6 && n != 4 {
        return Err(InputError::file(
            shown,
            format!(
                "the wrench on `{}` has {n} fields; it needs X, Y, Z, K, M, N or X, Y, Z, N",
                s.topic
            ),
            "name six fields (or four) in run.yaml's `log.wrench.fields`",
        ));
    }
    let flip = if src.frame == Some(Frame::Flu) {
        -1.0
    } else {
        1.0
    };
    // THRUST's column order: X, Y, Z, N, K, M.
    let (x, y, z, nn, k, m) = if n == 6 {
        (0, 1, 2, 5, Some(3), Some(4))
    } else {
        (0, 1, 2, 3, None, None)
    };
    let col = |j: usize, sign: f64| s.rows.iter().map(|r| sign * r[j]).collect::<Vec<f64>>();
    let mut cols = vec![col(x, 1.0), col(y, flip), col(z, flip), col(nn, flip)];
    cols.push(k.map_or(vec![f64::NAN; s.t.len()], |k| col(k, 1.0)));
    cols.push(m.map_or(vec![f64::NAN; s.t.len()], |m| col(m, flip)));
    Ok(log_of(&s.t, cols, THRUST.len() - 1))
}

/// The body wrench of per-thruster commands, through the thrusters' curve and allocation.
fn per_thruster(
    s: &Samples,
    thrusters: Option<&Thrusters>,
    shown: &str,
) -> Result<Log, InputError> {
    let t = thrusters.ok_or_else(|| {
        InputError::file(
            shown,
            format!("`{}` carries per-thruster commands, and pipeline.yaml describes no thrusters", s.topic),
            "add vehicle.thrusters to pipeline.yaml (a layout such as bluerov2, or units with position_m and direction, and a curve), or log the body wrench",
        )
    })?;
    let a = t.allocation();
    let n = s.rows.first().map_or(0, Vec::len);
    if n != a.units.len() {
        return Err(InputError::file(
            shown,
            format!(
                "`{}` gives {n} commands per message and vehicle.thrusters has {} units",
                s.topic,
                a.units.len()
            ),
            "name one field per thruster, in vehicle.thrusters' order, in run.yaml's `log.command.fields`",
        ));
    }
    let tau: Vec<[f64; 6]> = s.rows.iter().map(|r| a.wrench(r)).collect();
    // THRUST's column order: X, Y, Z, N, K, M.
    let cols = [0, 1, 2, 5, 3, 4]
        .iter()
        .map(|&j| tau.iter().map(|w| w[j]).collect())
        .collect();
    let mut log = log_of(&s.t, cols, THRUST.len() - 1);
    let moves = |j: usize| a.columns.iter().any(|c| c[j].abs() > 1e-12);
    log.present[4] = moves(3);
    log.present[5] = moves(4);
    Ok(log)
}
