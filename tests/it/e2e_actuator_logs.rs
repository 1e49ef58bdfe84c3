//! A fin-steered vehicle's log read as it is: the AUV twin's dives (`examples/iver3_auv`, fin
//! angles in degrees and the propeller in rpm) written as a ROS 1 bag, an MCAP file, a ROS 2
//! SQLite bag, a DataFlash log and topic tables, their actuators named by `log.actuators`
//! with `columns`, read back to the same actuator log and fused velocities as the CSV files;
//! the adaptive identifier given the MCAP dives gets what it gets from the CSV dives; a
//! mapping whose columns do not fit is a located error.

use crate::common::{example, json, ok, run, stderr};
use crate::e2e_logs::{FORMATS, files, load, same_fusion};
use crate::log_writer::{LogFormat, write};
use hydrofit::pool::import::{self, PoolRun};
use std::path::Path;

/// Replaces the CSV run `dir` by a log of `format` holding the same numbers, mapped in its
/// `run.yaml`; returns the run as the CSV files held it.
fn to_log(root: &Path, dir: &str, format: LogFormat) -> PoolRun {
    let csv = import::load_as_logged(root, dir, &files(root, dir), None).unwrap();
    let folder = root.join(dir);
    let meta = std::fs::read_to_string(folder.join("run.yaml")).unwrap();
    for f in ["actuators.csv", "nav.csv", "imu.csv", "depth.csv"] {
        std::fs::remove_file(folder.join(f)).unwrap();
    }
    let log = write(&csv, &folder, format, None).unwrap();
    assert!(
        log.contains("actuators:") && log.contains("columns: ["),
        "{log}"
    );
    assert!(
        !log.contains("wrench:"),
        "a fin-steered run logs no wrench: {log}"
    );
    let yaml = format!("{}\n{log}", meta.trim_end());
    std::fs::write(folder.join("run.yaml"), yaml).unwrap();
    csv
}

#[test]
fn a_fin_steered_dive_reads_from_every_log_format_as_its_csv_files() {
    for format in FORMATS {
        let p = example("iver3_auv");
        let root = p.path();
        let dir = "cases/pool/dive_87";
        let csv = to_log(root, dir, format);
        let logged = load(root, dir, None);
        let (a, b) = (
            csv.actuators.as_ref().unwrap(),
            logged.actuators.as_ref().unwrap(),
        );
        let what = format!("{format:?}");
        assert_eq!(a.names, b.names, "{what}");
        assert_eq!(a.units, b.units, "{what}: units as the CSV header had them");
        assert_eq!(a.log.t.len(), b.log.t.len(), "{what}: samples");
        for (x, y) in a.log.t.iter().zip(&b.log.t) {
            assert!((x - y).abs() < 1e-6, "{what}: t {x} against {y}");
        }
        for (ca, cb) in a.log.cols.iter().zip(&b.log.cols) {
            for (x, y) in ca.iter().zip(cb) {
                assert!(
                    (x - y).abs() <= 1e-9 * (1.0 + x.abs()),
                    "{what}: {x} against {y}"
                );
            }
        }
        // No thrust logged: the run is steered by its actuators, as the CSV run is.
        assert!(!logged.force_logged, "{what}");
        let topic = match format {
            LogFormat::DataFlash => ":ACT",
            _ => ":/actuators",
        };
        assert!(
            logged.command_path.ends_with(topic),
            "{what}: {}",
            logged.command_path
        );
        let csv_loaded = load(root, dir, None);
        same_fusion(&what, &csv_loaded, &logged);
    }
}

/// The adaptive identifier's scaled estimates of a project's `aid` stage.
fn scaled(dir: &Path) -> Vec<(String, f64)> {
    let field = json(dir, "reports/field.json");
    let aid = (field["identifiers"].as_array().unwrap().iter())
        .find(|r| r["stage"] == "aid")
        .unwrap();
    let d = &aid["detail"];
    let names = d["names"].as_array().unwrap().iter();
    let values = d["scaled"].as_array().unwrap().iter();
    names
        .zip(values)
        .map(|(n, v)| (n.as_str().unwrap().to_string(), v.as_f64().unwrap()))
        .collect()
}

#[test]
fn the_adaptive_identifier_gets_from_mcap_dives_what_it_gets_from_their_csv_files() {
    let csv = example("iver3_auv");
    ok(csv.path(), &["build"]);
    let logged = example("iver3_auv");
    for dive in ["dive_86", "dive_87", "dive_88"] {
        to_log(
            logged.path(),
            &format!("cases/pool/{dive}"),
            LogFormat::Mcap,
        );
    }
    ok(logged.path(), &["build"]);
    let (a, b) = (scaled(csv.path()), scaled(logged.path()));
    assert_eq!(a.len(), 20);
    for ((n, x), (_, y)) in a.iter().zip(&b) {
        assert!(
            (x - y).abs() <= 1e-6 * x.abs().max(1e-3),
            "{n}: {y} from the logs, {x} from the CSV files"
        );
    }
    // Each parameter's provenance names the log and the actuators' topic.
    let params = json(logged.path(), "reports/parameters.json").to_string();
    assert!(params.contains("run.mcap"), "the log is an input");
}

#[test]
fn actuator_columns_that_do_not_fit_are_located_errors() {
    let p = example("iver3_auv");
    let root = p.path();
    let dir = "cases/pool/dive_86";
    to_log(root, dir, LogFormat::Mcap);
    let yaml = root.join(dir).join("run.yaml");
    let good = std::fs::read_to_string(&yaml).unwrap();
    let cases = [
        // One column short.
        (", prop_rpm]", "]", "name 5 fields and 4 columns"),
        // A heading without its unit.
        ("prop_rpm]", "prop]", "has no unit suffix"),
        // Columns on a signal that is not the actuators.
        (
            "frame: ned}",
            "frame: ned, columns: [a_deg]}",
            "`columns` names actuators",
        ),
    ];
    for (from, to, says) in cases {
        assert!(good.contains(from), "{from} in {good}");
        std::fs::write(&yaml, good.replacen(from, to, 1)).unwrap();
        let o = run(root, &["build"]);
        let e = stderr(&o);
        assert!(!o.status.success() && e.contains(says), "{says}: {e}");
        assert!(e.contains("run.mcap"), "the error names the log: {e}");
    }
    // Both actuators.csv and the log's actuators: which one is meant is not guessed.
    std::fs::write(&yaml, &good).unwrap();
    let src = crate::common::manifest_dir().join("examples/iver3_auv/cases/pool/dive_86");
    std::fs::copy(
        src.join("actuators.csv"),
        root.join(dir).join("actuators.csv"),
    )
    .unwrap();
    let e = stderr(&run(root, &["build"]));
    assert!(
        e.contains("both actuators.csv and the actuators in its log"),
        "{e}"
    );
}
