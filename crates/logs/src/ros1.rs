//! ROS 1 bags, format 2.0 (ROS wiki Bags/Format/2.0): the reader, and [`Writer`] for bags
//! `rosbag` reads. Chunks may be uncompressed, bz2 or lz4; message definitions come from the
//! bag's connection records, so no ROS installation is needed.

mod index;
mod record;
mod writer;

pub use writer::{Compression, Writer};

use crate::compress::Codec;
use crate::merge::{self, Slot};
use crate::msgdef::{self, Flavor};
use crate::value::Schema;
use crate::wire::{self, Wire};
use crate::{LogError, Message, Topic};
use record::{OP_MSG_DATA, RecordError, get_time, get_u32, record_at};
use std::borrow::Cow;
use std::collections::HashMap;
use std::ops::Range;
use std::path::Path;

/// An open bag: its bytes and where its messages are.
#[derive(Debug)]
pub struct Bag {
    data: Vec<u8>,
    chunks: Vec<Chunk>,
    /// Per connection (as `Slot::conn` counts them): its id in the file and its topic.
    conns: Vec<(u32, usize)>,
    /// Every message, in time order.
    slots: Vec<Slot>,
    /// How many topics `open` listed: `read` must be given those.
    n_topics: usize,
    /// What was stepped over to read it (a missing index, a torn last chunk).
    notes: Vec<String>,
}

/// A chunk record.
#[derive(Debug, Clone)]
pub(crate) struct Chunk {
    /// Offset of the chunk record in the file.
    pos: usize,
    /// Where its (compressed) data is in the file.
    data: Range<usize>,
    codec: Codec,
    /// Size inflated, as its header says.
    size: u64,
    /// Cut short at the end of the file: read as far as it goes.
    torn: bool,
}

/// A connection record's fields.
#[derive(Debug, Clone, Default)]
pub(crate) struct RawConn {
    id: u32,
    /// Offset of the record, for errors.
    pos: usize,
    topic: String,
    type_name: String,
    md5: String,
    definition: String,
}

/// What the index (or a scan) says the bag holds; `Slot::conn` indexes `conns`.
#[derive(Debug, Default)]
pub(crate) struct Found {
    chunks: Vec<Chunk>,
    conns: Vec<RawConn>,
    slots: Vec<Slot>,
}

impl Bag {
    /// Reads the bag header and the index (or scans the chunks when there is none) and lists
    /// the topics, with counts and time spans from the index.
    pub fn open(path: &Path, data: Vec<u8>) -> Result<(Bag, Vec<Topic>), LogError> {
        if !data.starts_with(b"#ROSBAG V2.0\n") {
            return Err(LogError::new(path, "not a ROS 1 bag (no `#ROSBAG V2.0` line)").at(0));
        }
        let (head, start) = index::bag_header(&data).map_err(|e| {
            LogError::new(path, e)
                .at(index::MAGIC_LEN as u64)
                .fix("the file is not a complete ROS 1 bag; record it again")
        })?;
        let mut notes = Vec::new();
        let mut found = match index::read_index(&data, &head) {
            Ok(found) => found,
            Err(_) => {
                notes.push(unindexed(&data, head.index_pos));
                index::scan(path, &data, start, head.index_pos)?
            }
        };
        if let Some(c) = found.chunks.iter().find(|c| c.torn) {
            notes.push(format!(
                "the chunk at byte {} is cut short by the end of the file: its messages up to the cut are read, any after it are lost",
                c.pos
            ));
        }
        let chunk_pos = |c: u32| found.chunks[c as usize].pos as u64;
        if let Some(back) = merge::step_back(&found.slots, chunk_pos) {
            notes.push(back.note(&found.conns[back.conn as usize].topic));
        }
        found.slots.sort_unstable_by_key(Slot::key);
        let (topics, conns) = topics_of(path, &found)?;
        let bag = Bag {
            data,
            chunks: found.chunks,
            conns,
            slots: found.slots,
            n_topics: topics.len(),
            notes,
        };
        Ok((bag, topics))
    }

    /// What was stepped over to read the bag, one sentence each.
    pub fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    /// Decodes the messages of the topics `wanted`, in time order, and calls `each` with them.
    pub fn read(
        &self,
        path: &Path,
        topics: &[Topic],
        wanted: &[usize],
        each: &mut dyn FnMut(&Message) -> Result<(), LogError>,
    ) -> Result<(), LogError> {
        let sizes = (self.n_topics, topics.len());
        let slots = merge::wanted(path, &self.slots, sizes, wanted, |s| {
            self.conns[s.conn as usize].1
        })?;
        let load = |c: u32| self.load(path, c);
        merge::run(&slots, &load, &mut |slot, bytes| {
            let msg = self.message(path, topics, slot, bytes)?;
            each(&msg)
        })
    }

    /// Inflates chunk `c` (a torn chunk as far as it goes).
    fn load(&self, path: &Path, c: u32) -> Result<Cow<'_, [u8]>, LogError> {
        let chunk = &self.chunks[c as usize];
        let raw = &self.data[chunk.data.clone()];
        if chunk.codec == Codec::None && raw.len() as u64 == chunk.size {
            return Ok(Cow::Borrowed(raw));
        }
        let (bytes, why) = crate::compress::decompress(chunk.codec, raw, chunk.size);
        match why {
            Some(why) if !chunk.torn => Err(LogError::new(path, format!("chunk: {why}"))
                .at(chunk.pos as u64)
                .fix("the bag is damaged in this chunk: copy it again from the vehicle, try `rosbag fix`, or cut the run before it (span_s)")),
            _ => Ok(Cow::Owned(bytes)),
        }
    }

    /// Decodes the message record at `slot` in its inflated chunk `bytes`.
    fn message(
        &self,
        path: &Path,
        topics: &[Topic],
        slot: &Slot,
        bytes: &[u8],
    ) -> Result<Message, LogError> {
        let chunk = &self.chunks[slot.chunk as usize];
        let (id, t) = self.conns[slot.conn as usize];
        let topic = &topics[t];
        let at = if chunk.codec == Codec::None {
            chunk.data.start as u64 + slot.offset
        } else {
            chunk.pos as u64
        };
        let inside = if chunk.codec == Codec::None {
            String::new()
        } else {
            format!(" (byte {} of the inflated chunk)", slot.offset)
        };
        let fail = |what: String| {
            LogError::new(
                path,
                format!("topic {} ({}): {what}{inside}", topic.name, topic.type_name),
            )
            .at(at)
        };
        let r = record_at(bytes, slot.offset as usize).map_err(|e| match e {
            RecordError::Short => fail("the index points past the chunk's end".into()),
            RecordError::Bad(e) => fail(format!("the index points at no record ({e})")),
        })?;
        let time_ns = get_time(r.head.time, "time").map_err(&fail)?;
        if r.head.op != Some(OP_MSG_DATA) || get_u32(r.head.conn, "conn") != Ok(id) {
            return Err(fail(
                "the index points at another record than its message".into(),
            ));
        }
        let time_s = wire::ns_to_s(time_ns);
        let value = wire::decode(&topic.schema, r.data, Wire::Ros1).map_err(|e| {
            fail(format!(
                "the message at t = {time_s:.6} s does not match its definition: {e}"
            ))
            .fix("the bag was recorded with another version of this message type, or is damaged")
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
type Conns = Vec<(u32, usize)>;

/// The topics (one per topic name and message type), sorted by name, with their message
/// counts and time spans; and per connection, its id and topic.
fn topics_of(path: &Path, found: &Found) -> Result<(Vec<Topic>, Conns), LogError> {
    let mut order: Vec<usize> = (0..found.conns.len()).collect();
    order.sort_by(|&a, &b| found.conns[a].topic.cmp(&found.conns[b].topic));
    let mut topics: Vec<Topic> = Vec::new();
    let mut keys: HashMap<(&str, &str, &str), usize> = HashMap::new();
    let mut conns = vec![(0, 0); found.conns.len()];
    for i in order {
        let c = &found.conns[i];
        let key = (c.topic.as_str(), c.type_name.as_str(), c.md5.as_str());
        let t = match keys.get(&key) {
            Some(&t) => t,
            None => {
                topics.push(new_topic(path, c)?);
                keys.insert(key, topics.len() - 1);
                topics.len() - 1
            }
        };
        conns[i] = (c.id, t);
    }
    for s in &found.slots {
        let topic = &mut topics[conns[s.conn as usize].1];
        let t = wire::ns_to_s(s.time_ns);
        if topic.count == 0 {
            (topic.first_s, topic.last_s) = (t, t);
        }
        topic.count += 1;
        topic.first_s = topic.first_s.min(t);
        topic.last_s = topic.last_s.max(t);
    }
    Ok((topics, conns))
}

fn new_topic(path: &Path, c: &RawConn) -> Result<Topic, LogError> {
    let schema: Schema =
        msgdef::schema(&c.definition, &c.type_name, Flavor::Ros1).map_err(|e| {
            LogError::new(
                path,
                format!(
                    "topic {} ({}): its message definition cannot be read: {e}",
                    c.topic, c.type_name
                ),
            )
            .at(c.pos as u64)
            .fix("the bag's connection record is damaged or was written by a non-standard tool")
        })?;
    Ok(Topic {
        name: c.topic.clone(),
        type_name: c.type_name.clone(),
        count: 0,
        first_s: 0.0,
        last_s: 0.0,
        schema,
    })
}

/// Why a bag was read by scanning: its index is missing (a recording that was not closed) or
/// lies beyond the end of the file (a file cut short).
fn unindexed(data: &[u8], index_pos: u64) -> String {
    if index_pos == 0 {
        "the bag has no index (its recording was not closed): read by scanning its chunks".into()
    } else if index_pos >= data.len() as u64 {
        format!(
            "the bag ends at byte {} though its index should start at byte {index_pos}: the file was cut short; read by scanning its chunks",
            data.len()
        )
    } else {
        format!("the bag's index at byte {index_pos} is damaged: read by scanning its chunks")
    }
}
