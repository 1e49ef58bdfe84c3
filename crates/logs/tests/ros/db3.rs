//! ROS 2 SQLite bags (`.db3`): round trips in Humble's and Jazzy's tables, messages
//! compressed one by one, a type a Humble bag cannot decode, rosbag2 folders, and damage.

use crate::common::*;
use crate::fuzz::Rng;
use hydrofit_logs::db3::storage_file;
use hydrofit_logs::write::{Db3Layout, Db3Writer};
use hydrofit_logs::{Format, Log, LogError, Options, Schema};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::time::{Duration, Instant};

const CUSTOM: &str = "/custom";

/// Writes the common run as a `.db3` bag; a Humble bag leaves out the custom type's topic
/// unless `custom` (it cannot carry its definition).
fn write_db3(path: &Path, layout: Layout, seconds: f64, custom: bool) -> Vec<Sent> {
    let mut w = Db3Writer::create(path, layout.0).expect("create");
    w.compress_messages(layout.1);
    let mut ids = Vec::new();
    for &(topic, ty, _) in TOPICS {
        let id = match ty {
            "test_msgs/Everything" => {
                w.add_channel(topic, "test_msgs/msg/Everything", &custom_ros2())
            }
            _ => w.add_topic(topic, ty),
        };
        ids.push(id.expect("topic"));
    }
    let schemas: Vec<Schema> = ids
        .iter()
        .map(|&id| w.schema(id).expect("schema").clone())
        .collect();
    let keep = |t: usize| custom || TOPICS[t].0 != CUSTOM;
    let sent: Vec<Sent> = run(&schemas, seconds)
        .into_iter()
        .filter(|m| keep(m.topic))
        .collect();
    for m in &sent {
        w.write(ids[m.topic], m.time_s, &m.value).expect("write");
    }
    w.finish().expect("finish");
    sent
}

/// (tables, messages compressed one by one).
#[derive(Debug, Clone, Copy)]
struct Layout(Db3Layout, bool);

const LAYOUTS: [Layout; 3] = [
    Layout(Db3Layout::Humble, false),
    Layout(Db3Layout::Jazzy, false),
    Layout(Db3Layout::Jazzy, true),
];

#[test]
fn db3_bags_round_trip_in_every_layout() {
    for layout in LAYOUTS {
        let path = tmp(&format!("round-{layout:?}.db3"));
        let custom = layout.0 == Db3Layout::Jazzy;
        let sent = write_db3(&path, layout, 6.0, custom);
        let log = Log::open(&path).unwrap();
        assert_eq!(log.format, Format::Db3, "{layout:?}");
        assert_eq!(log.topics.len(), TOPICS.len(), "{layout:?}");
        let imu = log.topic("/imu").unwrap();
        assert_eq!(log.topics[imu].type_name, "sensor_msgs/msg/Imu");
        let readable: Vec<usize> = (0..log.topics.len())
            .filter(|&t| custom || log.topics[t].name != CUSTOM)
            .collect();
        let mut got = Vec::new();
        log.read(&readable, &mut |m| {
            got.push(m.clone());
            Ok(())
        })
        .unwrap();
        assert_same(&log, &got, &sent);
        assert_eq!(
            log.notes().is_empty(),
            custom,
            "{layout:?}: {:?}",
            log.notes()
        );
    }
}

#[test]
fn a_humble_bag_lists_a_type_it_cannot_decode_and_refuses_it_with_the_fix() {
    let path = tmp("humble-custom.db3");
    write_db3(&path, Layout(Db3Layout::Humble, false), 1.0, true);
    let log = Log::open(&path).unwrap();
    let c = log.topic(CUSTOM).expect("listed");
    assert!(log.topics[c].count > 0);
    assert!(
        log.notes().iter().any(|n| n.contains(CUSTOM)),
        "{:?}",
        log.notes()
    );
    let e = log.read(&[c], &mut |_| Ok(())).unwrap_err();
    assert!(e.what.contains("does not carry its definition"), "{e}");
    assert!(
        e.fix.contains("MCAP") && e.fix.contains("message_folders"),
        "{e}"
    );
}

/// A Humble bag of a vehicle's own type reads through the type's `.msg` files: from a folder
/// the user names, or from a `types/` folder beside the bags; the files are inputs of what is
/// read, and a dependency found nowhere is refused by name.
#[test]
fn a_humble_bag_of_a_custom_type_reads_through_its_msg_files() {
    let root = tmp("msg-files");
    let _ = std::fs::remove_dir_all(&root);
    let own = custom_ros2();
    let own = own.split(SEP).next().unwrap().to_string();
    let write_pkg = |msg: &Path, with_item: bool| {
        std::fs::create_dir_all(msg).unwrap();
        std::fs::write(msg.join("Everything.msg"), format!("# all of it\n{own}\n")).unwrap();
        if with_item {
            std::fs::write(msg.join("Item.msg"), "string label\nint32[] values\n").unwrap();
        }
    };
    let bag = root.join("bags/run1/run1_0.db3");
    std::fs::create_dir_all(bag.parent().unwrap()).unwrap();
    let sent = write_db3(&bag, Layout(Db3Layout::Humble, false), 2.0, true);
    let read_all = |log: &Log| {
        let all: Vec<usize> = (0..log.topics.len()).collect();
        let mut got = Vec::new();
        log.read(&all, &mut |m| {
            got.push(m.clone());
            Ok(())
        })
        .map(|_| got)
    };
    // The user's workspace, named.
    let ws = root.join("ws/src");
    write_pkg(&ws.join("test_msgs/msg"), false);
    let options = Options {
        msg_folders: vec![ws.clone()],
        ..Options::default()
    };
    let log = Log::open_with(&bag, &options).unwrap();
    let e = read_all(&log).unwrap_err();
    assert!(e.what.contains("test_msgs/Item"), "{e}");
    write_pkg(&ws.join("test_msgs/msg"), true);
    let log = Log::open_with(&bag, &options).unwrap();
    assert!(log.notes().is_empty(), "{:?}", log.notes());
    assert_same(&log, &read_all(&log).unwrap(), &sent);
    let c = log.topic(CUSTOM).unwrap();
    let files = log.files(&[c]);
    assert_eq!(files.len(), 3, "{files:?}");
    assert!(files[1..].iter().all(|f| f.starts_with(&ws)), "{files:?}");
    // Beside the bags, found without being named.
    write_pkg(&root.join("bags/types/test_msgs/msg"), true);
    let log = Log::open(&bag).unwrap();
    assert_same(&log, &read_all(&log).unwrap(), &sent);
    assert!(log.files(&[c])[1].starts_with(root.join("bags/types")));
    std::fs::remove_dir_all(root).unwrap();
}

#[test]
fn a_rosbag2_folder_opens_through_its_one_storage_file() {
    let dir = tmp("bag-folder");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("metadata.yaml"),
        "rosbag2_bagfile_information: {}\n",
    )
    .unwrap();
    let file = dir.join("bag-folder_0.db3");
    let sent = write_db3(&file, Layout(Db3Layout::Jazzy, false), 1.0, true);
    let log = Log::open(&dir).unwrap();
    assert_eq!(log.path, file);
    assert_eq!(read_all(&log).len(), sent.len());
    write_db3(
        &dir.join("bag-folder_1.db3"),
        Layout(Db3Layout::Jazzy, false),
        1.0,
        true,
    );
    let e = storage_file(&dir).unwrap_err();
    assert!(e.what.contains("split into 2 files"), "{e}");
    let empty = tmp("empty-folder");
    std::fs::create_dir_all(&empty).unwrap();
    let e = Log::open(&empty).unwrap_err();
    assert!(e.what.contains("no .db3 or .mcap"), "{e}");
}

#[test]
fn an_sqlite_file_that_is_not_a_bag_is_refused_naming_its_tables() {
    let path = tmp("not-a-bag.db3");
    let _ = std::fs::remove_file(&path);
    let db = rusqlite_free_db(&path);
    let e = Log::open(&db).unwrap_err();
    assert!(e.what.contains("not a ROS 2 bag"), "{e}");
    assert!(e.what.contains("messages"), "{e}");
}

/// A database with a `messages` table but no `topics` one: the writer's tables, with the
/// name `topics` changed in the schema page (same length, so the file stays valid).
fn rusqlite_free_db(path: &Path) -> std::path::PathBuf {
    let w = Db3Writer::create(path, Db3Layout::Humble).unwrap();
    w.finish().unwrap();
    let mut bytes = std::fs::read(path).unwrap();
    let page = bytes.len().min(4096);
    let mut at = 0;
    while let Some(k) = bytes[at..page].windows(6).position(|w| w == b"topics") {
        bytes[at + k..at + k + 6].copy_from_slice(b"topicz");
        at += k + 6;
    }
    std::fs::write(path, &bytes).unwrap();
    path.to_path_buf()
}

/// Opens and reads every topic; the messages read and the error, if any.
fn open_and_read(path: &Path) -> (usize, Option<LogError>) {
    let log = match Log::open(path) {
        Ok(l) => l,
        Err(e) => return (0, Some(e)),
    };
    let all: Vec<usize> = (0..log.topics.len())
        .filter(|&t| log.topics[t].count > 0)
        .collect();
    let mut n = 0;
    let r = log.read(&all, &mut |m| {
        assert!(m.topic < log.topics.len());
        n += 1;
        Ok(())
    });
    (n, r.err())
}

/// Cut at many lengths and bytes changed anywhere (the SQLite pages, the CDR payloads, the
/// zstd frames): messages or an error naming the file, never a panic or a hang.
#[test]
fn fuzzed_db3_bags_never_panic() {
    for layout in [LAYOUTS[0], LAYOUTS[2]] {
        let good_path = tmp(&format!("fuzz-{layout:?}.db3"));
        write_db3(&good_path, layout, 1.0, layout.0 == Db3Layout::Jazzy);
        let good = std::fs::read(&good_path).unwrap();
        let (total, e) = open_and_read(&good_path);
        assert!(e.is_none(), "{e:?}");
        assert!(total > 100, "{layout:?}: the undamaged bag reads");
        let path = tmp(&format!("fuzzed-{layout:?}.db3"));
        let mut rng = Rng(7 + layout.1 as u64);
        let n = good.len();
        let mut cases: Vec<(String, Vec<u8>)> = (0..60)
            .map(|k| {
                (
                    format!("cut at {}", k * n / 60),
                    good[..k * n / 60].to_vec(),
                )
            })
            .collect();
        for _ in 0..240 {
            let mut bad = good.clone();
            let at = rng.below(n);
            let mask = 1 + rng.below(255) as u8;
            bad[at] ^= mask;
            cases.push((format!("byte {at} ^= {mask:#x}"), bad));
        }
        let mut errors = 0;
        for (case, data) in cases {
            std::fs::write(&path, &data).unwrap();
            let start = Instant::now();
            let r = catch_unwind(AssertUnwindSafe(|| open_and_read(&path)));
            let Ok((_, e)) = r else {
                panic!("{layout:?}, {case}: the reader panicked");
            };
            assert!(
                start.elapsed() < Duration::from_secs(5),
                "{layout:?}, {case}: too slow"
            );
            if let Some(e) = e {
                errors += 1;
                assert_eq!(e.path, path, "{layout:?}, {case}");
                assert!(!e.what.is_empty(), "{layout:?}, {case}");
            }
        }
        eprintln!("{layout:?}: {errors} errors of 300 damaged copies");
    }
}
