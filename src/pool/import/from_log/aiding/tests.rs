//! The aiding checks on written logs: a telemetry log, mavros bags, PX4's ROS 2 topics, a
//! DVL's own messages.

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
    let y = "file: run.mcap\nrates: {topic: /dvl/data, fields: [velocity.x, velocity.y, velocity.z], valid: fom}\n";
    let e = read(d.path(), ".", &serde_yaml_ng::from_str(y).unwrap(), None).unwrap_err();
    assert!(
        e.to_string()
            .contains("`valid` names a velocity's or a depth's"),
        "{e}"
    );
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
    let lp_def = "uint64 timestamp\nfloat32 z\nfloat32 vx\nfloat32 vy\nfloat32 vz\nbool v_xy_valid\nbool z_valid\n";
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
        // The EKF has a height from 1 s: before it, z is junk and marked so.
        let (z, z_valid) = if k < 10 { (-7.0, 0.0) } else { (2.0, 1.0) };
        let v = [
            ("vy", 0.4),
            ("z", z),
            ("v_xy_valid", valid),
            ("z_valid", z_valid),
        ];
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
    assert_eq!(depth.len(), 40);
    assert!(depth.cols[0].iter().all(|z| (z - 2.0).abs() < 1e-6));
    let notes = run.notes.join("\n");
    assert!(notes.contains("20 of 50 velocity samples"), "{notes}");
    assert!(notes.contains("10 of 50 depth samples"), "{notes}");
}

/// A depth flag named by `log.depth.valid` (a pressure driver's own), and a depth never
/// valid: no depth, with a note.
#[test]
fn a_depth_marked_not_valid_is_left_out() {
    use hydrofit_logs::write::{self, McapCompression, McapWriter};
    let d = tempfile::tempdir().unwrap();
    let write_depth = |ok: &dyn Fn(usize) -> bool| {
        let path = d.path().join("run.mcap");
        let mut bag = McapWriter::create(&path, McapCompression::None).unwrap();
        let def = "float64 depth\nuint8 healthy\n";
        let id = (bag.add_channel("/depth", "my_msgs/msg/Depth", def)).unwrap();
        let schema = bag.schema(id).unwrap().clone();
        for k in 0..40 {
            let t = 1.7e9 + k as f64 * 0.1;
            let (z, h) = if ok(k) { (1.5, 1.0) } else { (0.0, 0.0) };
            let v = [("depth", z), ("healthy", h)];
            bag.write(id, t, &write::message(&schema, &v).unwrap())
                .unwrap();
        }
        bag.finish().unwrap();
    };
    let spec: LogSpec = serde_yaml_ng::from_str(
        "file: run.mcap\ndepth: {topic: /depth, fields: [depth], valid: healthy}\n",
    )
    .unwrap();
    write_depth(&|k| k % 4 != 0);
    let run = read(d.path(), ".", &spec, None).unwrap();
    let depth = run.depth.expect("the healthy depths");
    assert_eq!(depth.len(), 30);
    assert!(depth.cols[0].iter().all(|z| (z - 1.5).abs() < 1e-9));
    write_depth(&|_| false);
    let run = read(d.path(), ".", &spec, None).unwrap();
    assert!(run.depth.is_none());
    let notes = run.notes.join("\n");
    assert!(
        notes.contains("no depth") && notes.contains("for all 40 samples"),
        "{notes}"
    );
}
