//! A ROS 2 Humble bag (no definitions inside) of a vehicle's own message type reads through the
//! type's `.msg` file, named in run.yaml's `log: {message_folders: [...]}`: the field twin's
//! navigation-log run, its navigation log under a type of its own, reads back to the same log
//! as its CSV files, and the `.msg` file is an input of the run; without the folder, the run
//! is refused with the fix.

use crate::common::ok;
use crate::e2e_logs::files;
use crate::log_writer::{LogFormat, write};
use hydrofit::pool::import;
use hydrofit_logs::write::{Db3Layout, Db3Writer};
use hydrofit_logs::{Log, ros_types};
use std::path::Path;

/// `nav_msgs/Odometry`'s fields under the vehicle's own name, as its workspace would have it.
const NAV_STATE: &str = "# The vehicle's navigation state\n\
    std_msgs/Header header\n\
    string child_frame_id  # body frame\n\
    geometry_msgs/PoseWithCovariance pose\n\
    geometry_msgs/TwistWithCovariance twist\n";

/// Rewrites the bag at `path` with its `/nav` topic as `rov_msgs/msg/NavState`.
fn rename_nav_type(path: &Path) {
    let log = Log::open(path).unwrap();
    let out = path.with_extension("new");
    let mut w = Db3Writer::create(&out, Db3Layout::Humble).unwrap();
    let ids: Vec<i64> = (log.topics.iter())
        .map(|t| match t.name.as_str() {
            "/nav" => {
                let odometry = ros_types::ros2("nav_msgs/Odometry").unwrap();
                w.add_channel("/nav", "rov_msgs/msg/NavState", &odometry)
            }
            _ => w.add_topic(&t.name, &t.type_name),
        })
        .collect::<Result<_, _>>()
        .unwrap();
    let all: Vec<usize> = (0..log.topics.len()).collect();
    log.read(&all, &mut |m| w.write(ids[m.topic], m.log_time_s, &m.value))
        .unwrap();
    w.finish().unwrap();
    std::fs::rename(out, path).unwrap();
}

#[test]
fn a_humble_bag_of_the_vehicles_own_navigation_type_reads_through_its_msg_file() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    ok(
        root,
        &["twin", "field", "--out", "field", "--truth", "ftruth"],
    );
    let mut runs: Vec<String> = std::fs::read_dir(root.join("field"))
        .unwrap()
        .map(|e| format!("field/{}", e.unwrap().file_name().to_string_lossy()))
        .collect();
    runs.sort();
    let csv_dir = &runs[0];
    let csv_files = files(root, csv_dir);
    let csv = import::load_as_logged(root, csv_dir, &csv_files, None).unwrap();
    let to = "logged/run";
    std::fs::create_dir_all(root.join(to)).unwrap();
    let mapping = write(&csv, &root.join(to), LogFormat::Db3, None).unwrap();
    rename_nav_type(&root.join(to).join("run.db3"));
    // Two folders down from the project, where the search beside the bag does not reach.
    let pkg = root.join("defs/ws/rov_msgs/msg");
    std::fs::create_dir_all(&pkg).unwrap();
    std::fs::write(pkg.join("NavState.msg"), NAV_STATE).unwrap();
    let meta = std::fs::read_to_string(root.join(csv_dir).join("run.yaml")).unwrap();
    let run_yaml = |log: &str| {
        let text = format!("{}\n{log}", meta.trim_end());
        std::fs::write(root.join(to).join("run.yaml"), text).unwrap();
    };
    run_yaml(&mapping);
    let e = import::load(root, to, &files(root, to), None).unwrap_err();
    let e = e.to_string();
    assert!(
        e.contains("rov_msgs/msg/NavState") && e.contains("message_folders"),
        "{e}"
    );
    run_yaml(&mapping.replace(
        "  file: run.db3\n",
        "  file: run.db3\n  message_folders: [../../defs/ws]\n",
    ));
    let logged = import::load(root, to, &files(root, to), None).unwrap();
    let reference = import::load(root, csv_dir, &csv_files, None).unwrap();
    let (a, b) = (
        reference.nav.as_ref().unwrap(),
        logged.nav.as_ref().unwrap(),
    );
    assert_eq!(a.t.len(), b.t.len());
    assert!(a.t.len() > 100, "{} navigation rows", a.t.len());
    for (ca, cb) in a.cols.iter().zip(&b.cols) {
        for (x, y) in ca.iter().zip(cb) {
            let same = (x.is_nan() && y.is_nan()) || (x - y).abs() <= 1e-9 * (1.0 + x.abs());
            assert!(same, "{x} against {y}");
        }
    }
    let src = logged.log_source.as_ref().unwrap();
    assert_eq!(
        src.files,
        ["logged/run/run.db3", "defs/ws/rov_msgs/msg/NavState.msg"],
        "{src:?}"
    );
}
