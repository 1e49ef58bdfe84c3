//! Writes `.db3` bags with the tables rosbag2's `sqlite3` storage plugin creates: Humble's
//! (no message definitions) or Jazzy's (`message_definitions`, type hashes left empty, as
//! rosbag2 does for a type it has no hash of). For tests, and for simulators that log their
//! synthetic runs as a ROS 2 Humble vehicle would.

use crate::compress::{Codec, compress};
use crate::msgdef::{Flavor, schema};
use crate::value::{Schema, Value};
use crate::wire::split_time;
use crate::{LogError, encode, ros_types};
use rusqlite::Connection;
use std::path::{Path, PathBuf};

/// Which rosbag2 release's tables to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// ROS 2 Humble: no definitions in the bag (readers must know the types).
    Humble,
    /// ROS 2 Jazzy: each type's `.msg` text in `message_definitions`.
    Jazzy,
}

struct Channel {
    schema: Schema,
    topic: String,
}

/// A `.db3` bag being written, in one transaction: call [`Writer::finish`] to commit it.
pub struct Writer {
    path: PathBuf,
    db: Connection,
    layout: Layout,
    channels: Vec<Channel>,
    /// Whether messages are written zstd-compressed one by one (`--compression-mode message`).
    compress: bool,
}

impl Writer {
    /// Creates `path` (replacing a file there) with the tables of `layout`.
    pub fn create(path: &Path, layout: Layout) -> Result<Writer, LogError> {
        let fail = |e: rusqlite::Error| LogError::new(path, format!("cannot write the bag: {e}"));
        if path.exists() {
            std::fs::remove_file(path)
                .map_err(|e| LogError::new(path, format!("cannot replace the file: {e}")))?;
        }
        let db = Connection::open(path).map_err(fail)?;
        let hash = match layout {
            Layout::Humble => "",
            Layout::Jazzy => ", type_description_hash TEXT NOT NULL",
        };
        let (version, distro) = match layout {
            Layout::Humble => (3, "humble"),
            Layout::Jazzy => (4, "jazzy"),
        };
        let mut sql = format!(
            "PRAGMA journal_mode = MEMORY; PRAGMA synchronous = OFF; BEGIN;
             CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
             INSERT INTO schema VALUES ({version}, '{distro}');
             CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
               serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL{hash});
             CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,
               timestamp INTEGER NOT NULL, data BLOB NOT NULL);
             CREATE INDEX timestamp_idx ON messages (timestamp ASC);"
        );
        if layout == Layout::Jazzy {
            sql.push_str(
                "CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL,
                   encoding TEXT NOT NULL, encoded_message_definition TEXT NOT NULL,
                   type_description_hash TEXT NOT NULL);",
            );
        }
        db.execute_batch(&sql).map_err(fail)?;
        Ok(Writer {
            path: path.to_path_buf(),
            db,
            layout,
            channels: Vec::new(),
            compress: false,
        })
    }

    /// Writes every later message zstd-compressed on its own, as rosbag2's `message`
    /// compression mode does.
    pub fn compress_messages(&mut self, on: bool) {
        self.compress = on;
    }

    fn fail(&self, e: rusqlite::Error) -> LogError {
        LogError::new(&self.path, format!("cannot write the bag: {e}"))
    }

    /// Adds a topic whose type has the ROS 2 definition `definition` (its own lines, then
    /// each type it uses after a line of `=`). Returns its id.
    pub fn add_channel(
        &mut self,
        topic: &str,
        type_name: &str,
        definition: &str,
    ) -> Result<i64, LogError> {
        let schema = schema(definition, type_name, Flavor::Ros2)
            .map_err(|e| LogError::new(&self.path, format!("definition of {type_name}: {e}")))?;
        let id = self.channels.len() as i64 + 1;
        let (sql, hash) = match self.layout {
            Layout::Humble => ("INSERT INTO topics VALUES (?1, ?2, ?3, 'cdr', '')", None),
            Layout::Jazzy => (
                "INSERT INTO topics VALUES (?1, ?2, ?3, 'cdr', '', '')",
                Some(()),
            ),
        };
        self.db
            .execute(sql, (id, topic, type_name))
            .map_err(|e| self.fail(e))?;
        if hash.is_some() {
            self.db
                .execute(
                    "INSERT INTO message_definitions (topic_type, encoding, \
                     encoded_message_definition, type_description_hash) \
                     SELECT ?1, 'ros2msg', ?2, '' WHERE NOT EXISTS \
                     (SELECT 1 FROM message_definitions WHERE topic_type = ?1)",
                    (type_name, definition),
                )
                .map_err(|e| self.fail(e))?;
        }
        self.channels.push(Channel {
            schema,
            topic: topic.to_string(),
        });
        Ok(id)
    }

    /// Adds a topic of one of the common types [`ros_types`] defines (`sensor_msgs/Imu`).
    pub fn add_topic(&mut self, topic: &str, type_name: &str) -> Result<i64, LogError> {
        let def = ros_types::ros2(type_name).ok_or_else(|| {
            LogError::new(&self.path, format!("no built-in definition of {type_name}"))
        })?;
        self.add_channel(topic, &ros_types::ros2_name(type_name), &def)
    }

    /// The layout a message on topic `id` must have.
    pub fn schema(&self, id: i64) -> Option<&Schema> {
        usize::try_from(id - 1)
            .ok()
            .and_then(|i| self.channels.get(i))
            .map(|c| &c.schema)
    }

    /// Writes a message received at `time_s` (seconds since the Unix epoch).
    pub fn write(&mut self, id: i64, time_s: f64, value: &Value) -> Result<(), LogError> {
        let ch = usize::try_from(id - 1)
            .ok()
            .and_then(|i| self.channels.get(i))
            .ok_or_else(|| LogError::new(&self.path, format!("no topic {id}")))?;
        let payload = encode::cdr(&ch.schema, value)
            .map_err(|e| LogError::new(&self.path, format!("{}: {e}", ch.topic)))?;
        self.write_bytes(id, time_s, &payload)
    }

    /// Writes a message already serialized (CDR with its encapsulation header) as it is.
    pub fn write_bytes(&mut self, id: i64, time_s: f64, payload: &[u8]) -> Result<(), LogError> {
        let ns = split_time(time_s)
            .and_then(|(s, ns)| s.checked_mul(1_000_000_000)?.checked_add(i64::from(ns)))
            .filter(|&ns| ns >= 0)
            .ok_or_else(|| LogError::new(&self.path, format!("time {time_s} s out of range")))?;
        let packed;
        let data = if self.compress {
            packed = compress(Codec::Zstd, payload)
                .map_err(|e| LogError::new(&self.path, format!("zstd: {e}")))?;
            &packed[..]
        } else {
            payload
        };
        self.db
            .execute(
                "INSERT INTO messages (topic_id, timestamp, data) VALUES (?1, ?2, ?3)",
                (id, ns, data),
            )
            .map_err(|e| self.fail(e))?;
        Ok(())
    }

    /// Commits the bag.
    pub fn finish(self) -> Result<(), LogError> {
        self.db.execute_batch("COMMIT;").map_err(|e| self.fail(e))
    }
}
