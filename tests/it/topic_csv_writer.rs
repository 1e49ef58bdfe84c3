//! A test fixture: a twin's run as `rostopic echo -p` would export its topics, one CSV per
//! topic (`%time`, the header's stamp, the fields), or as a simulator's tables (`timestamp` in
//! seconds, flat column names), for the log writer (`log_writer.rs`).

use crate::log_writer::{Row, Stream};
use std::path::Path;

/// `t` (s since the run's start) as `rostopic echo -p` writes times: whole nanoseconds since
/// the Unix epoch.
fn nanos(epoch_s: f64, t: f64) -> String {
    let at = epoch_s + t;
    let secs = at.floor();
    let ns = ((at - secs) * 1e9).round().min(999_999_999.0);
    format!("{}{:09}", secs as u64, ns as u64)
}

/// Each stream as its topic's `rostopic echo -p` file in the folder `path`: `%time` (the
/// receive time), the header's stamp where the type has a header, then the numbers.
pub fn write(path: &Path, streams: &[Stream], rows: &[Row], epoch_s: f64) -> anyhow::Result<()> {
    let stamped = |s: &Stream| !s.ros_type.ends_with("MultiArray");
    let header = |s: &Stream| {
        let names = s
            .ros_fields
            .iter()
            .map(|f| format!(",field.{}", f.replace(['[', ']'], "")));
        let stamp = if stamped(s) {
            ",field.header.seq,field.header.stamp,field.header.frame_id"
        } else {
            ""
        };
        format!("%time{stamp}{}", names.collect::<String>())
    };
    let time = |s: &Stream, k: usize, t: f64| match stamped(s) {
        true => format!("{},{k},{},base_link", nanos(epoch_s, t), nanos(epoch_s, t)),
        false => nanos(epoch_s, t),
    };
    write_tables(path, streams, rows, header, time)
}

/// The clock a simulator's tables start at, s (its own time since it started, not the epoch).
const SIM_START_S: f64 = 312.5;

/// A field's name as a flat table column: `pose.pose.orientation.x` is
/// `pose_pose_orientation_x`, `data[3]` is `data3`.
pub fn flat(field: &str) -> String {
    field.replace('.', "_").replace(['[', ']'], "")
}

/// Each stream as a table in the folder `path`, as a simulator or an analysis tool writes
/// them: `timestamp` in seconds of its own clock, then the numbers under flat names.
pub fn write_plain(path: &Path, streams: &[Stream], rows: &[Row]) -> anyhow::Result<()> {
    let header = |s: &Stream| {
        let names = s.ros_fields.iter().map(|f| format!(",{}", flat(f)));
        format!("timestamp{}", names.collect::<String>())
    };
    let time = |_: &Stream, _: usize, t: f64| format!("{:.9}", SIM_START_S + t);
    write_tables(path, streams, rows, header, time)
}

/// Each stream as `<topic>.csv` in the folder `path`: the `header` line, then per row its
/// time cells (`time` of the stream, the row's index in it and its time) and its numbers.
fn write_tables(
    path: &Path,
    streams: &[Stream],
    rows: &[Row],
    header: impl Fn(&Stream) -> String,
    time: impl Fn(&Stream, usize, f64) -> String,
) -> anyhow::Result<()> {
    std::fs::create_dir_all(path)?;
    for s in streams {
        let mut text = header(s) + "\n";
        for (k, r) in rows.iter().filter(|r| r.stream == s.name).enumerate() {
            text += &time(s, k, r.t);
            for x in &r.numbers {
                text += &format!(",{x}");
            }
            text += "\n";
        }
        let stem = s.ros_topic.trim_start_matches('/');
        std::fs::write(path.join(format!("{stem}.csv")), text)?;
    }
    Ok(())
}
