use super::*;

const NAV: &str = "%time,field.header.seq,field.header.stamp,field.header.frame_id,field.velocity.x,field.velocity.y,field.orientation.z
1669909208877428140,11387,1669909208830211715,,0.5,-0.25,0.4
1669909208977451040,11388,1669909208949668236,odom,0.6,,0.41
";
const WRENCH: &str = "%time,field.force.x,field.torque.z
1669909208900000000,1.5,-0.2
1669909208920000000,1.6,-0.1
";

/// A fresh scratch folder of this test process.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hydrofit-topic-csv-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A logger stopped mid-write leaves a last row with fewer cells and no line break: the
/// rows before it are read, it is left out and said so; a whole last row without a line
/// break is kept.
#[test]
fn a_last_row_cut_short_is_left_out_and_said() {
    let d = scratch("torn");
    let torn = format!("{NAV}1669909209077451040,11389,16699092");
    std::fs::write(d.as_path().join("navigation_state_3.csv"), torn).unwrap();
    std::fs::write(d.as_path().join("wrench_3.csv"), WRENCH.trim_end()).unwrap();
    let log = crate::Log::open(d.as_path()).unwrap();
    assert_eq!(log.topics[0].count, 2);
    assert_eq!(log.topics[1].count, 2, "a whole last row is kept");
    let mut times = Vec::new();
    log.read(&[0, 1], &mut |m| {
        times.push((m.topic, m.log_time_s));
        Ok(())
    })
    .unwrap();
    assert_eq!(times.iter().filter(|t| t.0 == 0).count(), 2);
    assert_eq!(times.iter().filter(|t| t.0 == 1).count(), 2);
    let notes = log.notes();
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(notes[0].starts_with("navigation_state_3.csv: its last row is cut short"));
    // A run reading the other file of the folder is not told of this one.
    assert_eq!(log.notes_for(&[0]), notes);
    assert!(log.notes_for(&[1]).is_empty(), "{:?}", log.notes_for(&[1]));
    std::fs::remove_dir_all(d).unwrap();
}

#[test]
fn a_folder_of_topic_files_reads_as_one_log_in_time_order() {
    let d = scratch("folder");
    std::fs::write(d.as_path().join("navigation_state_3.csv"), NAV).unwrap();
    std::fs::write(d.as_path().join("wrench_3.csv"), WRENCH).unwrap();
    std::fs::write(d.as_path().join("notes.csv"), "a,b\n1,2\n").unwrap();
    assert!(is_topic_folder(d.as_path()));
    let log = crate::Log::open(d.as_path()).unwrap();
    assert_eq!(log.format, crate::Format::TopicCsv);
    let names: Vec<&str> = log.topics.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, ["navigation_state_3", "wrench_3"]);
    assert_eq!(log.topics[0].count, 2);
    assert!((log.topics[1].first_s - 1669909208.9).abs() < 1e-6);
    let vx = log.topics[0].schema.select("velocity.x").unwrap();
    let vy = log.topics[0].schema.select("velocity.y").unwrap();
    let n = log.topics[1].schema.select("torque.z").unwrap();
    let mut seen = Vec::new();
    log.read(&[0, 1], &mut |m| {
        let x = match m.topic {
            0 => vx.get(&m.value).unwrap(),
            _ => n.get(&m.value).unwrap(),
        };
        let y = (m.topic == 0).then(|| vy.get(&m.value).unwrap());
        seen.push((m.topic, m.log_time_s, m.stamp_s, x, y));
        Ok(())
    })
    .unwrap();
    assert_eq!(seen.iter().map(|s| s.0).collect::<Vec<_>>(), [0, 1, 1, 0]);
    assert!((seen[0].2.unwrap() - 1_669_909_208.830_211_7).abs() < 1e-6);
    assert_eq!(seen[0].3, 0.5);
    assert!(seen[3].4.unwrap().is_nan(), "an empty cell is NaN");
    assert_eq!(seen[2].3, -0.1);
    assert_eq!(seen[1].2, None, "no header, no stamp");
    std::fs::remove_dir_all(d).unwrap();
}

#[test]
fn a_row_with_more_cells_than_the_header_is_an_error_with_its_line() {
    let d = scratch("row");
    let p = d.as_path().join("t.csv");
    std::fs::write(&p, "%time,field.x\n1,2\n3,4,5\n").unwrap();
    let log = crate::Log::open(&p).unwrap();
    let e = log.read(&[0], &mut |_| Ok(())).unwrap_err();
    assert!(e.what.contains("row 3"), "{}", e.what);
    // A first row shorter than the header, and Windows line ends: opened, then refused
    // when read, never a panic.
    std::fs::write(&p, "%time,field.x,field.y\r\n1,2\r\n3,4,5\r\n").unwrap();
    let log = crate::Log::open(&p).unwrap();
    assert_eq!(log.topics[0].schema.leaves().len(), 2);
    let e = log.read(&[0], &mut |_| Ok(())).unwrap_err();
    assert!(e.what.contains("row 2"), "{}", e.what);
    std::fs::remove_dir_all(d).unwrap();
}

/// Tables other tools write: a simulator's pose and per-thruster thrust in seconds (one
/// file with a byte-order mark), and a PX4 `ulog2csv` table timed in whole microseconds.
#[test]
fn csv_files_with_a_time_column_read_as_a_log_and_say_their_unit() {
    let d = scratch("plain");
    let pose = "timestamp,position_x,linear_velocity_x\n1284.956,7.9,-0.29\n1285.006,7.89,-0.30\n";
    let thrust = "\u{feff}timestamp,thrust0,thrust1\n1284.958,5.77,-2.88\n1285.008,5.78,-0.82\n";
    std::fs::write(d.as_path().join("pose_data.csv"), pose).unwrap();
    std::fs::write(d.as_path().join("thrust_data.csv"), thrust).unwrap();
    let log = crate::Log::open(d.as_path()).unwrap();
    assert_eq!(log.format, crate::Format::Csv);
    let names: Vec<&str> = log.topics.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, ["pose_data", "thrust_data"]);
    assert!((log.topics[1].last_s - 1285.008).abs() < 1e-9);
    let u = log.topics[0].schema.select("linear_velocity_x").unwrap();
    let t1 = log.topics[1].schema.select("thrust1").unwrap();
    let mut seen = Vec::new();
    log.read(&[0, 1], &mut |m| {
        let s = [&u, &t1][m.topic];
        seen.push((m.topic, m.log_time_s, m.stamp_s, s.get(&m.value).unwrap()));
        Ok(())
    })
    .unwrap();
    assert_eq!(seen.iter().map(|s| s.0).collect::<Vec<_>>(), [0, 1, 0, 1]);
    assert_eq!((seen[1].3, seen[2].3, seen[2].2), (-2.88, -0.30, None));
    assert!(
        log.notes().is_empty(),
        "fractional times are seconds: {:?}",
        log.notes()
    );

    let px4 = d.as_path().join("vehicle_local_position_0.csv");
    std::fs::write(
        &px4,
        "timestamp,vx,output[1]\n20000000,0.1,0.2\n20004000,0.1,0.3\n",
    )
    .unwrap();
    let log = crate::Log::open(&px4).unwrap();
    assert_eq!(log.format, crate::Format::Csv);
    assert!((log.topics[0].last_s - 20.004).abs() < 1e-12);
    assert!(log.notes()[0].contains("microseconds"), "{:?}", log.notes());
    // A column named with brackets is that column, not an array's element.
    let out1 = log.topics[0].schema.select("output[1]").unwrap();
    let mut last = f64::NAN;
    log.read(&[0], &mut |m| {
        last = out1.get(&m.value).unwrap();
        Ok(())
    })
    .unwrap();
    assert_eq!(last, 0.3);

    // A rosbag2 folder with a CSV export beside its storage is the bag, not the tables.
    let bag = d.as_path().join("bag");
    std::fs::create_dir_all(&bag).unwrap();
    std::fs::write(
        bag.join("metadata.yaml"),
        "rosbag2_bagfile_information: {}\n",
    )
    .unwrap();
    std::fs::write(bag.join("export.csv"), "time,x\n0.5,1\n").unwrap();
    assert!(!is_topic_folder(&bag));

    let semicolons = d.as_path().join("excel.csv");
    std::fs::write(&semicolons, "time;u\n0,05;1,5\n").unwrap();
    let e = crate::Log::open(&semicolons).unwrap_err();
    assert!(e.what.contains("separated by `;`"), "{e}");

    let untimed = d.as_path().join("gains.txt");
    std::fs::write(&untimed, "kp,kd\n1,2\n").unwrap();
    let e = crate::Log::open(&untimed).unwrap_err();
    assert!(e.fix.contains("time column"), "{e}");
    std::fs::remove_dir_all(d).unwrap();
}

/// A file whose clock was set back while it was written (or two recordings appended) spans
/// its earliest to its latest row, is read in time order, and says where the step came; a
/// step under a millisecond (threads writing out of turn) is not said.
#[test]
fn a_time_that_steps_back_is_said_and_read_in_time_order() {
    let d = scratch("back");
    let f = d.as_path().join("wrench.csv");
    let rows = "time,fx\n10.0,1\n10.1,2\n10.2,3\n5.0,4\n5.1,5\n5.0995,6\n";
    std::fs::write(&f, rows).unwrap();
    let log = crate::Log::open(&f).unwrap();
    let t = &log.topics[0];
    assert_eq!((t.count, t.first_s, t.last_s), (6, 5.0, 10.2));
    let notes = log.notes();
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].starts_with("wrench.csv: its time steps back by 5.200 s at 5.200 s after"),
        "{notes:?}"
    );
    let fx = t.schema.select("fx").unwrap();
    let mut seen = Vec::new();
    log.read(&[0], &mut |m| {
        seen.push((m.log_time_s, fx.get(&m.value).unwrap()));
        Ok(())
    })
    .unwrap();
    let order: Vec<f64> = seen.iter().map(|s| s.1).collect();
    assert_eq!(order, [4.0, 6.0, 5.0, 1.0, 2.0, 3.0]);
    std::fs::write(&f, "time,fx\n10.0,1\n10.1,2\n10.0995,3\n").unwrap();
    let log = crate::Log::open(&f).unwrap();
    assert!(log.notes().is_empty(), "{:?}", log.notes());
    assert_eq!(log.topics[0].last_s, 10.1);
    std::fs::remove_dir_all(d).unwrap();
}

/// `rostopic echo -p /topic >> nav.csv` run twice appends a second header: its line is
/// skipped and said, the rows of both recordings are read.
#[test]
fn a_header_repeated_among_the_rows_is_skipped_and_said() {
    let d = scratch("repeat");
    let f = d.as_path().join("wrench_3.csv");
    let again = "%time,field.force.x,field.torque.z\n1669909209900000000,1.7,-0.3\n";
    std::fs::write(&f, format!("{WRENCH}{again}")).unwrap();
    let log = crate::Log::open(&f).unwrap();
    let t = &log.topics[0];
    assert_eq!(t.count, 3);
    assert!((t.last_s - 1_669_909_209.9).abs() < 1e-6, "{}", t.last_s);
    let notes = log.notes();
    assert_eq!(
        notes,
        [
            "wrench_3.csv: its header comes again once among its rows, first as row 4 (recordings appended to one file): those rows are skipped"
        ]
    );
    let fx = t.schema.select("force.x").unwrap();
    let mut seen = Vec::new();
    log.read(&[0], &mut |m| {
        seen.push(fx.get(&m.value).unwrap());
        Ok(())
    })
    .unwrap();
    assert_eq!(seen, [1.5, 1.6, 1.7]);
    // A header as the last row (a recording started and stopped at once) is no time.
    std::fs::write(&f, format!("{WRENCH}%time,field.force.x,field.torque.z\n")).unwrap();
    let log = crate::Log::open(&f).unwrap();
    assert_eq!(log.topics[0].count, 2);
    std::fs::remove_dir_all(d).unwrap();
}

/// A table timed by dates and times (a spreadsheet's, pandas' `to_csv`): read in seconds since
/// 1970, the zone a cell gives honoured, and said; a cell that is neither a number nor a date
/// is an error naming its row.
#[test]
fn a_time_column_of_dates_and_times_reads_as_seconds_since_1970() {
    let d = scratch("dates");
    let f = d.as_path().join("depth.csv");
    let rows = "datetime,depth_m\n2023-04-18 11:03:34.000,1.5\n2023-04-18T13:03:34.250+02:00,1.6\n2023-04-18 11:03:34.500Z,1.7\n";
    std::fs::write(&f, rows).unwrap();
    let log = crate::Log::open(&f).unwrap();
    assert_eq!(log.format, crate::Format::Csv);
    assert!((log.topics[0].first_s - 1_681_815_814.0).abs() < 1e-6);
    assert!((log.topics[0].last_s - 1_681_815_814.5).abs() < 1e-6);
    let notes = log.notes();
    assert!(
        notes.iter().any(|n| n.contains("dates and times")),
        "{notes:?}"
    );
    let depth = log.topics[0].schema.select("depth_m").unwrap();
    let mut seen = Vec::new();
    log.read(&[0], &mut |m| {
        seen.push((m.log_time_s - 1_681_815_814.0, depth.get(&m.value).unwrap()));
        Ok(())
    })
    .unwrap();
    let steps: Vec<f64> = seen.iter().map(|s| (s.0 * 1000.0).round()).collect();
    assert_eq!(steps, [0.0, 250.0, 500.0], "{seen:?}");
    assert_eq!(seen[1].1, 1.6);

    // pandas' `to_csv` of a DatetimeIndex given no name: the unnamed first column.
    std::fs::write(
        &f,
        ",depth_m\n2023-04-18 11:03:34.0,1.5\n2023-04-18 11:03:34.5,1.6\n",
    )
    .unwrap();
    let log = crate::Log::open(&f).unwrap();
    assert!((log.topics[0].last_s - 1_681_815_814.5).abs() < 1e-6);
    assert!(
        log.notes().iter().any(|n| n.contains("pandas")),
        "{:?}",
        log.notes()
    );
    assert!(log.topics[0].schema.select("depth_m").is_ok());

    std::fs::write(&f, "datetime,depth_m\n2023-04-18 11:03:34,1.5\nsoon,1.6\n").unwrap();
    let e = crate::Log::open(&f).unwrap_err();
    assert!(e.what.contains("row 3") && e.what.contains("`soon`"), "{e}");
    assert!(e.fix.contains("date and time"), "{e}");
    std::fs::remove_dir_all(d).unwrap();
}
