//! Logs as vehicles write them: the twins' runs written as a ROS 1 bag, an MCAP file, a ROS 2
//! SQLite bag, an ArduPilot DataFlash log, `rostopic echo -p` topic files and a simulator's
//! tables (a CSV per topic, `timestamp` in seconds) read back to the same logs and the same fused velocities as their
//! CSV files, sample by sample; per-thruster PWM through a thruster layout and curve identifies
//! the same model as the logged wrench; a run folder that names what its log lacks is a
//! located error listing what the log holds. Real autopilot logs: `e2e_autopilot_logs.rs`.

use crate::common::{json, ok, run, stderr};
use crate::log_writer::{LogFormat, write};
use hydrofit::core::model::thrusters::{Command, Curve, Layout, NamedCurve, Thrusters};
use hydrofit::pool::fusion;
use hydrofit::pool::import::csvlog::Log;
use hydrofit::pool::import::{self, PoolRun};
use std::path::Path;

pub const FORMATS: [LogFormat; 7] = [
    LogFormat::Ros1Bag,
    LogFormat::Mcap,
    LogFormat::McapRos1,
    LogFormat::Db3,
    LogFormat::DataFlash,
    LogFormat::TopicCsv,
    LogFormat::PlainCsv,
];

/// The files of run folder `dir`, as the project lists them.
pub fn files(root: &Path, dir: &str) -> Vec<String> {
    hydrofit::core::fsutil::files_under(&root.join(dir), true)
        .unwrap()
        .into_iter()
        .map(|f| format!("{dir}/{f}"))
        .collect()
}

pub fn load(root: &Path, dir: &str, thrusters: Option<&Thrusters>) -> PoolRun {
    import::load(root, dir, &files(root, dir), thrusters).unwrap_or_else(|e| panic!("{dir}: {e}"))
}

/// The run's meta lines (role, description) followed by `log`.
fn run_yaml(root: &Path, csv_dir: &str, log: &str) -> String {
    let text = std::fs::read_to_string(root.join(csv_dir).join("run.yaml")).unwrap();
    format!("{}\n{log}", text.trim_end())
}

/// Writes the CSV run `csv_dir` as a log in a new folder `to` and loads it from there.
fn as_log(root: &Path, csv_dir: &str, to: &str, f: LogFormat, t: Option<&Thrusters>) -> PoolRun {
    let csv = import::load_as_logged(root, csv_dir, &files(root, csv_dir), None).unwrap();
    std::fs::create_dir_all(root.join(to)).unwrap();
    let log = write(&csv, &root.join(to), f, t).unwrap();
    std::fs::write(
        root.join(to).join("run.yaml"),
        run_yaml(root, csv_dir, &log),
    )
    .unwrap();
    load(root, to, t)
}

fn same_log(what: &str, a: &Option<Log>, b: &Option<Log>) {
    let (Some(a), Some(b)) = (a, b) else {
        assert_eq!(a.is_some(), b.is_some(), "{what}: present in one only");
        return;
    };
    assert_eq!(a.t.len(), b.t.len(), "{what}: samples");
    assert_eq!(a.present, b.present, "{what}: columns present");
    for (k, (x, y)) in a.t.iter().zip(&b.t).enumerate() {
        assert!((x - y).abs() < 1e-6, "{what}: t[{k}] {x} against {y}");
    }
    for (c, (ca, cb)) in a.cols.iter().zip(&b.cols).enumerate() {
        for (k, (x, y)) in ca.iter().zip(cb).enumerate() {
            let same = (x.is_nan() && y.is_nan()) || (x - y).abs() <= 1e-9 * (1.0 + x.abs());
            assert!(same, "{what}: column {c} sample {k}: {x} against {y}");
        }
    }
}

pub fn same_fusion(what: &str, a: &PoolRun, b: &PoolRun) {
    let s = fusion::Settings::default();
    let (fa, fb) = (fusion::fuse(a, &s), fusion::fuse(b, &s));
    assert_eq!(fa.t.len(), fb.t.len(), "{what}: fused samples");
    for j in 0..4 {
        let (Some(va), Some(vb)) = (&fa.vel[j], &fb.vel[j]) else {
            assert_eq!(
                fa.vel[j].is_some(),
                fb.vel[j].is_some(),
                "{what}: velocity {j}"
            );
            continue;
        };
        let worst = va
            .iter()
            .zip(vb)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(
            worst < 1e-6,
            "{what}: fused velocity {j} differs by up to {worst}"
        );
    }
}

#[test]
fn every_log_format_reads_back_to_the_csv_run_and_its_fusion() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    ok(root, &["twin", "pool", "--out", "pool", "--truth", "truth"]);
    ok(
        root,
        &["twin", "field", "--out", "field", "--truth", "ftruth"],
    );
    let mut runs: Vec<String> = Vec::new();
    for set in ["pool", "field"] {
        let mut names: Vec<String> = std::fs::read_dir(root.join(set))
            .unwrap()
            .map(|e| format!("{set}/{}", e.unwrap().file_name().to_string_lossy()))
            .collect();
        names.sort();
        // Two runs of each set: the UWB, sonar and IMU runs, and the navigation-log runs.
        runs.extend(names.into_iter().take(2));
    }
    for f in FORMATS {
        for dir in &runs {
            let to = format!(
                "as_{}/{}",
                f.file_name().replace('.', "_"),
                dir.replace('/', "_")
            );
            let csv = load(root, dir, None);
            let log = as_log(root, dir, &to, f, None);
            let what = format!("{dir} as {:?}", f);
            same_log(
                &format!("{what}: command"),
                &Some(csv.thrust.clone()),
                &Some(log.thrust.clone()),
            );
            same_log(&format!("{what}: UWB"), &csv.uwb, &log.uwb);
            same_log(&format!("{what}: sonar"), &csv.sonar, &log.sonar);
            same_log(&format!("{what}: IMU"), &csv.imu, &log.imu);
            same_log(&format!("{what}: depth"), &csv.depth, &log.depth);
            same_log(&format!("{what}: navigation log"), &csv.nav, &log.nav);
            same_fusion(&what, &csv, &log);
            let src = log.log_source.as_ref().expect("a log source");
            assert!(src.topics.contains_key("wrench"), "{what}: {src:?}");
        }
    }
}

/// The Heavy's layout and T200 curve, at twice the T200's thrust: the twin's 35 kg vehicle is
/// commanded up to 100 N, more than eight T200 give in some directions.
pub fn heavy() -> Thrusters {
    Thrusters {
        layout: Some(Layout::Bluerov2Heavy),
        units: vec![],
        command: Command::Pwm,
        neutral_us: 1500.0,
        half_range_us: 400.0,
        curve: Some(Curve::Named(NamedCurve::T200_16v)),
        gain: 2.0,
    }
}

const PIPELINE: &str = "vehicle:
  name: twin ROV
  mass_kg: 35.2
  inertia_kg_m2: {zz: 1.38}
  dofs: [surge, sway, heave, yaw]
  structure: diagonal
THRUSTERS
stages:
  pool: {kind: pool, inputs: [\"cases/pool/*/\"]}
  fit: {kind: fit, from: [pool], settings: {constants: every_dof}}
  validate: {kind: validate, from: [fit, pool]}
  report: {kind: report, from: [fit, pool, validate]}
";

#[test]
fn per_thruster_pwm_identifies_the_model_the_wrench_does() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    let names = twin_pool(root);
    let thrusters = heavy();
    let (wrench, pwm) = (root.join("wrench"), root.join("pwm"));
    for (k, n) in names.iter().enumerate() {
        let from = format!("twin/pool/{n}");
        hydrofit::core::fsutil::copy_dir(&root.join(&from), &wrench.join("cases/pool").join(n))
            .unwrap();
        // The same run with its command as eight PWM values in a ROS 1 bag, or every other
        // run in a ROS 2 SQLite bag.
        let to = format!("pwm/cases/pool/{n}");
        let format = [LogFormat::Ros1Bag, LogFormat::Db3][k % 2];
        let run = as_log(root, &from, &to, format, Some(&thrusters));
        if format == LogFormat::Db3 {
            into_rosbag2_folder(&root.join(&to));
        }
        let csv = load(root, &from, None);
        // The wrench back from whole-microsecond PWM: within the curve's step per microsecond.
        for c in 0..4 {
            let worst = csv.thrust.cols[c]
                .iter()
                .zip(&run.thrust.cols[c])
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1.0, "{n}: command column {c} off by {worst}");
        }
        sensors_from_csv(root, &from, &to);
    }
    // Every constant kept (`constants: every_dof`): which ones cross-validation keeps may
    // differ between the two where a DOF's left-out errors are at its margin, and this
    // compares the models the two commands give, not that choice.
    write_pipeline(&wrench, None);
    write_pipeline(&pwm, Some(&thrusters));
    ok(&wrench, &["build"]);
    ok(&pwm, &["build"]);
    let (a, b) = (coefficients(&wrench), coefficients(&pwm));
    assert_eq!(a.len(), b.len());
    // The same model: each coefficient the runs determine within 3 % or two standard errors
    // (whole-microsecond PWM moves each thrust by up to a tenth of a newton). A DOF with a
    // coefficient the runs cannot determine (the twin's heave added mass, 2.4 times its mass,
    // sits on the 2x prior) trades its other coefficients against it: it is left out.
    let dof = |n: &str| n.chars().next().unwrap();
    // (A constant force near zero, not identifiable for being small, says nothing of the rest.)
    let unsure: Vec<char> = a
        .iter()
        .filter(|p| !p.3 && !p.0.ends_with("_0"))
        .map(|p| dof(&p.0))
        .collect();
    let mut compared = 0;
    for ((n, x, se, sure), (_, y, _, _)) in a.iter().zip(&b) {
        if *sure && !unsure.contains(&dof(n)) {
            let tol = (0.03 * x.abs()).max(2.0 * se);
            assert!(
                (x - y).abs() <= tol,
                "{n}: {x} from the wrench, {y} from PWM (std. error {se})"
            );
            compared += 1;
        }
    }
    assert!(
        compared >= 8,
        "only {compared} coefficients were identifiable"
    );
    // And it predicts the held-out runs as well in those DOFs.
    let letter = |d: &str| match d {
        "surge" => 'X',
        "sway" => 'Y',
        "heave" => 'Z',
        "roll" => 'K',
        "pitch" => 'M',
        _ => 'N',
    };
    let nmae = |p: &Path| -> Vec<(String, f64)> {
        let v = json(p, "reports/validation.json");
        let runs = v["models"][0]["runs"].as_array().unwrap().clone();
        let mut out = Vec::new();
        for r in runs.iter().filter(|r| r["role"] == "validate") {
            for (d, m) in r["dofs"].as_object().unwrap() {
                out.push((d.clone(), m["nmae"].as_f64().unwrap()));
            }
        }
        out
    };
    for ((d, x), (_, y)) in nmae(&wrench).iter().zip(nmae(&pwm)) {
        if !unsure.contains(&letter(d)) {
            assert!(
                (x - y).abs() < 0.02,
                "{d}: held-out NMAE {x} from the wrench, {y} from PWM"
            );
        }
    }
    let inputs = json(&pwm, "reports/parameters.json")["parameters"][0]["inputs"].clone();
    for file in ["run.bag", "bag/run.db3"] {
        assert!(
            inputs.as_array().unwrap().iter().any(|i| {
                i["path"].as_str().unwrap().ends_with(file)
                    && i["topics"]["command"] == "/thrusters"
                    && i["blake3"].as_str().is_some_and(|h| h.len() == 64)
            }),
            "{file} is an input, with its topic and hash: {inputs}"
        );
    }
}

/// The pool twin's effect-free runs written under `root/twin/pool`, their names sorted.
fn twin_pool(root: &Path) -> Vec<String> {
    let args = ["twin", "pool", "--out", "twin/pool", "--truth", "truth"];
    ok(root, &[&args[..], &["--effect", "none"]].concat());
    let mut names: Vec<String> = std::fs::read_dir(root.join("twin/pool"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    names.sort();
    names
}

/// The run folder `to` (its command from a log) given the sensors of the CSV run `from`: its
/// CSV files copied, their lines dropped from `log:`.
fn sensors_from_csv(root: &Path, from: &str, to: &str) {
    for f in ["uwb.csv", "sonar.csv", "imu.csv", "depth.csv"] {
        if root.join(from).join(f).exists() {
            std::fs::copy(root.join(from).join(f), root.join(to).join(f)).unwrap();
        }
    }
    let yaml = std::fs::read_to_string(root.join(to).join("run.yaml")).unwrap();
    let kept: Vec<&str> = yaml
        .lines()
        .filter(|l| {
            !l.contains("position:")
                && !l.contains("sonar:")
                && !l.contains("attitude:")
                && !l.contains("rates:")
                && !l.contains("acceleration:")
                && !l.contains("depth:")
        })
        .collect();
    std::fs::write(root.join(to).join("run.yaml"), kept.join("\n") + "\n").unwrap();
}

/// `project/pipeline.yaml`: [`PIPELINE`] with `thrusters` (or a logged wrench).
fn write_pipeline(project: &Path, thrusters: Option<&Thrusters>) {
    let indented: String = match thrusters {
        Some(t) => {
            let yaml = serde_yaml_ng::to_string(&serde_json::json!({"thrusters": t})).unwrap();
            yaml.lines().map(|l| format!("  {l}\n")).collect()
        }
        None => String::new(),
    };
    let text = PIPELINE.replace("THRUSTERS\n", &indented);
    std::fs::write(project.join("pipeline.yaml"), text).unwrap();
}

/// Each coefficient of a built project: name, value, standard error, identifiable.
fn coefficients(p: &Path) -> Vec<(String, f64, f64, bool)> {
    json(p, "reports/parameters.json")["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| {
            let v = |k: &str| x[k].as_f64().unwrap_or(f64::NAN);
            let sure = x["identifiable"].as_bool().unwrap_or(true);
            (
                x["name"].as_str().unwrap().to_string(),
                v("value"),
                v("stderr"),
                sure,
            )
        })
        .collect()
}

/// A simulator logs each thruster's thrust in newtons, in tables with its own clock: through
/// `command: newtons` (no curve) the runs identify the model the logged wrench does, to the
/// digits the tables keep.
#[test]
fn per_thruster_thrust_in_newtons_identifies_the_model_the_wrench_does() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    let names = twin_pool(root);
    let thrusters = Thrusters {
        command: Command::Newtons,
        curve: None,
        gain: 1.0,
        ..heavy()
    };
    let (wrench, newtons) = (root.join("wrench"), root.join("newtons"));
    for n in &names {
        let from = format!("twin/pool/{n}");
        hydrofit::core::fsutil::copy_dir(&root.join(&from), &wrench.join("cases/pool").join(n))
            .unwrap();
        let to = format!("newtons/cases/pool/{n}");
        let run = as_log(root, &from, &to, LogFormat::PlainCsv, Some(&thrusters));
        let csv = load(root, &from, None);
        for c in 0..4 {
            let worst = (csv.thrust.cols[c].iter().zip(&run.thrust.cols[c]))
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-6, "{n}: command column {c} off by {worst}");
        }
        sensors_from_csv(root, &from, &to);
        // The tables out of `cases/pool/`, whose every folder is a run.
        let tables = format!("{n}_tables");
        std::fs::create_dir_all(newtons.join("logs")).unwrap();
        let at = newtons.join("cases/pool").join(&tables);
        std::fs::rename(at, newtons.join("logs").join(&tables)).unwrap();
        let yaml = std::fs::read_to_string(root.join(&to).join("run.yaml")).unwrap();
        let moved = yaml.replace(&format!("../{tables}"), &format!("../../../logs/{tables}"));
        std::fs::write(root.join(&to).join("run.yaml"), moved).unwrap();
    }
    write_pipeline(&wrench, None);
    write_pipeline(&newtons, Some(&thrusters));
    ok(&wrench, &["build"]);
    ok(&newtons, &["build"]);
    let (a, b) = (coefficients(&wrench), coefficients(&newtons));
    assert_eq!(a.len(), b.len());
    for ((n, x, se, _), (_, y, _, _)) in a.iter().zip(&b) {
        assert!(
            (x - y).abs() <= 1e-3 * x.abs() + 0.01 * se,
            "{n}: {x} from the wrench, {y} from thrusts in newtons"
        );
    }
}

/// Moves the run folder's `run.db3` into a rosbag2 folder `bag/` (with a `metadata.yaml`, as
/// `ros2 bag record` leaves it) and points `run.yaml` at the folder.
fn into_rosbag2_folder(run: &Path) {
    std::fs::create_dir_all(run.join("bag")).unwrap();
    std::fs::rename(run.join("run.db3"), run.join("bag/run.db3")).unwrap();
    std::fs::write(
        run.join("bag/metadata.yaml"),
        "rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n",
    )
    .unwrap();
    let yaml = std::fs::read_to_string(run.join("run.yaml")).unwrap();
    assert!(yaml.contains("file: run.db3"), "{yaml}");
    std::fs::write(
        run.join("run.yaml"),
        yaml.replace("file: run.db3", "file: bag"),
    )
    .unwrap();
}

#[test]
fn a_mapping_the_log_cannot_satisfy_is_a_located_error() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    ok(root, &["twin", "pool", "--out", "twin", "--truth", "truth"]);
    let mixed =
        import::load_as_logged(root, "twin/mixed", &files(root, "twin/mixed"), None).unwrap();
    std::fs::create_dir_all(root.join("p/cases/pool/r")).unwrap();
    let log = write(
        &mixed,
        &root.join("p/cases/pool/r"),
        LogFormat::Ros1Bag,
        None,
    )
    .unwrap();
    std::fs::write(
        root.join("p/pipeline.yaml"),
        PIPELINE.replace("THRUSTERS\n", ""),
    )
    .unwrap();
    let cases = [
        // A topic the log lacks: the error lists the topics it has, with types and rates.
        (
            log.replace("topic: /wrench", "topic: /cmd_wrench"),
            vec![
                "no topic `/cmd_wrench`",
                "/wrench  geometry_msgs/WrenchStamped",
            ],
        ),
        // A field the message lacks.
        (
            log.replace("wrench.force.x", "wrench.force.q"),
            vec!["wrench.force.q", "wrench.force.x"],
        ),
        // A topic of another type: the IMU named for the wrench.
        (
            log.replace("wrench: {topic: /wrench", "wrench: {topic: /imu"),
            vec!["sensor_msgs/Imu", "no field"],
        ),
        // A span outside the log.
        (
            log.replace("stack: none", "stack: none\n  span_s: [900, 1000]"),
            vec!["span_s [900, 1000]"],
        ),
    ];
    for (text, want) in cases {
        std::fs::write(
            root.join("p/cases/pool/r/run.yaml"),
            format!("role: train\n{text}"),
        )
        .unwrap();
        let o = run(&root.join("p"), &["build", "pool"]);
        let e = stderr(&o);
        assert!(!o.status.success(), "{text}");
        for w in &want {
            assert!(e.contains(w), "wanted `{w}` in:\n{e}");
        }
        assert!(e.contains("run.bag"), "the error names the log: {e}");
    }
    // A log cut in its middle (a copy that stopped): read up to the cut, and said.
    let bag = root.join("p/cases/pool/r/run.bag");
    let bytes = std::fs::read(&bag).unwrap();
    std::fs::write(&bag, &bytes[..bytes.len() / 2]).unwrap();
    std::fs::write(
        root.join("p/cases/pool/r/run.yaml"),
        format!("role: train\n{log}"),
    )
    .unwrap();
    let cut = load(&root.join("p"), "cases/pool/r", None);
    let notes = cut.notes.join("\n");
    assert!(
        notes.contains("run.bag: the bag ends at byte") && notes.contains("cut short"),
        "{notes}"
    );
    assert!(
        cut.thrust.t.len() < mixed.thrust.t.len() * 3 / 4,
        "read up to the cut only"
    );
    // Damage in its middle: a located error.
    let mut bytes = bytes.clone();
    let mid = bytes.len() / 2;
    for b in &mut bytes[mid..mid + 100] {
        *b = 0xff;
    }
    std::fs::write(&bag, &bytes).unwrap();
    let o = run(&root.join("p"), &["build", "pool"]);
    assert!(!o.status.success(), "damage in the middle is an error");
    let e = stderr(&o);
    assert!(e.contains("run.bag") && e.contains("(byte "), "{e}");
}

/// A topic CSV export that stopped mid-write (its last row cut in the middle) is read without
/// that row, where it stopped the whole run before, and the run's notes say so; a topic whose file holds its header only is an error
/// that names the topic, not a message about its fields.
#[test]
fn a_topic_csv_cut_short_is_read_to_its_last_whole_row() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    ok(root, &["twin", "pool", "--out", "pool", "--truth", "truth"]);
    let dir = "pool/mixed";
    let whole = as_log(root, dir, "csv/r", LogFormat::TopicCsv, None);
    let topics = root.join("csv/r_topics");
    let wrench = std::fs::read_dir(&topics)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.to_string_lossy().contains("wrench"))
        .expect("a wrench topic file");
    let text = std::fs::read_to_string(&wrench).unwrap();
    let body = text.trim_end();
    let last = body.rfind('\n').unwrap();
    let cut = &body[..last + 1 + (body.len() - last) / 3];
    std::fs::write(&wrench, cut).unwrap();
    let torn = load(root, "csv/r", None);
    // Read to its last whole row (the rows are counted in the log reader's own test; the
    // command is then put on a regular clock, which may end where the whole log's does).
    assert!(torn.thrust.t.len().abs_diff(whole.thrust.t.len()) <= 2);
    assert!(
        torn.notes
            .iter()
            .any(|n| n.contains("last row is cut short")),
        "{:?}",
        torn.notes
    );
    let header = &text[..text.find('\n').unwrap() + 1];
    std::fs::write(&wrench, header).unwrap();
    let files = files(root, "csv/r");
    let e = import::load(root, "csv/r", &files, None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("the wrench topic `/wrench` has no messages"),
        "{e}"
    );
}
