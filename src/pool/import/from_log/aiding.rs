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
//! left out the same way.

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
}

impl Rule {
    /// The signal name the status is read under (never a signal of `run.yaml`).
    fn signal(self) -> &'static str {
        match self {
            Rule::Bits => "ekf_status",
            Rule::Flag => "velocity_valid",
            Rule::Lock => "dvl_valid",
        }
    }

    /// Why a sample the rule marks is not a measurement.
    fn why(self, status: &str) -> String {
        match self {
            Rule::Lock => format!(
                "the DVL marks them not valid (its validity flag on `{status}` false: no bottom lock, too close or too few beams)"
            ),
            _ => format!(
                "the autopilot's filter status (`{status}`) says its horizontal velocity was not aided (no DVL or position fix: the velocity is then dead reckoning, not a measurement)"
            ),
        }
    }

    fn aided(self, word: f64) -> bool {
        let w = word as u32;
        match self {
            Rule::Bits => w & HORIZONTAL_VELOCITY != 0 && w & CONSTANT_POSITION == 0,
            Rule::Flag | Rule::Lock => word != 0.0,
        }
    }
}

const RULES: [Rule; 3] = [Rule::Bits, Rule::Flag, Rule::Lock];

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
        let flag = (log.topic(topic)).and_then(|i| usable(log, i, "v_xy_valid"));
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
/// whose log carries it; says so in `notes` when it is one whose log does not.
pub(super) fn add_status(
    log: &VehicleLog,
    sources: &mut Vec<(&'static str, Chosen)>,
    notes: &mut Vec<String>,
) {
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

/// `valid` names a velocity's validity flag; on another signal it is an error.
pub(super) fn check_valid(name: &str, s: &Source, shown: &str) -> Result<(), InputError> {
    if name == "velocity" || s.valid.is_none() {
        return Ok(());
    }
    Err(InputError::file(
        shown,
        format!("the {name} on `{}` has `valid`", s.topic),
        format!(
            "`valid` names a velocity's validity flag (`log.velocity.valid`); leave it out of `log.{name}`"
        ),
    ))
}

/// Leaves out the velocity samples the filter's status marks as not aided (the status in
/// force is the last one at or before the sample; a sample before the first status is kept),
/// and takes the status out of the signals. Says what was left out in `notes`.
pub(super) fn keep_aided(
    samples: &mut BTreeMap<&'static str, Samples>,
    shown: &str,
    notes: &mut Vec<String>,
) {
    let Some((status, rule)) = RULES
        .into_iter()
        .find_map(|r| Some((samples.remove(r.signal())?, r)))
    else {
        return;
    };
    let Some(v) = samples.get_mut("velocity") else {
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
        samples.remove("velocity");
        notes.push(format!(
            "{shown}: no velocity: {why} for all {total} samples of `{topic}`; {}",
            match rule {
                Rule::Lock => "the DVL measured nothing in this run's span: check its altitude and `span_s`, or give the run a position (UWB, sonar)",
                _ => "map a DVL's own topic in run.yaml's `log.velocity`, or give the run a position (UWB, sonar)",
            }
        ));
        return;
    }
    let (t, rows) = (std::mem::take(&mut v.t), std::mem::take(&mut v.rows));
    (v.t, v.rows) = (t.into_iter().zip(rows).zip(&keep))
        .filter(|(_, k)| **k)
        .map(|(s, _)| s)
        .unzip();
    notes.push(format!(
        "{shown}: {dropped} of {total} velocity samples of `{topic}` left out: {why} at their times"
    ));
}

#[cfg(test)]
mod tests {
    use super::super::super::log_spec::LogSpec;
    use super::super::read;
    use hydrofit_logs::tlog::Writer;

    const T0: u64 = 1_700_000_000_000_000;

    /// A telemetry log of 10 s: attitude at 20 Hz, `LOCAL_POSITION_NED` at 10 Hz (0.3 m/s
    /// north), and the filter's status at 2 Hz, its flags from `flags(t)`.
    fn tlog(dir: &std::path::Path, flags: impl Fn(f64) -> f64) {
        let mut w = Writer::new(true);
        for k in 0..200u64 {
            let t = k as f64 * 0.05;
            let us = T0 + k * 50_000;
            let ms = (k * 50) as f64;
            let att = [ms, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
            w.write(us, (1, 1), "ATTITUDE", &att).unwrap();
            if k % 2 == 0 {
                let lp = [ms, 0.0, 0.0, 0.0, 0.3, 0.0, 0.0];
                w.write(us, (1, 1), "LOCAL_POSITION_NED", &lp).unwrap();
            }
            if k % 10 == 0 {
                let st = [flags(t), 0.03, 0.005, 0.02, 0.01, 0.0];
                w.write(us, (1, 1), "EKF_STATUS_REPORT", &st).unwrap();
            }
        }
        std::fs::write(dir.join("run.tlog"), w.into_bytes()).unwrap();
    }

    fn spec() -> LogSpec {
        let y = "file: run.tlog\nstack: none\nattitude: {topic: ATTITUDE, fields: [roll, pitch, yaw]}\nvelocity: {topic: LOCAL_POSITION_NED, fields: [vx, vy, vz], frame: ned}\n";
        serde_yaml_ng::from_str(y).unwrap()
    }

    #[test]
    fn velocity_the_filter_did_not_aid_is_left_out() {
        let d = tempfile::tempdir().unwrap();
        // Aided (831, ArduSub with a DVL), then constant-position mode for 3 s (167: the
        // horizontal-velocity bit still set), then aided again.
        tlog(d.path(), |t| {
            if (5.0..8.0).contains(&t) {
                167.0
            } else {
                831.0
            }
        });
        let run = read(d.path(), ".", &spec(), None).unwrap();
        let nav = run.nav.expect("the aided samples");
        // 100 samples at 10 Hz; those at 5.0 .. 7.9 s (30) follow a constant-position status.
        assert_eq!(nav.len(), 70);
        assert!(nav.t.iter().all(|t| !(5.0 - 1e-9..8.0 - 1e-9).contains(t)));
        assert!(nav.cols[0].iter().all(|u| (u - 0.3).abs() < 1e-6));
        let notes = run.notes.join("\n");
        assert!(
            notes.contains("30 of 100 velocity samples of `LOCAL_POSITION_NED` left out")
                && notes.contains("`EKF_STATUS_REPORT`"),
            "{notes}"
        );
        let source = run.source.expect("a source");
        assert_eq!(source.topics["ekf_status"], "EKF_STATUS_REPORT");

        // Never aided: no navigation log, and a note that says what to do.
        tlog(d.path(), |_| 167.0);
        let run = read(d.path(), ".", &spec(), None).unwrap();
        assert!(run.nav.is_none());
        let notes = run.notes.join("\n");
        assert!(
            notes.contains("no velocity") && notes.contains("for all 100 samples"),
            "{notes}"
        );
        // Without the horizontal-velocity bit (an EKF still aligning), likewise.
        tlog(d.path(), |_| 1.0 + 4.0 + 32.0);
        assert!(read(d.path(), ".", &spec(), None).unwrap().nav.is_none());

        // Aided throughout: every sample, no note.
        tlog(d.path(), |_| 831.0);
        let run = read(d.path(), ".", &spec(), None).unwrap();
        assert_eq!(run.nav.expect("a navigation log").len(), 100);
        assert!(!run.notes.join("\n").contains("left out"));
    }

    /// A mavros bag (ROS 1) whose `ekf_status` plugin published the filter's status: the
    /// default `local_position/odom` velocity is kept only while it was aided.
    #[test]
    fn mavros_velocity_is_checked_against_the_ekf_status_plugin() {
        use hydrofit_logs::write::{self, BagCompression, BagWriter};
        let d = tempfile::tempdir().unwrap();
        let mut bag = BagWriter::create(&d.path().join("run.bag"), BagCompression::None).unwrap();
        let odom = bag
            .add_topic("/mavros/local_position/odom", "nav_msgs/Odometry")
            .unwrap();
        let def = "uint16 flags\nfloat32 velocity_variance\n";
        let status = "/mavros/ekf_status/ekf_status_report";
        let ekf = (bag.add_connection(status, "mavros_msgs/EKFStatusReport", def)).unwrap();
        let (s_odom, s_ekf) = (
            bag.schema(odom).unwrap().clone(),
            bag.schema(ekf).unwrap().clone(),
        );
        for k in 0..100 {
            let t = 1.7e9 + k as f64 * 0.1;
            if k % 5 == 0 {
                // Aided for the first 6 s, then constant-position mode.
                let flags = if k < 60 { 831.0 } else { 167.0 };
                let m = write::message(&s_ekf, &[("flags", flags)]).unwrap();
                bag.write(ekf, t, &m).unwrap();
            }
            let v = [("header.stamp", t), ("twist.twist.linear.x", 0.3)];
            bag.write(odom, t, &write::message(&s_odom, &v).unwrap())
                .unwrap();
        }
        bag.finish().unwrap();
        let spec: LogSpec = serde_yaml_ng::from_str("file: run.bag\n").unwrap();
        let run = read(d.path(), ".", &spec, None).unwrap();
        assert_eq!(run.nav.expect("the aided samples").len(), 60);
        let notes = run.notes.join("\n");
        assert!(notes.contains(&format!("`{status}`")), "{notes}");
    }

    /// Without the `ekf_status` plugin's topic the mavros velocity is read as it is, and the
    /// run's notes say that nothing tells whether it was measured.
    #[test]
    fn an_unchecked_mavros_velocity_is_said() {
        use hydrofit_logs::write::{self, BagCompression, BagWriter};
        let d = tempfile::tempdir().unwrap();
        let mut bag = BagWriter::create(&d.path().join("run.bag"), BagCompression::None).unwrap();
        let topic = "/mavros/local_position/odom";
        let odom = bag.add_topic(topic, "nav_msgs/Odometry").unwrap();
        let schema = bag.schema(odom).unwrap().clone();
        for k in 0..20 {
            let t = 1.7e9 + k as f64 * 0.1;
            let v = [("header.stamp", t), ("twist.twist.linear.x", 0.3)];
            bag.write(odom, t, &write::message(&schema, &v).unwrap())
                .unwrap();
        }
        bag.finish().unwrap();
        let spec: LogSpec = serde_yaml_ng::from_str("file: run.bag\n").unwrap();
        let run = read(d.path(), ".", &spec, None).unwrap();
        assert_eq!(run.nav.expect("the velocity").len(), 20);
        let notes = run.notes.join("\n");
        assert!(notes.contains("holds no filter status"), "{notes}");
    }

    /// A Water Linked DVL's own messages (`dvl_msgs/DVL`): the samples it marks not valid
    /// (no bottom lock; their velocity is junk) are left out with no mapping of the flag; a
    /// flag of another name is named by `valid`; a DVL never locked gives no velocity.
    #[test]
    fn dvl_samples_without_bottom_lock_are_left_out() {
        use hydrofit_logs::write::{self, McapCompression, McapWriter};
        let d = tempfile::tempdir().unwrap();
        let write_dvl = |flag: &str, valid: &dyn Fn(usize) -> bool| {
            let path = d.path().join("run.mcap");
            let mut bag = McapWriter::create(&path, McapCompression::None).unwrap();
            let def = format!(
                "std_msgs/Header header\ngeometry_msgs/Vector3 velocity\nfloat64 fom\nbool {flag}\n================================================================================\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n================================================================================\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n================================================================================\nMSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n"
            );
            let id = (bag.add_channel("/dvl/data", "dvl_msgs/msg/DVL", &def)).unwrap();
            let schema = bag.schema(id).unwrap().clone();
            for k in 0..50 {
                let t = 1.7e9 + k as f64 * 0.1;
                let (ok, u) = if valid(k) { (1.0, 0.3) } else { (0.0, -32.768) };
                let v = [("header.stamp", t), ("velocity.x", u), (flag, ok)];
                bag.write(id, t, &write::message(&schema, &v).unwrap())
                    .unwrap();
            }
            bag.finish().unwrap();
        };
        let spec = |extra: &str| -> LogSpec {
            let y = format!(
                "file: run.mcap\nvelocity: {{topic: /dvl/data, fields: [velocity.x, velocity.y, velocity.z]{extra}}}\n"
            );
            serde_yaml_ng::from_str(&y).unwrap()
        };
        // Bottom lock lost for 1 s of 5.
        write_dvl("velocity_valid", &|k| !(20..30).contains(&k));
        let run = read(d.path(), ".", &spec(""), None).unwrap();
        let nav = run.nav.expect("the valid samples");
        assert_eq!(nav.len(), 40);
        assert!(nav.cols[0].iter().all(|u| (u - 0.3).abs() < 1e-9));
        let notes = run.notes.join("\n");
        assert!(
            notes.contains("10 of 50 velocity samples of `/dvl/data` left out")
                && notes.contains("the DVL marks them not valid"),
            "{notes}"
        );
        // Another driver's flag, named.
        write_dvl("bottom_lock", &|k| k % 2 == 0);
        let run = read(d.path(), ".", &spec(", valid: bottom_lock"), None).unwrap();
        assert_eq!(run.nav.expect("the locked samples").len(), 25);
        // Unnamed, that flag is not known: every sample is read.
        let run = read(d.path(), ".", &spec(""), None).unwrap();
        assert_eq!(run.nav.expect("every sample").len(), 50);
        // A flag the message lacks is an error naming it.
        let e = read(d.path(), ".", &spec(", valid: locked"), None).unwrap_err();
        assert!(e.to_string().contains("locked"), "{e}");
        // `valid` on another signal is an error.
        let y = "file: run.mcap\ndepth: {topic: /dvl/data, fields: [velocity.z], valid: fom}\n";
        let e = read(d.path(), ".", &serde_yaml_ng::from_str(y).unwrap(), None).unwrap_err();
        assert!(e.to_string().contains("`valid` names a velocity's"), "{e}");
        // Never locked: no velocity, and a note that says so.
        write_dvl("velocity_valid", &|_| false);
        let run = read(d.path(), ".", &spec(""), None).unwrap();
        assert!(run.nav.is_none());
        let notes = run.notes.join("\n");
        assert!(notes.contains("the DVL measured nothing"), "{notes}");
    }

    /// PX4's ROS 2 bridge (`/fmu/out/...`, px4_msgs): the `px4` stack is the default, its
    /// quaternion (w, x, y, z) is read as NED, and `v_xy_valid` on the velocity's own message
    /// says which samples were aided.
    #[test]
    fn px4_ros2_topics_read_by_default_with_their_validity_flag() {
        use hydrofit_logs::write::{self, McapCompression, McapWriter};
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("run.mcap");
        let mut bag = McapWriter::create(&path, McapCompression::None).unwrap();
        let lp_def =
            "uint64 timestamp\nfloat32 z\nfloat32 vx\nfloat32 vy\nfloat32 vz\nbool v_xy_valid\n";
        let lp = "/fmu/out/vehicle_local_position";
        let lp = (bag.add_channel(lp, "px4_msgs/msg/VehicleLocalPosition", lp_def)).unwrap();
        let att_def = "uint64 timestamp\nfloat32[4] q\n";
        let att = "/fmu/out/vehicle_attitude";
        let att = (bag.add_channel(att, "px4_msgs/msg/VehicleAttitude", att_def)).unwrap();
        let (s_lp, s_att) = (
            bag.schema(lp).unwrap().clone(),
            bag.schema(att).unwrap().clone(),
        );
        // Heading 90 deg (east): q = (cos 45, 0, 0, sin 45).
        let h = std::f64::consts::FRAC_1_SQRT_2;
        for k in 0..50 {
            let t = 1.7e9 + k as f64 * 0.1;
            let valid = if k < 20 { 0.0 } else { 1.0 };
            let v = [("vy", 0.4), ("z", 2.0), ("v_xy_valid", valid)];
            bag.write(lp, t, &write::message(&s_lp, &v).unwrap())
                .unwrap();
            let q = [("q[0]", h), ("q[3]", h)];
            bag.write(att, t, &write::message(&s_att, &q).unwrap())
                .unwrap();
        }
        bag.finish().unwrap();
        let spec: LogSpec = serde_yaml_ng::from_str("file: run.mcap\n").unwrap();
        let run = read(d.path(), ".", &spec, None).unwrap();
        let nav = run.nav.expect("the valid samples");
        assert_eq!(nav.len(), 30);
        // 0.4 m/s east, heading east: 0.4 m/s forward.
        assert!(
            nav.cols[0].iter().all(|u| (u - 0.4).abs() < 1e-6),
            "{:?}",
            nav.cols[0]
        );
        assert!(nav.cols[1].iter().all(|v| v.abs() < 1e-6));
        let depth = run.depth.expect("depth");
        assert!(depth.cols[0].iter().all(|z| (z - 2.0).abs() < 1e-6));
        let notes = run.notes.join("\n");
        assert!(notes.contains("20 of 50 velocity samples"), "{notes}");
    }
}
