//! MCAP files as ROS 2 writes them (MCAP spec, <https://mcap.dev/spec>): `ros2msg` schemas and
//! CDR messages, chunked or not, chunks uncompressed, zstd or lz4; and ROS 1 bags converted
//! to MCAP (`mcap convert`: `ros1msg` schemas, ROS 1 messages). The reader, and [`Writer`].
//! Other schema encodings (`ros2idl`, `protobuf`, `jsonschema`, ...) are reported, not read.

mod index;
mod records;
mod writer;

pub use writer::{Compression, Writer};

use crate::compress::{Codec, decompress};
use crate::merge::{self, Slot};
use crate::msgdef::{self, Flavor};
use crate::wire;
use crate::{LogError, Message, Topic};
use records::{ChannelRec, OP_MESSAGE, SchemaRec, rec_at};
use std::borrow::Cow;
use std::collections::HashMap;
use std::ops::Range;
use std::path::Path;

/// An open MCAP file: its bytes and where its messages are.
#[derive(Debug)]
pub struct File {
    data: Vec<u8>,
    chunks: Vec<Chunk>,
    /// Per channel (as `Slot::conn` counts them): its id and its topic.
    channels: Vec<(u16, usize)>,
    /// Per topic: whose messages it carries (ROS 1's serialization or ROS 2's CDR).
    flavors: Vec<Flavor>,
    /// Every message, in time order.
    slots: Vec<Slot>,
    /// How many topics `open` listed: `read` must be given those.
    n_topics: usize,
    /// What was stepped over to read it (a missing summary).
    notes: Vec<String>,
}

/// A chunk record (or, for messages outside chunks, the whole file).
#[derive(Debug, Clone)]
pub(crate) struct Chunk {
    pos: usize,
    /// Where its (compressed) records are in the file.
    records: Range<usize>,
    codec: Codec,
    size: u64,
    /// CRC-32 of the inflated records; 0 when the writer did not compute it.
    crc: u32,
    torn: bool,
}

/// What the summary (or a scan) says the file holds; `Slot::conn` indexes `channels`.
#[derive(Debug, Default)]
pub(crate) struct Found {
    chunks: Vec<Chunk>,
    schemas: Vec<SchemaRec>,
    channels: Vec<ChannelRec>,
    ids: index::Ids,
    slots: Vec<Slot>,
    /// The chunk standing for the whole file, once a message outside chunks is seen.
    file_chunk: Option<u32>,
}

impl File {
    /// Reads the summary (or scans the data section when there is none) and lists the topics.
    pub fn open(path: &Path, data: Vec<u8>) -> Result<(File, Vec<Topic>), LogError> {
        if !data.starts_with(records::MAGIC) {
            return Err(LogError::new(path, "not an MCAP file (no MCAP magic)").at(0));
        }
        let mut notes = Vec::new();
        let mut found = match index::read_summary(&data) {
            Ok(found) => found,
            Err(_) => {
                notes.push(
                    "the file's summary (its index) is missing or damaged, as when a recording is not closed or the file is cut short: read by scanning its records".to_string(),
                );
                index::scan(path, &data)?
            }
        };
        let chunk_pos = |c: u32| found.chunks[c as usize].pos as u64;
        if let Some(back) = merge::step_back(&found.slots, chunk_pos) {
            notes.push(back.note(&found.channels[back.conn as usize].topic));
        }
        found.slots.sort_unstable_by_key(Slot::key);
        let (topics, channels, flavors) = topics_of(path, &found)?;
        let file = File {
            data,
            chunks: found.chunks,
            channels,
            flavors,
            slots: found.slots,
            n_topics: topics.len(),
            notes,
        };
        Ok((file, topics))
    }

    /// What was stepped over to read the file, one sentence each.
    pub fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    /// Decodes the messages of the topics `wanted`, in log-time order, and calls `each`.
    pub fn read(
        &self,
        path: &Path,
        topics: &[Topic],
        wanted: &[usize],
        each: &mut dyn FnMut(&Message) -> Result<(), LogError>,
    ) -> Result<(), LogError> {
        let sizes = (self.n_topics, topics.len());
        let slots = merge::wanted(path, &self.slots, sizes, wanted, |s| {
            self.channels[s.conn as usize].1
        })?;
        let load = |c: u32| self.load(path, c);
        merge::run(&slots, &load, &mut |slot, bytes| {
            let msg = self.message(path, topics, slot, bytes)?;
            each(&msg)
        })
    }

    fn load(&self, path: &Path, c: u32) -> Result<Cow<'_, [u8]>, LogError> {
        let chunk = &self.chunks[c as usize];
        let raw = &self.data[chunk.records.clone()];
        let fail = |what: String| {
            LogError::new(path, format!("chunk: {what}"))
                .at(chunk.pos as u64)
                .fix("the file is damaged in this chunk: copy it again from the vehicle, or cut the run before it (span_s)")
        };
        let bytes = if chunk.codec == Codec::None && raw.len() as u64 == chunk.size {
            Cow::Borrowed(raw)
        } else {
            let (bytes, why) = decompress(chunk.codec, raw, chunk.size);
            match why {
                Some(why) if !chunk.torn => return Err(fail(why)),
                _ => Cow::Owned(bytes),
            }
        };
        // The CRC of the inflated records (MCAP spec, "Chunk": 0 means not computed).
        if chunk.crc != 0 && !chunk.torn && crc32fast::hash(&bytes) != chunk.crc {
            return Err(fail(
                "its CRC does not match: the records are damaged".into(),
            ));
        }
        Ok(bytes)
    }

    fn message(
        &self,
        path: &Path,
        topics: &[Topic],
        slot: &Slot,
        bytes: &[u8],
    ) -> Result<Message, LogError> {
        let chunk = &self.chunks[slot.chunk as usize];
        let (id, t) = self.channels[slot.conn as usize];
        let topic = &topics[t];
        let (at, inside) = if chunk.codec == Codec::None {
            (chunk.records.start as u64 + slot.offset, String::new())
        } else {
            (
                chunk.pos as u64,
                format!(" (byte {} of the inflated chunk)", slot.offset),
            )
        };
        let fail = |what: String| {
            LogError::new(
                path,
                format!("topic {} ({}): {what}{inside}", topic.name, topic.type_name),
            )
            .at(at)
        };
        let r = rec_at(bytes, slot.offset as usize)
            .map_err(|_| fail("the index points past the chunk's end".into()))?;
        let (ch, time_ns, payload) = records::message(r.body).map_err(&fail)?;
        if r.op != OP_MESSAGE || ch != id {
            return Err(fail(
                "the index points at another record than its message".into(),
            ));
        }
        let time_s = wire::ns_to_s(time_ns);
        let decoded = match self.flavors[t] {
            Flavor::Ros1 => wire::decode(&topic.schema, payload, wire::Wire::Ros1),
            Flavor::Ros2 => wire::decode_cdr(&topic.schema, payload),
        };
        let value = decoded.map_err(|e| {
            fail(format!(
                "the message at t = {time_s:.6} s does not match its schema: {e}"
            ))
            .fix("the file was written with another version of this message type, or is damaged")
        })?;
        Ok(Message {
            topic: t,
            log_time_s: time_s,
            stamp_s: wire::header_stamp(&topic.schema, &value),
            value,
        })
    }
}

/// Per connection (channel): its id in the file and the index of its topic.
type Conns = Vec<(u16, usize)>;

/// The topics (one per topic name and schema), sorted by name, with counts and time spans,
/// and each topic's flavour.
fn topics_of(path: &Path, found: &Found) -> Result<(Vec<Topic>, Conns, Vec<Flavor>), LogError> {
    let mut order: Vec<usize> = (0..found.channels.len()).collect();
    order.sort_by(|&a, &b| found.channels[a].topic.cmp(&found.channels[b].topic));
    let mut topics: Vec<Topic> = Vec::new();
    let mut flavors: Vec<Flavor> = Vec::new();
    let mut keys: HashMap<(&str, u16), usize> = HashMap::new();
    let mut channels = vec![(0, 0); found.channels.len()];
    for i in order {
        let c = &found.channels[i];
        let t = match keys.get(&(c.topic.as_str(), c.schema_id)) {
            Some(&t) => t,
            None => {
                let (topic, flavor) = new_topic(path, c, &found.schemas)?;
                topics.push(topic);
                flavors.push(flavor);
                keys.insert((c.topic.as_str(), c.schema_id), topics.len() - 1);
                topics.len() - 1
            }
        };
        channels[i] = (c.id, t);
    }
    for s in &found.slots {
        let topic = &mut topics[channels[s.conn as usize].1];
        let t = wire::ns_to_s(s.time_ns);
        if topic.count == 0 {
            (topic.first_s, topic.last_s) = (t, t);
        }
        topic.count += 1;
        topic.first_s = topic.first_s.min(t);
        topic.last_s = topic.last_s.max(t);
    }
    Ok((topics, channels, flavors))
}

fn new_topic(
    path: &Path,
    c: &ChannelRec,
    schemas: &[SchemaRec],
) -> Result<(Topic, Flavor), LogError> {
    let fail = |what: String, fix: &str| {
        LogError::new(path, format!("topic {}: {what}", c.topic))
            .at(c.at as u64)
            .fix(fix)
    };
    let Some(s) = schemas.iter().find(|s| s.id == c.schema_id) else {
        return Err(fail(
            format!("its channel has no schema (schema id {})", c.schema_id),
            "hydrofit reads ROS MCAP files, whose channels have ros2msg or ros1msg schemas",
        ));
    };
    let flavor = match s.encoding.as_str() {
        "ros2msg" => Flavor::Ros2,
        "ros1msg" => Flavor::Ros1,
        other => {
            return Err(fail(
                format!(
                    "its schema {} is encoded as `{other}`, which is not read: only ROS \
                     `ros2msg` and `ros1msg` schemas are (not ros2idl, protobuf, flatbuffer, \
                     jsonschema)",
                    s.name
                ),
                "record the topic with a message type defined in a .msg file, or export the \
                 topics needed to CSV",
            ));
        }
    };
    let wanted = match flavor {
        Flavor::Ros2 => "cdr",
        Flavor::Ros1 => "ros1",
    };
    if c.encoding != wanted {
        return Err(fail(
            format!(
                "its messages are encoded as `{}`, not `{wanted}` as its `{}` schema says",
                c.encoding, s.encoding
            ),
            "hydrofit reads ROS 2 (CDR) messages and ROS 1 messages converted to MCAP",
        ));
    }
    let text = String::from_utf8_lossy(&s.data);
    let schema = msgdef::schema(&text, &s.name, flavor).map_err(|e| {
        fail(
            format!("its schema {} cannot be read: {e}", s.name),
            "the schema record is damaged or was written by a non-standard tool",
        )
    })?;
    let topic = Topic {
        name: c.topic.clone(),
        type_name: s.name.clone(),
        count: 0,
        first_s: 0.0,
        last_s: 0.0,
        schema,
    };
    Ok((topic, flavor))
}
