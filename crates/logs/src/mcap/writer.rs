//! Writes MCAP files as ROS 2 does (profile `ros2`, `ros2msg` schemas, CDR messages), or as
//! `mcap convert` writes a ROS 1 bag's messages (`ros1msg` schemas, ROS 1 serialization): the
//! data section (schemas and channels, then messages in chunks with their message indexes,
//! or loose), then a summary (schemas, channels, statistics, chunk indexes), summary offsets
//! and the footer (MCAP spec, "File Structure"). CRCs are written for readers to check.

use super::records::*;
use crate::compress::{Codec, compress};
use crate::msgdef::{Flavor, schema};
use crate::value::{Schema, Value};
use crate::wire::split_time;
use crate::{LogError, encode, ros_types};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// How the writer stores messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    /// Messages outside chunks (no message index: readers scan the data section).
    Unchunked,
    /// Chunks, uncompressed.
    None,
    Zstd,
    Lz4,
}

/// Chunks are closed once their records reach this size.
const CHUNK_SIZE: usize = 1 << 20;

struct Channel {
    schema: Schema,
    topic: String,
    count: u64,
    /// ROS 1 messages (`ros1msg` schema) or ROS 2 CDR (`ros2msg`).
    flavor: Flavor,
}

/// The open chunk.
#[derive(Default)]
struct Open {
    records: Vec<u8>,
    start_ns: u64,
    end_ns: u64,
    /// Per channel: (log time, offset in `records`).
    index: BTreeMap<u16, Vec<(u64, u64)>>,
}

/// An MCAP file being written. Call [`Writer::finish`] to write its summary; a file not
/// finished is still readable (by scanning).
pub struct Writer {
    path: PathBuf,
    out: BufWriter<File>,
    pos: u64,
    crc: crc32fast::Hasher,
    mode: Compression,
    schemas: Vec<u8>,
    channel_records: Vec<u8>,
    channels: Vec<Channel>,
    open: Open,
    chunk_indexes: Vec<u8>,
    chunk_count: u32,
    span: Option<(u64, u64)>,
    chunk_size: usize,
}

impl Writer {
    /// Creates (or truncates) the file at `path`.
    pub fn create(path: &Path, mode: Compression) -> Result<Writer, LogError> {
        let file = File::create(path).map_err(|e| io_err(path, e))?;
        let mut w = Writer {
            path: path.to_path_buf(),
            out: BufWriter::with_capacity(1 << 20, file),
            pos: 0,
            crc: crc32fast::Hasher::new(),
            mode,
            schemas: Vec::new(),
            channel_records: Vec::new(),
            channels: Vec::new(),
            open: Open::default(),
            chunk_indexes: Vec::new(),
            chunk_count: 0,
            span: None,
            chunk_size: CHUNK_SIZE,
        };
        let mut body = Vec::new();
        put_bytes(&mut body, b"ros2");
        put_bytes(&mut body, b"hydrofit-logs");
        let mut rec = MAGIC.to_vec();
        put(&mut rec, OP_HEADER, &body);
        w.put(&rec)?;
        Ok(w)
    }

    /// Adds a topic with its ROS 2 type (`nav_msgs/msg/Odometry`) and `ros2msg` definition
    /// text; returns its channel id for [`Writer::write`].
    pub fn add_channel(
        &mut self,
        topic: &str,
        type_name: &str,
        definition: &str,
    ) -> Result<u16, LogError> {
        self.channel(topic, type_name, definition, Flavor::Ros2)
    }

    /// Adds a topic of ROS 1 messages, as `mcap convert` writes a bag's: its ROS 1 type
    /// (`nav_msgs/Odometry`) and `ros1msg` definition (the bag's `message_definition`, its
    /// dependencies after `===` lines); returns its channel id for [`Writer::write`].
    pub fn add_ros1_channel(
        &mut self,
        topic: &str,
        type_name: &str,
        definition: &str,
    ) -> Result<u16, LogError> {
        self.channel(topic, type_name, definition, Flavor::Ros1)
    }

    fn channel(
        &mut self,
        topic: &str,
        type_name: &str,
        definition: &str,
        flavor: Flavor,
    ) -> Result<u16, LogError> {
        let schema = schema(definition, type_name, flavor)
            .map_err(|e| LogError::new(&self.path, format!("definition of {type_name}: {e}")))?;
        let id = u16::try_from(self.channels.len() + 1)
            .map_err(|_| LogError::new(&self.path, "more than 65535 channels"))?;
        let (schema_encoding, message_encoding): (&[u8], &[u8]) = match flavor {
            Flavor::Ros1 => (b"ros1msg", b"ros1"),
            Flavor::Ros2 => (b"ros2msg", b"cdr"),
        };
        let mut body = id.to_le_bytes().to_vec();
        put_bytes(&mut body, type_name.as_bytes());
        put_bytes(&mut body, schema_encoding);
        put_bytes(&mut body, definition.as_bytes());
        let mut rec = Vec::new();
        put(&mut rec, OP_SCHEMA, &body);
        // Schema id = channel id: one schema per channel keeps the writer simple.
        let mut body = id.to_le_bytes().to_vec();
        body.extend(id.to_le_bytes());
        put_bytes(&mut body, topic.as_bytes());
        put_bytes(&mut body, message_encoding);
        body.extend(0u32.to_le_bytes()); // metadata: an empty map
        let mut chan = Vec::new();
        put(&mut chan, OP_CHANNEL, &body);
        self.schemas.extend_from_slice(&rec);
        self.channel_records.extend_from_slice(&chan);
        rec.extend(chan);
        self.put(&rec)?;
        self.channels.push(Channel {
            schema,
            topic: topic.to_string(),
            count: 0,
            flavor,
        });
        Ok(id)
    }

    /// [`Writer::add_ros1_channel`] for one of the common types [`ros_types`] defines.
    pub fn add_ros1_topic(&mut self, topic: &str, type_name: &str) -> Result<u16, LogError> {
        let def = ros_types::ros1(type_name).ok_or_else(|| {
            LogError::new(&self.path, format!("no built-in definition of {type_name}"))
        })?;
        self.add_ros1_channel(topic, type_name, &def)
    }

    /// Adds a topic of one of the common types [`ros_types`] defines (`sensor_msgs/Imu`).
    pub fn add_topic(&mut self, topic: &str, type_name: &str) -> Result<u16, LogError> {
        let def = ros_types::ros2(type_name).ok_or_else(|| {
            LogError::new(&self.path, format!("no built-in definition of {type_name}")).fix(
                format!(
                    "give its definition to add_channel; built in: {}",
                    ros_types::COMMON.join(", ")
                ),
            )
        })?;
        self.add_channel(topic, &ros_types::ros2_name(type_name), &def)
    }

    /// The layout a message on channel `id` must have.
    pub fn schema(&self, id: u16) -> Option<&Schema> {
        self.channels
            .get((id as usize).checked_sub(1)?)
            .map(|c| &c.schema)
    }

    /// Writes a message logged at `time_s` (seconds; ROS 2 uses the Unix epoch).
    pub fn write(&mut self, id: u16, time_s: f64, value: &Value) -> Result<(), LogError> {
        let Some(ch) = (id as usize)
            .checked_sub(1)
            .and_then(|i| self.channels.get_mut(i))
        else {
            return Err(LogError::new(&self.path, format!("no channel {id}")));
        };
        let payload = match ch.flavor {
            Flavor::Ros1 => encode::ros1(&ch.schema, value),
            Flavor::Ros2 => encode::cdr(&ch.schema, value),
        }
        .map_err(|e| LogError::new(&self.path, format!("{}: {e}", ch.topic)))?;
        self.write_bytes(id, time_s, &payload)
    }

    /// Writes a message already serialized (CDR with its encapsulation header, or ROS 1's
    /// serialization on a ROS 1 channel) as it is: for
    /// copying messages, and for testing readers with messages that do not match their type.
    pub fn write_bytes(&mut self, id: u16, time_s: f64, payload: &[u8]) -> Result<(), LogError> {
        let Some(ch) = (id as usize)
            .checked_sub(1)
            .and_then(|i| self.channels.get_mut(i))
        else {
            return Err(LogError::new(&self.path, format!("no channel {id}")));
        };
        let ns = split_time(time_s)
            .and_then(|(s, ns)| {
                u64::try_from(s)
                    .ok()?
                    .checked_mul(1_000_000_000)?
                    .checked_add(ns as u64)
            })
            .ok_or_else(|| {
                LogError::new(
                    &self.path,
                    format!("time {time_s} s is out of MCAP's range"),
                )
            })?;
        ch.count += 1;
        let seq = ch.count as u32;
        let mut body = Vec::with_capacity(22 + payload.len());
        body.extend(id.to_le_bytes());
        body.extend(seq.to_le_bytes());
        body.extend(ns.to_le_bytes());
        body.extend(ns.to_le_bytes());
        body.extend(payload);
        self.span = Some(self.span.map_or((ns, ns), |(a, b)| (a.min(ns), b.max(ns))));
        if self.mode == Compression::Unchunked {
            let mut rec = Vec::new();
            put(&mut rec, OP_MESSAGE, &body);
            return self.put(&rec);
        }
        let o = &mut self.open;
        if o.index.is_empty() {
            (o.start_ns, o.end_ns) = (ns, ns);
        }
        (o.start_ns, o.end_ns) = (o.start_ns.min(ns), o.end_ns.max(ns));
        o.index
            .entry(id)
            .or_default()
            .push((ns, o.records.len() as u64));
        put(&mut o.records, OP_MESSAGE, &body);
        if o.records.len() >= self.chunk_size {
            self.flush_chunk()?;
        }
        Ok(())
    }

    /// Closes chunks once they hold `bytes` of records (default about 1 MiB); small chunks
    /// make small test files with many chunks.
    pub fn set_chunk_size(&mut self, bytes: usize) {
        self.chunk_size = bytes.max(1);
    }

    /// Writes the chunk (compressed), then its message index records; keeps its chunk index.
    fn flush_chunk(&mut self) -> Result<(), LogError> {
        if self.open.index.is_empty() {
            return Ok(());
        }
        let o = std::mem::take(&mut self.open);
        let (codec, name) = match self.mode {
            Compression::Zstd => (Codec::Zstd, "zstd"),
            Compression::Lz4 => (Codec::Lz4, "lz4"),
            _ => (Codec::None, ""),
        };
        let packed = compress(codec, &o.records).map_err(|e| io_err(&self.path, e))?;
        let mut body = Vec::with_capacity(packed.len() + 64);
        for x in [o.start_ns, o.end_ns, o.records.len() as u64] {
            body.extend(x.to_le_bytes());
        }
        body.extend(crc32fast::hash(&o.records).to_le_bytes());
        put_bytes(&mut body, name.as_bytes());
        body.extend((packed.len() as u64).to_le_bytes());
        body.extend(&packed);
        let chunk_at = self.pos;
        let mut rec = Vec::with_capacity(body.len() + 9);
        put(&mut rec, OP_CHUNK, &body);
        let chunk_len = rec.len() as u64;
        let mut offsets = Vec::new();
        let index_at = chunk_at + chunk_len;
        for (&ch, list) in &o.index {
            offsets.extend(ch.to_le_bytes());
            offsets.extend((chunk_at + rec.len() as u64).to_le_bytes());
            let mut b = ch.to_le_bytes().to_vec();
            b.extend(((list.len() * 16) as u32).to_le_bytes());
            for &(t, off) in list {
                b.extend(t.to_le_bytes());
                b.extend(off.to_le_bytes());
            }
            put(&mut rec, OP_MESSAGE_INDEX, &b);
        }
        let mut ci = Vec::new();
        for x in [o.start_ns, o.end_ns, chunk_at, chunk_len] {
            ci.extend(x.to_le_bytes());
        }
        put_bytes(&mut ci, &offsets);
        ci.extend((chunk_at + rec.len() as u64 - index_at).to_le_bytes());
        put_bytes(&mut ci, name.as_bytes());
        ci.extend((packed.len() as u64).to_le_bytes());
        ci.extend((o.records.len() as u64).to_le_bytes());
        put(&mut self.chunk_indexes, OP_CHUNK_INDEX, &ci);
        self.chunk_count += 1;
        self.put(&rec)
    }

    /// Closes the last chunk and writes the data end, summary, summary offsets and footer.
    pub fn finish(mut self) -> Result<(), LogError> {
        self.flush_chunk()?;
        let mut end = Vec::new();
        put(
            &mut end,
            OP_DATA_END,
            &self.crc.clone().finalize().to_le_bytes(),
        );
        self.put(&end)?;
        let summary_at = self.pos;
        let mut summary = Vec::new();
        let mut groups = Vec::new();
        let stats = self.statistics();
        for (op, bytes) in [
            (OP_SCHEMA, &self.schemas),
            (OP_CHANNEL, &self.channel_records),
            (OP_STATISTICS, &stats),
            (OP_CHUNK_INDEX, &self.chunk_indexes),
        ] {
            if !bytes.is_empty() {
                groups.push((op, summary_at + summary.len() as u64, bytes.len() as u64));
                summary.extend_from_slice(bytes);
            }
        }
        let offsets_at = summary_at + summary.len() as u64;
        for (op, at, len) in groups {
            let mut b = vec![op];
            b.extend(at.to_le_bytes());
            b.extend(len.to_le_bytes());
            put(&mut summary, OP_SUMMARY_OFFSET, &b);
        }
        // The footer's CRC covers the summary up to and including summary_offset_start.
        summary.push(OP_FOOTER);
        summary.extend(20u64.to_le_bytes());
        summary.extend(summary_at.to_le_bytes());
        summary.extend(offsets_at.to_le_bytes());
        summary.extend(crc32fast::hash(&summary).to_le_bytes());
        summary.extend(MAGIC);
        self.put(&summary)?;
        let path = self.path.clone();
        let file = self
            .out
            .into_inner()
            .map_err(|e| io_err(&path, e.into_error()))?;
        file.sync_all().map_err(|e| io_err(&path, e))
    }

    /// The statistics record.
    fn statistics(&self) -> Vec<u8> {
        let total: u64 = self.channels.iter().map(|c| c.count).sum();
        let mut b = total.to_le_bytes().to_vec();
        b.extend((self.channels.len() as u16).to_le_bytes());
        b.extend((self.channels.len() as u32).to_le_bytes());
        b.extend(0u32.to_le_bytes()); // attachments
        b.extend(0u32.to_le_bytes()); // metadata
        b.extend(self.chunk_count.to_le_bytes());
        let (start, end) = self.span.unwrap_or((0, 0));
        b.extend(start.to_le_bytes());
        b.extend(end.to_le_bytes());
        let mut counts = Vec::new();
        for (i, c) in self.channels.iter().enumerate() {
            counts.extend((i as u16 + 1).to_le_bytes());
            counts.extend(c.count.to_le_bytes());
        }
        put_bytes(&mut b, &counts);
        let mut rec = Vec::new();
        put(&mut rec, OP_STATISTICS, &b);
        rec
    }

    fn put(&mut self, bytes: &[u8]) -> Result<(), LogError> {
        self.out
            .write_all(bytes)
            .map_err(|e| io_err(&self.path, e))?;
        self.crc.update(bytes);
        self.pos += bytes.len() as u64;
        Ok(())
    }
}

fn io_err(path: &Path, e: std::io::Error) -> LogError {
    LogError::new(path, format!("cannot write the MCAP file: {e}"))
}
