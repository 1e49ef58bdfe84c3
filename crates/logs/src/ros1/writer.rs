//! Writes ROS 1 bags (format 2.0) as `rosbag record` does: the bag header padded to 4096 bytes,
//! chunks of about 768 KiB each followed by their index data records, and on `finish` the
//! connection and chunk info records, with the bag header rewritten to point at them.

use super::index::MAGIC_LEN;
use super::record::*;
use crate::compress::{Codec, compress};
use crate::msgdef::{Definition, Flavor};
use crate::value::{Schema, Value};
use crate::{LogError, encode, ros_types};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// How the writer compresses its chunks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    None,
    Bz2,
    Lz4,
}

/// `rosbag`'s default chunk threshold.
const CHUNK_SIZE: usize = 768 * 1024;
/// The bag header record is padded to this many bytes so that it can be rewritten in place.
const BAG_HEADER_LEN: usize = 4096;

struct Conn {
    topic: String,
    type_name: String,
    md5: String,
    definition: String,
    schema: Schema,
    written: bool,
}

/// A chunk written: where, when, and how many messages of each connection.
struct ChunkInfo {
    pos: u64,
    start_ns: u64,
    end_ns: u64,
    counts: BTreeMap<u32, u32>,
}

/// A bag being written. Call [`Writer::finish`] to write its index; a bag not finished is
/// still readable (by scanning), like one whose recording was cut off.
pub struct Writer {
    path: PathBuf,
    out: BufWriter<File>,
    pos: u64,
    codec: Codec,
    conns: Vec<Conn>,
    chunk: Vec<u8>,
    /// Index entries of the open chunk, per connection: (time ns, offset in the chunk).
    entries: BTreeMap<u32, Vec<(u64, u32)>>,
    infos: Vec<ChunkInfo>,
    chunk_size: usize,
}

impl Writer {
    /// Creates (or truncates) the bag at `path`.
    pub fn create(path: &Path, compression: Compression) -> Result<Writer, LogError> {
        let file = File::create(path).map_err(|e| io_err(path, e))?;
        let mut w = Writer {
            path: path.to_path_buf(),
            out: BufWriter::with_capacity(1 << 20, file),
            pos: 0,
            codec: match compression {
                Compression::None => Codec::None,
                Compression::Bz2 => Codec::Bz2,
                Compression::Lz4 => Codec::Lz4,
            },
            conns: Vec::new(),
            chunk: Vec::with_capacity(CHUNK_SIZE + 4096),
            entries: BTreeMap::new(),
            infos: Vec::new(),
            chunk_size: CHUNK_SIZE,
        };
        w.put(b"#ROSBAG V2.0\n")?;
        let header = bag_header(0, 0, 0);
        w.put(&header)?;
        Ok(w)
    }

    /// Adds a topic with its ROS 1 message definition (the main type's text, then each type
    /// it uses after a `===` line and `MSG: pkg/Type`); returns its id for [`Writer::write`].
    pub fn add_connection(
        &mut self,
        topic: &str,
        type_name: &str,
        definition: &str,
    ) -> Result<u32, LogError> {
        let def = Definition::parse(definition, type_name, Flavor::Ros1)
            .map_err(|e| LogError::new(&self.path, format!("definition of {type_name}: {e}")))?;
        let schema = def
            .schema()
            .map_err(|e| LogError::new(&self.path, format!("{type_name}: {e}")))?;
        let md5 = def
            .md5()
            .map_err(|e| LogError::new(&self.path, format!("{type_name}: {e}")))?;
        self.conns.push(Conn {
            topic: topic.to_string(),
            type_name: type_name.to_string(),
            md5,
            definition: definition.to_string(),
            schema,
            written: false,
        });
        Ok(self.conns.len() as u32 - 1)
    }

    /// Adds a topic of one of the common types [`ros_types`] defines (`nav_msgs/Odometry`).
    pub fn add_topic(&mut self, topic: &str, type_name: &str) -> Result<u32, LogError> {
        let def = ros_types::ros1(type_name).ok_or_else(|| {
            LogError::new(&self.path, format!("no built-in definition of {type_name}")).fix(
                format!(
                    "give its definition to add_connection; built in: {}",
                    ros_types::COMMON.join(", ")
                ),
            )
        })?;
        self.add_connection(topic, type_name, &def)
    }

    /// The layout a message on connection `id` must have.
    pub fn schema(&self, id: u32) -> Option<&Schema> {
        self.conns.get(id as usize).map(|c| &c.schema)
    }

    /// Writes a message received at `time_s` (seconds since the Unix epoch).
    pub fn write(&mut self, id: u32, time_s: f64, value: &Value) -> Result<(), LogError> {
        let Some(conn) = self.conns.get(id as usize) else {
            return Err(LogError::new(&self.path, format!("no connection {id}")));
        };
        let bytes = encode::ros1(&conn.schema, value).map_err(|e| {
            LogError::new(
                &self.path,
                format!("{} ({}): {e}", conn.topic, conn.type_name),
            )
        })?;
        self.write_bytes(id, time_s, &bytes)
    }

    /// Writes a message already serialized (ROS 1 serialization) as it is: for copying
    /// messages, and for testing readers with messages that do not match their type.
    pub fn write_bytes(&mut self, id: u32, time_s: f64, bytes: &[u8]) -> Result<(), LogError> {
        let Some(conn) = self.conns.get(id as usize) else {
            return Err(LogError::new(&self.path, format!("no connection {id}")));
        };
        let time = crate::wire::split_time(time_s)
            .and_then(|(s, ns)| Some((u32::try_from(s).ok()?, ns)))
            .ok_or_else(|| {
                LogError::new(
                    &self.path,
                    format!("time {time_s} s is out of ROS 1's range"),
                )
            })?;
        if !conn.written {
            let record = self.connection_record(id);
            self.chunk.extend(record);
            self.conns[id as usize].written = true;
        }
        let offset = self.chunk.len() as u32;
        let mut t = time.0.to_le_bytes().to_vec();
        t.extend(time.1.to_le_bytes());
        put_record(
            &mut self.chunk,
            &[
                ("op", &[OP_MSG_DATA]),
                ("conn", &id.to_le_bytes()),
                ("time", &t),
            ],
            bytes,
        );
        let ns = time.0 as u64 * 1_000_000_000 + time.1 as u64;
        self.entries.entry(id).or_default().push((ns, offset));
        if self.chunk.len() >= self.chunk_size {
            self.flush_chunk()?;
        }
        Ok(())
    }

    /// Closes chunks once they hold `bytes` of records (default about 1 MiB); small chunks
    /// make small test files with many chunks.
    pub fn set_chunk_size(&mut self, bytes: usize) {
        self.chunk_size = bytes.max(1);
    }

    /// Writes the last chunk and the index, and points the bag header at it.
    pub fn finish(mut self) -> Result<(), LogError> {
        self.flush_chunk()?;
        let index_pos = self.pos;
        let mut index = Vec::new();
        for id in 0..self.conns.len() as u32 {
            index.extend(self.connection_record(id));
        }
        for info in &self.infos {
            put_chunk_info(&mut index, info);
        }
        self.put(&index)?;
        let header = bag_header(index_pos, self.conns.len() as u32, self.infos.len() as u32);
        let path = self.path.clone();
        let mut file = self
            .out
            .into_inner()
            .map_err(|e| io_err(&path, e.into_error()))?;
        file.seek(SeekFrom::Start(MAGIC_LEN as u64))
            .map_err(|e| io_err(&path, e))?;
        file.write_all(&header).map_err(|e| io_err(&path, e))?;
        file.sync_all().map_err(|e| io_err(&path, e))
    }

    fn connection_record(&self, id: u32) -> Vec<u8> {
        let c = &self.conns[id as usize];
        let mut data = Vec::new();
        put_fields(
            &mut data,
            &[
                ("topic", c.topic.as_bytes()),
                ("type", c.type_name.as_bytes()),
                ("md5sum", c.md5.as_bytes()),
                ("message_definition", c.definition.as_bytes()),
            ],
        );
        let mut out = Vec::new();
        let head: [(&str, &[u8]); 3] = [
            ("op", &[OP_CONNECTION]),
            ("conn", &id.to_le_bytes()),
            ("topic", c.topic.as_bytes()),
        ];
        put_record(&mut out, &head, &data);
        out
    }

    /// Compresses and writes the open chunk, then its index data records.
    fn flush_chunk(&mut self) -> Result<(), LogError> {
        if self.entries.is_empty() {
            return Ok(());
        }
        let packed = compress(self.codec, &self.chunk).map_err(|e| io_err(&self.path, e))?;
        let size = (self.chunk.len() as u32).to_le_bytes();
        let name = match self.codec {
            Codec::Bz2 => "bz2",
            Codec::Lz4 => "lz4",
            _ => "none",
        };
        let mut out = Vec::with_capacity(packed.len() + 4096);
        put_record(
            &mut out,
            &[
                ("op", &[OP_CHUNK]),
                ("compression", name.as_bytes()),
                ("size", &size),
            ],
            &packed,
        );
        let mut info = ChunkInfo {
            pos: self.pos,
            start_ns: u64::MAX,
            end_ns: 0,
            counts: BTreeMap::new(),
        };
        for (&id, list) in &self.entries {
            let mut data = Vec::with_capacity(list.len() * 12);
            for &(ns, offset) in list {
                data.extend(ros_time(ns));
                data.extend(offset.to_le_bytes());
                info.start_ns = info.start_ns.min(ns);
                info.end_ns = info.end_ns.max(ns);
            }
            let n = list.len() as u32;
            info.counts.insert(id, n);
            let head: [(&str, &[u8]); 4] = [
                ("op", &[OP_INDEX_DATA]),
                ("ver", &1u32.to_le_bytes()),
                ("conn", &id.to_le_bytes()),
                ("count", &n.to_le_bytes()),
            ];
            put_record(&mut out, &head, &data);
        }
        self.put(&out)?;
        self.infos.push(info);
        self.chunk.clear();
        self.entries.clear();
        Ok(())
    }

    fn put(&mut self, bytes: &[u8]) -> Result<(), LogError> {
        self.out
            .write_all(bytes)
            .map_err(|e| io_err(&self.path, e))?;
        self.pos += bytes.len() as u64;
        Ok(())
    }
}

fn io_err(path: &Path, e: std::io::Error) -> LogError {
    LogError::new(path, format!("cannot write the bag: {e}"))
}

/// A ROS time: `u32` seconds, `u32` nanoseconds.
fn ros_time(ns: u64) -> [u8; 8] {
    let mut t = [0; 8];
    t[..4].copy_from_slice(&((ns / 1_000_000_000) as u32).to_le_bytes());
    t[4..].copy_from_slice(&((ns % 1_000_000_000) as u32).to_le_bytes());
    t
}

/// The bag header record, padded with spaces to `BAG_HEADER_LEN` bytes as rosbag does.
fn bag_header(index_pos: u64, conns: u32, chunks: u32) -> Vec<u8> {
    let head: [(&str, &[u8]); 4] = [
        ("op", &[OP_BAG_HEADER]),
        ("index_pos", &index_pos.to_le_bytes()),
        ("conn_count", &conns.to_le_bytes()),
        ("chunk_count", &chunks.to_le_bytes()),
    ];
    let mut fields = Vec::new();
    put_fields(&mut fields, &head);
    let pad = BAG_HEADER_LEN - 8 - fields.len();
    let mut out = Vec::with_capacity(BAG_HEADER_LEN);
    put_record(&mut out, &head, &vec![b' '; pad]);
    out
}

fn put_chunk_info(out: &mut Vec<u8>, info: &ChunkInfo) {
    let mut data = Vec::new();
    for (&id, &n) in &info.counts {
        data.extend(id.to_le_bytes());
        data.extend(n.to_le_bytes());
    }
    let head: [(&str, &[u8]); 6] = [
        ("op", &[OP_CHUNK_INFO]),
        ("ver", &1u32.to_le_bytes()),
        ("chunk_pos", &info.pos.to_le_bytes()),
        ("start_time", &ros_time(info.start_ns)),
        ("end_time", &ros_time(info.end_ns)),
        ("count", &(info.counts.len() as u32).to_le_bytes()),
    ];
    put_record(out, &head, &data);
}
