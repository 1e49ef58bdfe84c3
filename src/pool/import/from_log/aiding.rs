//! Whether an autopilot's velocity estimate was measured. ArduPilot's EKF reports a velocity
//! whatever aids it: with no DVL, no position fix and no optical flow it runs in
//! constant-position mode, and its horizontal velocity is then inertial dead reckoning held
//! near zero, not a measurement of the vehicle's motion. The filter says so in its status
//! word, logged beside the velocity: MAVLink's `EKF_STATUS_REPORT.flags` in a telemetry log
//! (for `LOCAL_POSITION_NED` and `GLOBAL_POSITION_INT`), the `SS` field of `XKF4` (EKF3) or
//! `NKF4` (EKF2) in a DataFlash log (for `XKF1` / `NKF1`'s `VN`, `VE`, `VD`). A velocity sample
//! taken while the status says the horizontal velocity was not aided is left out, with a
//! note; the run keeps the samples the filter did measure.
//!
//! Both words share their low bits (ArduPilot's `nav_filter_status`, MAVLink's
//! `EKF_STATUS_FLAGS`): bit 1 the horizontal velocity is good, bit 7 constant-position mode.
//! Through mavros, the `ekf_status` plugin of mavros_extras publishes the MAVLink message as
//! `mavros_msgs/EKFStatusReport`; a bag without it leaves `local_position/odom` unchecked.
//! PX4 says it on the velocity's own message: `vehicle_local_position.v_xy_valid` (in a ULog,
//! and on the ROS 2 bridge's `/fmu/out/vehicle_local_position`).
//!
//! A DVL says it of its own velocity: without bottom lock (too high, too close, too few
//! beams) its velocity is not a measurement, and its message says so (Water Linked's
//! `dvl_msgs/DVL.velocity_valid`, or the field `log.velocity.valid` names). Those samples are
//! left out the same way. So are the depths PX4's EKF marks not valid
//! (`vehicle_local_position.z_valid`, false until it has a height source), or those a field
//! named by `log.depth.valid` marks.

use super::{Chosen, Samples};
use crate::core::diag::InputError;
use crate::pool::import::log_spec::Source;
use hydrofit_logs::{Format, Log as VehicleLog};
use std::collections::BTreeMap;

/// How a status says the horizontal velocity was aided.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Rule {
    /// ArduPilot's status word: bit 1 set, bit 7 clear.
    Bits,
    /// PX4's flag: not zero.
    Flag,
    /// A DVL's validity flag on its own messages: not zero.
    Lock,
    /// A depth's validity flag (PX4's `z_valid`, or `log.depth.valid`): not zero.
    Depth,
}

impl Rule {
    /// The signal name the status is read under (never a signal of `run.yaml`).
    fn signal(self) -> &'static str {
        match self {
            Rule::Bits => "ekf_status",
            Rule::Flag => "velocity_valid",
            Rule::Lock => "dvl_valid",
            Rule::Depth => "depth_valid",
        }
    }

    /// The signal whose samples the status judges.
    fn target(self) -> &'static str {
        match self {
            Rule::Depth => "depth",
            _ => "velocity",
        }
    }

    /// Why a sample the rule marks is not a measurement.
    fn why(self, status: &str) -> String {
        match self {
            Rule::Lock => format!(
                "the DVL marks them not valid (its validity flag on `{status}` false: no bottom lock, too close or too few beams)"
            ),
            Rule::Depth => format!(
                "the log marks them not valid (the validity flag on `{status}` false: an estimator with no height source yet)"
            ),
            _ => format!(
                "the autopilot's filter status (`{status}`) says its horizontal velocity was not aided (no DVL or position fix: the velocity is then dead reckoning, not a measurement)"
            ),
        }
    }

    /// What to do when the rule leaves out every sample of a run.
    fn fix(self) -> &'static str {
        match self {
            Rule::Lock => {
                "the DVL measured nothing in this run's span: check its altitude and `span_s`, or give the run a position (UWB, sonar)"
            }
            Rule::Depth => "map a pressure sensor's own topic in run.yaml's `log.depth`",
            _ => {
                "map a DVL's own topic in run.yaml's `log.velocity`, or give the run a position (UWB, sonar)"
            }
        }
    }

    fn aided(self, word: f64) -> bool {
        let w = word as u32;
        match self {
            Rule::Bits => w & HORIZONTAL_VELOCITY != 0 && w & CONSTANT_POSITION == 0,
            Rule::Flag | Rule::Lock | Rule::Depth => word != 0.0,
        }
    }
}

const RULES: [Rule; 4] = [Rule::Bits, Rule::Flag, Rule::Lock, Rule::Depth];

/// `EKF_STATUS_FLAGS` / `nav_filter_status`: horizontal velocity estimate good.
const HORIZONTAL_VELOCITY: u32 = 1 << 1;
/// Constant-position mode: no aiding at all, the filter holds its position.
const CONSTANT_POSITION: u32 = 1 << 7;

/// Where the filter's status for a velocity is.
enum Status {
    /// In the log: its topic and field, and how it says aided.
    Found(Source, Rule),
    /// The velocity is an autopilot's estimate, and the log holds no status for it.
    Missing,
    /// The velocity is not an estimate this module knows (a DVL's own, a tracker's).
    NotEstimate,
}

/// The filter's status for the velocity `velocity`: the status topic of the same filter
/// instance (or MAVLink sender), its status word.
fn status_source(log: &VehicleLog, velocity: &Source) -> Status {
    let found = |s: Option<(Source, Rule)>| s.map_or(Status::Missing, |(s, r)| Status::Found(s, r));
    let topic = velocity.topic.as_str();
    let lock = |f: &str| Status::Found(Source::new(topic, &[f]), Rule::Lock);
    if let Some(f) = &velocity.valid {
        return lock(f);
    }
    let i = log.topic(topic);
    if i.is_some_and(|i| usable(log, i, "velocity_valid").is_some()) {
        return lock("velocity_valid");
    }
    if topic.ends_with("vehicle_local_position") {
        let flag = i.and_then(|i| usable(log, i, "v_xy_valid"));
        return found(flag.map(|_| (Source::new(topic, &["v_xy_valid"]), Rule::Flag)));
    }
    let (base, instance) = match topic.split_once('[') {
        Some((b, rest)) => (b, format!("[{rest}")),
        None => (topic, String::new()),
    };
    let (status, field) = match (log.format, base) {
        (Format::Tlog, "LOCAL_POSITION_NED" | "GLOBAL_POSITION_INT") => {
            ("EKF_STATUS_REPORT", "flags")
        }
        (Format::DataFlash, "XKF1") => ("XKF4", "SS"),
        (Format::DataFlash, "NKF1") => ("NKF4", "SS"),
        (Format::DataFlash | Format::Tlog, _) => return Status::NotEstimate,
        _ if topic.contains("mavros/") => {
            return match mavros_status(log) {
                Some((s, r)) => Status::Found(s, r),
                None if topic.contains("mavros/local_position")
                    || topic.contains("mavros/global_position") =>
                {
                    Status::Missing
                }
                None => Status::NotEstimate,
            };
        }
        _ => return Status::NotEstimate,
    };
    // A telemetry log names a message by its sender only when several send it.
    found(
        [format!("{status}{instance}"), status.to_string()]
            .into_iter()
            .find_map(|t| {
                let i = log.topic(&t)?;
                usable(log, i, field)?;
                Some((Source::new(&t, &[field]), Rule::Bits))
            }),
    )
}

/// mavros's `ekf_status` plugin (mavros_extras): a topic of type `mavros_msgs/EKFStatusReport`
/// with the MAVLink message's `flags`, wherever the launch file put it.
fn mavros_status(log: &VehicleLog) -> Option<(Source, Rule)> {
    (log.topics.iter().enumerate())
        .filter(|(_, t)| t.type_name.to_lowercase().contains("ekfstatus"))
        .find_map(|(i, t)| {
            usable(log, i, "flags")?;
            Some((Source::new(&t.name, &["flags"]), Rule::Bits))
        })
}

/// Whether topic `i` can be read and has `field` (a firmware or a message version may lack
/// it: then there is nothing to check).
fn usable(log: &VehicleLog, i: usize, field: &str) -> Option<()> {
    log.undecodable(i).is_none().then_some(())?;
    log.topics[i].schema.select(field).ok().map(|_| ())
}

/// Whether signal `name` is a status this module reads (not a signal of `run.yaml`).
pub(super) fn is_status(name: &str) -> bool {
    RULES.iter().any(|r| r.signal() == name)
}

/// Adds the filter's status to the signals read, when the velocity is an autopilot's estimate
/// whose log carries it; says so in `notes` when it is one whose log does not. Adds the
/// depth's validity flag where it has one.
pub(super) fn add_status(
    log: &VehicleLog,
    sources: &mut Vec<(&'static str, Chosen)>,
    notes: &mut Vec<String>,
) {
    if let Some(source) = depth_flag(log, sources) {
        let explicit = false;
        sources.push((Rule::Depth.signal(), Chosen { source, explicit }));
    }
    let Some(velocity) = (sources.iter())
        .find(|(k, _)| *k == "velocity")
        .map(|(_, c)| c.source.clone())
    else {
        return;
    };
    match status_source(log, &velocity) {
        Status::Found(source, rule) => {
            let explicit = false;
            sources.push((rule.signal(), Chosen { source, explicit }));
        }
        Status::Missing => notes.push(format!(
            "the velocity on `{}` is the autopilot's estimate, and the log holds no filter status to say a DVL or position fix aided it (mavros: record mavros_extras' `ekf_status` topic too); where nothing aided it, it is dead reckoning, not a measurement",
            velocity.topic
        )),
        Status::NotEstimate => {}
    }
}

/// The depth's validity flag: the field `log.depth.valid` names, or PX4's `z_valid` beside
/// `vehicle_local_position`'s `z`.
fn depth_flag(log: &VehicleLog, sources: &[(&'static str, Chosen)]) -> Option<Source> {
    let depth = &sources.iter().find(|(k, _)| *k == "depth")?.1.source;
    let topic = depth.topic.as_str();
    if let Some(f) = &depth.valid {
        return Some(Source::new(topic, &[f]));
    }
    let px4 = topic.ends_with("vehicle_local_position") && depth.fields == ["z"];
    px4.then(|| usable(log, log.topic(topic)?, "z_valid"))??;
    Some(Source::new(topic, &["z_valid"]))
}

/// `valid` names a velocity's or a depth's validity flag; on another signal it is an error.
pub(super) fn check_valid(name: &str, s: &Source, shown: &str) -> Result<(), InputError> {
    if name == "velocity" || name == "depth" || s.valid.is_none() {
        return Ok(());
    }
    Err(InputError::file(
        shown,
        format!("the {name} on `{}` has `valid`", s.topic),
        format!(
            "`valid` names a velocity's or a depth's validity flag (`log.velocity.valid`, `log.depth.valid`); leave it out of `log.{name}`"
        ),
    ))
}

/// Leaves out the samples each status marks as not valid (the velocity's filter status or
/// flag, the depth's flag; the status in force is the last one at or before the sample, and
/// a sample before the first status is kept), and takes the statuses out of the signals.
/// Says what was left out in `notes`.
pub(super) fn keep_aided(
    samples: &mut BTreeMap<&'static str, Samples>,
    shown: &str,
    notes: &mut Vec<String>,
) {
    for rule in RULES {
        if let Some(status) = samples.remove(rule.signal()) {
            keep(samples, &status, rule, shown, notes);
        }
    }
}

/// [`keep_aided`] for one status.
fn keep(
    samples: &mut BTreeMap<&'static str, Samples>,
    status: &Samples,
    rule: Rule,
    shown: &str,
    notes: &mut Vec<String>,
) {
    let target = rule.target();
    let Some(v) = samples.get_mut(target) else {
        return;
    };
    let aided = |t: f64| {
        let k = status.t.partition_point(|s| *s <= t);
        let Some(word) = k.checked_sub(1).and_then(|k| status.rows[k].first()) else {
            return true;
        };
        rule.aided(*word)
    };
    let keep: Vec<bool> = v.t.iter().map(|&t| aided(t)).collect();
    let dropped = keep.iter().filter(|k| !**k).count();
    if dropped == 0 {
        return;
    }
    let total = keep.len();
    let topic = v.topic.clone();
    let why = rule.why(&status.topic);
    if dropped == total {
        samples.remove(target);
        notes.push(format!(
            "{shown}: no {target}: {why} for all {total} samples of `{topic}`; {}",
            rule.fix()
        ));
        return;
    }
    let (t, rows) = (std::mem::take(&mut v.t), std::mem::take(&mut v.rows));
    (v.t, v.rows) = (t.into_iter().zip(rows).zip(&keep))
        .filter(|(_, k)| **k)
        .map(|(s, _)| s)
        .unzip();
    notes.push(format!(
        "{shown}: {dropped} of {total} {target} samples of `{topic}` left out: {why} at their times"
    ));
}

#[cfg(test)]
mod tests;
