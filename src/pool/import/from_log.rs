//! A run read from the log the vehicle wrote (`log:` in `run.yaml`, see [`super::log_spec`]):
//! each signal's topic read once, cut to the run's span, its time taken from the header stamp
//! or the receive time, converted to SI units and the body frame hydrofit uses (x forward,
//! y starboard, z down), and laid out as the CSV logs of a run folder are, so that the fusion
//! cannot tell a log from its CSV export. Per-thruster commands become the body wrench here,
//! through `vehicle.thrusters`.

mod actuators;
mod aiding;
mod layout;
mod lever;
mod parts;
mod pulse;
mod unmapped;

pub use unmapped::unmapped;

use super::csvlog::Log;
use super::log_spec::{LogSpec, Source, Stack, TimeSource};
use crate::core::diag::InputError;
use crate::core::model::thrusters::{Command, Thrusters};
use hydrofit_logs::{Format, Log as VehicleLog, Selector};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
    /// The files read, each an input of the run: for a folder of topic files (`rostopic echo
    /// -p`) each topic's file; for a `.db3` bag whose types were read from `.msg` files, the
    /// bag and those files. Empty when the log is one file (`path`) and nothing else is read.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub files: Vec<String>,
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
    /// A fin-steered vehicle's actuator commands (`log.actuators`), as `actuators.csv`.
    pub actuators: Option<super::actuators::Actuators>,
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
    let options = hydrofit_logs::Options {
        csv_time_unit_s: spec.time_unit.map(|u| u.seconds()),
        msg_folders: (spec.message_folders.iter())
            .map(|f| resolve(root, dir, f).0)
            .collect(),
    };
    let log = VehicleLog::open_with(&abs, &options).map_err(|e| {
        let at = e.offset.map_or(String::new(), |o| format!(" (byte {o})"));
        InputError::file(&shown, format!("{}{at}", e.what), e.fix)
    })?;
    if spec.time_unit.is_some() && !matches!(log.format, Format::TopicCsv | Format::Csv) {
        return Err(InputError::file(
            &shown,
            format!(
                "`time_unit` is for CSV tables; this is a {}, which says its own times",
                log.format.name()
            ),
            "leave `time_unit` out of run.yaml's `log:`",
        ));
    }
    // A rosbag2 folder was opened through its storage file: that file is the input.
    if log.path != abs
        && let Some(name) = log.path.file_name()
    {
        shown = format!("{}/{}", shown.trim_end_matches('/'), name.to_string_lossy());
    }
    let mut out = FromLog::default();
    let sources = sources(&log, spec, thrusters, &mut out.notes);
    let timed = timed_topics(&log, &sources);
    let (start, end) = span(&log, &timed, spec, &shown)?;
    let mut samples = read_signals(&log, &sources, spec.time, start, end, &shown)?;
    aiding::keep_aided(&mut samples, &shown, &mut out.notes);
    for n in log.notes_for(&timed) {
        out.notes.push(format!("{shown}: {n}"));
    }
    layout::build(&mut out, &sources, &samples, thrusters, &shown)?;
    let read_from = log.files(&timed);
    out.source = Some(LogSource {
        path: shown,
        format: log.format.name().into(),
        topics: sources
            .iter()
            .map(|(k, s)| (k.to_string(), s.source.topic.clone()))
            .collect(),
        span_s: [start, end].map(|x| ((x - log_start(&log, &timed)) * 1e6).round() / 1e6),
        files: match is_topic_folder(&log) || read_from.len() > 1 {
            true => (read_from.iter())
                .map(|f| resolve(root, dir, &f.to_string_lossy()).1)
                .collect(),
            false => Vec::new(),
        },
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
#[derive(Clone)]
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
    let normalised = thrusters.is_some_and(|t| t.command == Command::Normalised);
    let mut out: Vec<(&'static str, Chosen)> = Vec::new();
    let mut missing: Vec<(&'static str, String)> = Vec::new();
    for (k, source) in super::stacks::defaults(stack, n, normalised) {
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
    aiding::add_status(log, &mut out, notes);
    missing.dedup_by(|a, b| a.0 == b.0);
    for (signal, topic) in missing {
        notes.push(format!(
            "no {signal}: the {} stack's topic `{topic}` is not in the log (name another in run.yaml's `log.{signal}`)",
            stack.name()
        ));
    }
    out
}

fn default_stack(log: &VehicleLog) -> Stack {
    match log.format {
        Format::DataFlash => Stack::Ardusub,
        Format::Tlog => Stack::ArdusubTlog,
        Format::Ulog => Stack::Px4,
        _ if log.topics.iter().any(|t| t.name.starts_with("/mavros/")) => Stack::Mavros,
        _ if log.topics.iter().any(|t| t.name.starts_with("/fmu/")) => Stack::Px4,
        _ => Stack::None,
    }
}

/// Whether the log is a folder of CSV files (`rostopic echo -p`'s or others), one topic each.
fn is_topic_folder(log: &VehicleLog) -> bool {
    matches!(log.format, Format::TopicCsv | Format::Csv) && log.path.is_dir()
}

/// The topics whose times make the log's span: all of them, but in a folder of topic files
/// (`rostopic echo -p`, often every run of a day side by side) those the run reads.
fn timed_topics(log: &VehicleLog, sources: &[(&'static str, Chosen)]) -> Vec<usize> {
    if !is_topic_folder(log) {
        return (0..log.topics.len()).collect();
    }
    let mut out: Vec<usize> = (sources.iter())
        .flat_map(|(_, c)| c.source.topics())
        .filter_map(|t| log.topic(&t))
        .collect();
    out.sort_unstable();
    out.dedup();
    // None of them there: the signal that names a missing topic says so, listing the topics.
    if out.is_empty() {
        return (0..log.topics.len()).collect();
    }
    out
}

/// The time of the log's first timed message. A DataFlash log's format and parameter records
/// carry no time of their own (they read as the time of the message before them): only
/// messages with a `TimeUS` or `TimeMS` field count; only the topics `timed_in`.
fn log_start(log: &VehicleLog, timed_in: &[usize]) -> f64 {
    let timed = |t: &hydrofit_logs::Topic| {
        log.format != Format::DataFlash
            || t.schema
                .fields
                .iter()
                .any(|f| f.name == "TimeUS" || f.name == "TimeMS")
    };
    (timed_in.iter().map(|&i| &log.topics[i]))
        .filter(|t| t.count > 0 && timed(t))
        .map(|t| t.first_s)
        .fold(f64::INFINITY, f64::min)
}

/// The run's span in the log's clock.
fn span(
    log: &VehicleLog,
    timed: &[usize],
    spec: &LogSpec,
    shown: &str,
) -> Result<(f64, f64), InputError> {
    let start = log_start(log, timed);
    if !start.is_finite() {
        return Err(InputError::file(
            shown,
            "the log holds no messages",
            "record the run again, or point `log.file` at the right log",
        ));
    }
    let end = (timed.iter().map(|&i| &log.topics[i]))
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

/// A compiled signal, or one part of a signal spread over several topics: its topic's index
/// and a selector per field.
struct Compiled<'a> {
    name: &'static str,
    topic: usize,
    selectors: Vec<Selector>,
    chosen: &'a Chosen,
    /// Which of the signal's topics this is, and how many it has.
    part: usize,
    parts: usize,
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
        .collect::<Result<Vec<_>, _>>()?
        .into_iter()
        .flatten()
        .collect();
    // The parts of signals spread over several topics, each message as it came.
    let mut pieces: BTreeMap<&'static str, Vec<parts::Piece>> = BTreeMap::new();
    let mut out = no_samples(&compiled);
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
            if c.parts > 1 {
                pieces.entry(c.name).or_default().push(parts::Piece {
                    t: t - start,
                    part: c.part,
                    row,
                });
            } else {
                s.t.push(t - start);
                s.rows.push(row);
            }
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
        return Err(no_field(shown, &b));
    }
    for (name, p) in pieces {
        let s = out.get_mut(name).expect("a signal");
        (s.t, s.rows) = parts::merged(p, parts_of(&compiled, name));
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

/// A message with none of the fields named (`what`: the signal, its topic and the time).
fn no_field(shown: &str, what: &str) -> InputError {
    InputError::file(
        shown,
        format!(
            "{what}: none of the fields is in the message (an array shorter than the fields named?)"
        ),
        "check the fields against `hydrofit inspect` of the log",
    )
}

/// Each compiled signal's samples, none read yet.
fn no_samples(compiled: &[Compiled]) -> BTreeMap<&'static str, Samples> {
    (compiled.iter())
        .map(|c| {
            let s = Samples {
                topic: c.chosen.source.topic.clone(),
                t: Vec::new(),
                rows: Vec::new(),
                stamped: 0,
                received: 0,
            };
            (c.name, s)
        })
        .collect()
}

/// How many topics signal `name` is spread over.
fn parts_of(compiled: &[Compiled], name: &str) -> usize {
    compiled
        .iter()
        .find(|c| c.name == name)
        .map_or(1, |c| c.parts)
}

/// A signal's topics and fields checked against the log, one compiled part per topic: a
/// missing topic or field lists what the log holds.
fn compile<'a>(
    log: &VehicleLog,
    name: &'static str,
    c: &'a Chosen,
    shown: &str,
) -> Result<Vec<Compiled<'a>>, InputError> {
    let topics = c.source.topics();
    let parts = topics.len();
    (topics.iter().enumerate())
        .map(|(part, topic)| {
            let mut one = compile_part(log, name, c, shown, topic)?;
            (one.part, one.parts) = (part, parts);
            Ok(one)
        })
        .collect()
}

/// One topic of a signal (see [`compile`]).
fn compile_part<'a>(
    log: &VehicleLog,
    name: &'static str,
    c: &'a Chosen,
    shown: &str,
    topic_name: &str,
) -> Result<Compiled<'a>, InputError> {
    let s = &c.source;
    let topic = log.topic(topic_name).ok_or_else(|| {
        InputError::file(
            shown,
            format!("the log has no topic `{topic_name}` (for the {name})"),
            format!(
                "name one the log has in run.yaml's `log.{name}.topic`:\n{}",
                listing(log)
            ),
        )
    })?;
    if let Some((what, fix)) = log.undecodable(topic) {
        let type_name = &log.topics[topic].type_name;
        return Err(InputError::file(
            shown,
            format!("the {name} on `{topic_name}` ({type_name}) cannot be read: {what}"),
            fix,
        ));
    }
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
    actuators::check_columns(name, s, fields.len(), shown)?;
    aiding::check_valid(name, s, shown).and_then(|_| lever::check_at(name, s, shown))?;
    if name == "attitude" && !matches!(fields.len(), 3 | 4) {
        return Err(InputError::file(
            shown,
            format!(
                "the attitude on `{}` names {} fields",
                s.topic,
                fields.len()
            ),
            "name three angles (roll, pitch, yaw), four quaternion components (x, y, z, w), or `quaternion: <path>`",
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
        part: 0,
        parts: 1,
    })
}

/// What a log holds, a line per topic, as `hydrofit inspect` prints it, and the reader's
/// notes (a folder's CSV files that are not topics).
pub fn listing(log: &VehicleLog) -> String {
    let notes = log.notes().into_iter().map(|n| format!("  note: {n}"));
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
        .chain(notes)
        .collect::<Vec<_>>()
        .join("\n")
}
