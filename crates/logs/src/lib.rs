//! Logs as vehicles write them, read without user code: ROS 1 bags (`.bag`), ROS 2 bags
//! (MCAP `.mcap` and SQLite `.db3`, CDR payloads), ArduPilot DataFlash logs (`.BIN`), MAVLink
//! telemetry logs (`.tlog`), PX4 ULog files (`.ulg`) and CSV files with a time column (a topic per file: `rostopic echo
//! -p`'s exports, PlotJuggler's, PX4's, a simulator's). All but the tlog describe their own messages (a ROS message
//! definition, an MCAP schema, a DataFlash FMT record, a ULog format record), so any message is decoded into a
//! [`Value`] tree without compiled-in types; MAVLink is not self-describing, so the tlog
//! reader compiles in the messages ArduSub users need. A field is picked by its path
//! (`twist.twist.linear.x`, `data[3]`, `C1`).
//!
//! [`Log::open`] reads what a log holds (its topics, their types, counts and time spans) as
//! `rosbag info` would; [`Log::read`] decodes the messages of the topics asked for.
//! Every error says where in the file it is ([`LogError`]): a damaged log is never a panic.
//!
//! [`write`](mod@write) writes ROS 1 bags and MCAP files (for tests, and for simulators that
//! log their synthetic runs as a vehicle would), with the common message types of
//! [`ros_types`].

mod compress;
pub mod csv_clock;
pub mod dataflash;
pub mod db3;
mod encode;
pub mod error;
pub mod iso_time;
pub mod mcap;
mod merge;
pub mod msg_files;
pub mod msgdef;
pub mod ros1;
pub mod ros_types;
pub mod tlog;
pub mod topic_csv;
pub mod ulog;
pub mod value;
mod wire;
pub mod write;

pub use error::LogError;
pub use value::{Field, Leaf, Schema, Selector, Value};

use std::path::{Path, PathBuf};

/// The file formats a log may have.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// ROS 1 bag, version 2.0 (uncompressed, bz2 or lz4 chunks).
    Ros1Bag,
    /// MCAP (ROS 2 `ros2msg` schemas with CDR messages, or `ros1msg` with ROS 1 messages).
    Mcap,
    /// ArduPilot DataFlash binary log (`.BIN`), self-described by FMT records.
    DataFlash,
    /// MAVLink telemetry log (`.tlog`): receive times and MAVLink 1/2 packets.
    Tlog,
    /// PX4 ULog (`.ulg`), self-described by its format records.
    Ulog,
    /// ROS 2 bag in SQLite (`.db3`), CDR messages.
    Db3,
    /// Topics exported by `rostopic echo -p`: a CSV file per topic, or a folder of them.
    TopicCsv,
    /// Any other CSV file with a time column (one topic), or a folder of them.
    Csv,
}

impl Format {
    pub fn name(self) -> &'static str {
        match self {
            Format::Ros1Bag => "ROS 1 bag",
            Format::Mcap => "MCAP",
            Format::DataFlash => "ArduPilot DataFlash log",
            Format::Tlog => "MAVLink telemetry log",
            Format::Ulog => "PX4 ULog",
            Format::Db3 => "ROS 2 SQLite bag",
            Format::TopicCsv => "rostopic CSV",
            Format::Csv => "CSV with a time column",
        }
    }
}

/// One topic (ROS, ULog) or message type (DataFlash) of a log.
#[derive(Debug, Clone)]
pub struct Topic {
    /// The topic (`/mavros/imu/data`) or the DataFlash message name (`ATT`).
    pub name: String,
    /// The message type (`sensor_msgs/Imu`; for DataFlash the message name again).
    pub type_name: String,
    /// How many messages the log holds on it.
    pub count: u64,
    /// The log time of the first and the last message, seconds (the log's own clock: ROS
    /// receive time since the Unix epoch, DataFlash `TimeUS` since boot, tlog receive time
    /// since the Unix epoch).
    pub first_s: f64,
    pub last_s: f64,
    /// The message's layout.
    pub schema: Schema,
}

impl Topic {
    /// Messages per second over the topic's span (0 for fewer than two messages).
    pub fn rate_hz(&self) -> f64 {
        let span = self.last_s - self.first_s;
        if self.count > 1 && span > 0.0 {
            (self.count - 1) as f64 / span
        } else {
            0.0
        }
    }
}

/// One decoded message.
#[derive(Debug, Clone)]
pub struct Message {
    /// Index of the topic in [`Log::topics`].
    pub topic: usize,
    /// The time the log recorded the message at, seconds (ROS: receive time since the Unix
    /// epoch; MCAP: `log_time`; DataFlash: `TimeUS` / 1e6; tlog: the record's receive time
    /// since the Unix epoch).
    pub log_time_s: f64,
    /// `header.stamp` (seconds since the Unix epoch) when the message has a ROS header whose
    /// stamp is not zero; `None` otherwise.
    pub stamp_s: Option<f64>,
    /// The message, laid out as the topic's schema says.
    pub value: Value,
}

/// What the user says of a log that the log does not say itself.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Options {
    /// Seconds per unit of a CSV table's time column whose name gives no unit (`None`: read
    /// from its values, [`csv_clock`]).
    pub csv_time_unit_s: Option<f64>,
    /// Folders searched first for the `.msg` files of types a `.db3` bag does not define
    /// ([`msg_files`]).
    pub msg_folders: Vec<PathBuf>,
}

/// An open log: what it holds, and the means to read it.
#[derive(Debug)]
pub struct Log {
    pub path: PathBuf,
    pub format: Format,
    pub topics: Vec<Topic>,
    inner: Inner,
}

/// What a reader keeps between listing the topics and reading them (the file's bytes, chunk
/// and record offsets, FMT records), so that `read` does not parse the index twice.
#[derive(Debug)]
enum Inner {
    Ros1(ros1::Bag),
    Mcap(mcap::File),
    DataFlash(dataflash::Bin),
    Tlog(tlog::Tlog),
    Ulog(ulog::Ulog),
    Db3(db3::Db3),
    TopicCsv(topic_csv::TopicCsv),
}

/// The first bytes of each format.
const ROS1_MAGIC: &[u8] = b"#ROSBAG V2.0\n";
const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";
const DATAFLASH_MAGIC: &[u8] = &[0xA3, 0x95];
const ZSTD_MAGIC: &[u8] = &[0x28, 0xB5, 0x2F, 0xFD];

const HEADERLESS: &str = "a CSV table without a header (its first row is numbers): its columns have no names to read them by";
const HEADERLESS_FIX: &str = "give the table a header line naming its columns, the time among them (`t` in seconds, or `time_ms`, ...): MATLAB's `writetable` writes one, `writematrix` does not; or convert it into a run folder's files (docs/formats.md)";

/// A file that holds no log at all: empty (a copy or a download that did not finish), or a
/// Git LFS pointer (a repository cloned without `git lfs`, whose large files are stubs).
fn not_a_log(path: &Path, data: &[u8]) -> Option<LogError> {
    if data.is_empty() {
        return Some(
            LogError::new(path, "the file is empty (0 bytes)")
                .at(0)
                .fix("copy the log again: a copy or download that stopped leaves an empty file"),
        );
    }
    if data.starts_with(b"version https://git-lfs.github.com/spec/") {
        let size = String::from_utf8_lossy(&data[..data.len().min(400)])
            .lines()
            .find_map(|l| l.strip_prefix("size ").map(str::to_string))
            .unwrap_or_else(|| "?".into());
        return Some(
            LogError::new(
                path,
                format!("a Git LFS pointer, not the log (the log is {size} bytes, not fetched)"),
            )
            .at(0)
            .fix("fetch the large files of the clone: `git lfs install && git lfs pull`"),
        );
    }
    None
}

/// The error for a folder of CSV files none of which names a time: each listed, those whose
/// first row is numbers said to have no header.
fn untimed_folder(path: &Path, files: &[(PathBuf, bool)]) -> LogError {
    let list: Vec<String> = (files.iter())
        .map(|(f, headerless)| {
            let name = f.file_name().unwrap_or_default().to_string_lossy();
            match headerless {
                true => format!("{name} (no header: its first row is numbers)"),
                false => format!("{name} (no time column in its header)"),
            }
        })
        .collect();
    LogError::new(
        path,
        format!(
            "a folder of CSV files none of which names a time column: {}",
            list.join(", ")
        ),
    )
    .fix(HEADERLESS_FIX)
}

impl Log {
    /// Opens `path`, recognises its format by its first bytes (not its extension) and lists
    /// its topics. Reads the index where the format has one, otherwise scans the file once.
    /// A tlog has no magic bytes: a file whose first bytes are none of the others' is read as
    /// a tlog when its name ends in `.tlog`. A rosbag2 folder is opened through its storage
    /// file ([`db3::storage_file`]), which is then the log's `path`.
    pub fn open(path: &Path) -> Result<Log, LogError> {
        Log::open_with(path, &Options::default())
    }

    /// [`Log::open`] with what the user says of the log ([`Options`]).
    pub fn open_with(path: &Path, options: &Options) -> Result<Log, LogError> {
        if topic_csv::is_topic_folder(path) {
            return Log::csv(path, options);
        }
        if let Some(files) = topic_csv::untimed_folder(path) {
            return Err(untimed_folder(path, &files));
        }
        let path = &db3::storage_file(path)?;
        let data = std::fs::read(path).map_err(|e| {
            LogError::new(path, format!("cannot read the log: {e}"))
                .fix("give the path of a ROS 1 bag, an MCAP file, an ArduPilot .BIN log, a PX4 .ulg or a .tlog")
        })?;
        if let Some(e) = not_a_log(path, &data) {
            return Err(e);
        }
        let (format, topics, inner) = if data.starts_with(ROS1_MAGIC) {
            let (bag, topics) = ros1::Bag::open(path, data)?;
            (Format::Ros1Bag, topics, Inner::Ros1(bag))
        } else if data.starts_with(MCAP_MAGIC) {
            let (file, topics) = mcap::File::open(path, data)?;
            (Format::Mcap, topics, Inner::Mcap(file))
        } else if data.starts_with(DATAFLASH_MAGIC) {
            let (bin, topics) = dataflash::Bin::open(path, data)?;
            (Format::DataFlash, topics, Inner::DataFlash(bin))
        } else if data.starts_with(ulog::MAGIC) {
            let (ulog, topics) = ulog::Ulog::open(path, data)?;
            (Format::Ulog, topics, Inner::Ulog(ulog))
        } else if data.starts_with(b"#ROSBAG V") {
            return Err(LogError::new(path, "a ROS bag of a version other than 2.0")
                .at(0)
                .fix("re-record or migrate the bag with ROS 1's `rosbag` (format 2.0)"));
        } else if is_tlog(path) {
            let (tlog, topics) = tlog::Tlog::open(path, data)?;
            (Format::Tlog, topics, Inner::Tlog(tlog))
        } else if data.starts_with(db3::MAGIC) {
            drop(data);
            let (db, topics) = db3::Db3::open(path, &options.msg_folders)?;
            (Format::Db3, topics, Inner::Db3(db))
        } else if topic_csv::is_timed_csv(&data) {
            drop(data);
            return Log::csv(path, options);
        } else if topic_csv::is_semicolon_csv(&data) {
            return Err(LogError::new(
                path,
                "a CSV table separated by `;` (a spreadsheet's export, decimal commas?)",
            )
            .at(0)
            .fix("export it with `,` between columns and `.` as the decimal point"));
        } else if topic_csv::is_headerless_table(&data) {
            return Err(LogError::new(path, HEADERLESS).at(0).fix(HEADERLESS_FIX));
        } else if data.starts_with(ZSTD_MAGIC) {
            return Err(LogError::new(
                path,
                "a zstd-compressed file (a rosbag2 bag compressed in `file` mode?)",
            )
            .at(0)
            .fix("inflate it first (`zstd -d bag_0.db3.zstd`) and give the inflated file"));
        } else {
            return Err(LogError::new(
                path,
                "not a ROS 1 bag, an MCAP file, an ArduPilot DataFlash log or a PX4 ULog (unknown first bytes)",
            )
            .at(0)
            .fix("give the log the vehicle wrote (.bag, .mcap, .BIN, .ulg, a .tlog named so, or a CSV file whose header names a time column: `time`, `timestamp`, `t`, `%time`)"));
        };
        Ok(Log {
            path: path.to_path_buf(),
            format,
            topics,
            inner,
        })
    }

    /// A CSV file with a time column, or a folder of them.
    fn csv(path: &Path, options: &Options) -> Result<Log, LogError> {
        let (csv, topics) = topic_csv::TopicCsv::open(path, options.csv_time_unit_s)?;
        let format = match csv.is_rostopic() {
            true => Format::TopicCsv,
            false => Format::Csv,
        };
        Ok(Log {
            path: path.to_path_buf(),
            format,
            topics,
            inner: Inner::TopicCsv(csv),
        })
    }

    /// The topic named `name`, if the log has it. A ROS name is the same with or without its
    /// leading slash (a recorder in the root namespace writes `/rovio/thrusters`, ROS 2 bags
    /// always `/...`, and a user may name it `rovio/thrusters` as `rostopic` accepts); the exact
    /// name is preferred where a log has both.
    pub fn topic(&self, name: &str) -> Option<usize> {
        let bare = |n: &str| n.strip_prefix('/').unwrap_or(n).to_string();
        self.topics
            .iter()
            .position(|t| t.name == name)
            .or_else(|| self.topics.iter().position(|t| bare(&t.name) == bare(name)))
    }

    /// Calls `each` with every message of the topics `wanted` (indices into `topics`), in log
    /// time order. Stops at the first error `each` returns, or at damage in the file.
    pub fn read(
        &self,
        wanted: &[usize],
        each: &mut dyn FnMut(&Message) -> Result<(), LogError>,
    ) -> Result<(), LogError> {
        match &self.inner {
            Inner::Ros1(b) => b.read(&self.path, &self.topics, wanted, each),
            Inner::Mcap(f) => f.read(&self.path, &self.topics, wanted, each),
            Inner::DataFlash(b) => b.read(&self.path, &self.topics, wanted, each),
            Inner::Tlog(t) => t.read(&self.path, &self.topics, wanted, each),
            Inner::Ulog(u) => u.read(&self.path, &self.topics, wanted, each),
            Inner::Db3(d) => d.read(&self.path, &self.topics, wanted, each),
            Inner::TopicCsv(c) => c.read(wanted, each),
        }
    }

    /// Why the messages of `topic` cannot be decoded, and the fix, for a topic the log lists
    /// but cannot read (a `.db3` bag's type with no definition found); `None` otherwise.
    pub fn undecodable(&self, topic: usize) -> Option<(String, String)> {
        match &self.inner {
            Inner::Db3(d) => d.refused(topic),
            _ => None,
        }
    }

    /// What the reader stepped over in a log it could still read (damaged bytes skipped, a
    /// last record cut off, packets with a bad checksum) and what it assumed (the unit of a CSV
    /// file's time column where its name does not give one), one sentence each; empty for an
    /// undamaged log. Formats that do not report such things yet give none.
    pub fn notes(&self) -> Vec<String> {
        match &self.inner {
            Inner::Ros1(b) => b.notes(),
            Inner::Mcap(f) => f.notes(),
            Inner::DataFlash(b) => b.notes(),
            Inner::Tlog(t) => t.notes(),
            Inner::Ulog(u) => u.notes(),
            Inner::Db3(d) => d.notes(),
            Inner::TopicCsv(c) => c.notes(),
        }
    }

    /// [`Log::notes`] about what reading `topics` meets: for a folder of topic files, the
    /// notes of those topics' files only (and the folder's files that are not read); for a
    /// log in one file, all of its notes.
    pub fn notes_for(&self, topics: &[usize]) -> Vec<String> {
        match &self.inner {
            Inner::TopicCsv(c) => c.notes_of(topics),
            _ => self.notes(),
        }
    }

    /// The files the messages of `topics` are read from: the log's own file, or for a folder
    /// of topic files each topic's file, and the `.msg` files a `.db3` bag's types were read
    /// from (each is an input of what is read from it).
    pub fn files(&self, topics: &[usize]) -> Vec<PathBuf> {
        match &self.inner {
            Inner::Db3(d) => {
                let mut out = vec![self.path.clone()];
                out.extend(d.msg_files(topics));
                out
            }
            Inner::TopicCsv(c) if self.path.is_dir() => {
                let mut out: Vec<PathBuf> =
                    topics.iter().map(|&t| c.file(t).to_path_buf()).collect();
                out.sort();
                out.dedup();
                out
            }
            _ => vec![self.path.clone()],
        }
    }
}

/// Whether `path` is named as a tlog (`.tlog`, any case).
fn is_tlog(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("tlog"))
}

/// `wanted` as a set over the topic indices; an index past the topics is the caller's error.
pub(crate) fn wanted_set(
    path: &std::path::Path,
    n: usize,
    wanted: &[usize],
) -> Result<Vec<bool>, LogError> {
    let mut want = vec![false; n];
    for &w in wanted {
        let Some(slot) = want.get_mut(w) else {
            return Err(LogError::new(
                path,
                format!("no topic {w}: the log has {n} topics"),
            ));
        };
        *slot = true;
    }
    Ok(want)
}

#[cfg(test)]
mod tests {
    /// A table without a header (MATLAB's `writematrix`) and a folder of them are refused
    /// as what they are, with how to write them, not as logs of unknown bytes or bags.
    #[test]
    fn a_table_without_a_header_is_named_as_such() {
        let d = std::env::temp_dir().join(format!("hydrofit-headerless-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let pose = d.join("pose_data.csv");
        std::fs::write(&pose, "-1.2e-18,4.84e-05,0,0.02\n0.1,0.2,0.3,0.4\n").unwrap();
        std::fs::write(d.join("gains.csv"), "kp,kd\n1,2\n").unwrap();
        let e = super::Log::open(&pose).unwrap_err();
        assert!(e.what.contains("without a header"), "{e}");
        assert!(e.fix.contains("writematrix"), "{e}");
        let e = super::Log::open(&d).unwrap_err();
        assert!(
            e.what.contains("gains.csv (no time column in its header)")
                && e.what
                    .contains("pose_data.csv (no header: its first row is numbers)"),
            "{e}"
        );
        std::fs::remove_dir_all(d).unwrap();
    }

    /// An empty file and a Git LFS pointer are said to be what they are, with the fix.
    #[test]
    fn an_empty_file_and_an_lfs_pointer_are_named() {
        let d = std::env::temp_dir().join(format!("hydrofit-nolog-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let empty = d.join("bag_0.mcap");
        std::fs::write(&empty, "").unwrap();
        let e = super::Log::open(&empty).unwrap_err();
        assert!(e.what.contains("empty (0 bytes)"), "{e}");
        let pointer = d.join("dive.bag");
        let text =
            "version https://git-lfs.github.com/spec/v1\noid sha256:4d7a2146\nsize 3800660\n";
        std::fs::write(&pointer, text).unwrap();
        let e = super::Log::open(&pointer).unwrap_err();
        assert!(
            e.what.contains("Git LFS pointer") && e.what.contains("3800660"),
            "{e}"
        );
        assert!(e.fix.contains("git lfs pull"), "{e}");
        std::fs::remove_dir_all(d).unwrap();
    }
}
