//! Finding a bag's connections, chunks and messages: from its index when the bag was closed,
//! else by scanning its chunks one after another (ROS wiki Bags/Format/2.0: the bag header's
//! `index_pos` points at the connection and chunk info records written on closing; each chunk
//! is followed by one index data record per connection in it).

use super::record::*;
use super::{Chunk, Found, RawConn};
use crate::LogError;
use crate::compress::{Codec, decompress};
use crate::merge::Slot;
use std::collections::HashMap;
use std::path::Path;

/// The bag header record's fields.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BagHead {
    pub index_pos: u64,
    pub conn_count: u32,
    pub chunk_count: u32,
}

/// `#ROSBAG V2.0\n`, before the bag header record.
pub(crate) const MAGIC_LEN: usize = 13;

/// Reads the bag header record; returns it and where the records after it start.
pub(crate) fn bag_header(data: &[u8]) -> Result<(BagHead, usize), String> {
    let r = record_at(data, MAGIC_LEN).map_err(|e| match e {
        RecordError::Short => "the file ends inside the bag header record".to_string(),
        RecordError::Bad(e) => format!("the bag header record is damaged: {e}"),
    })?;
    if r.head.op != Some(OP_BAG_HEADER) {
        return Err(format!(
            "the first record is not a bag header (op {:?})",
            r.head.op
        ));
    }
    let head = BagHead {
        index_pos: get_u64(r.head.index_pos, "index_pos")?,
        conn_count: get_u32(r.head.conn_count, "conn_count")?,
        chunk_count: get_u32(r.head.chunk_count, "chunk_count")?,
    };
    Ok((head, r.end))
}

/// Reads the index the bag was closed with. Any inconsistency is an `Err`: the caller then
/// scans the chunks instead.
pub(crate) fn read_index(data: &[u8], head: &BagHead) -> Result<Found, String> {
    let mut pos = usize::try_from(head.index_pos).map_err(|e| e.to_string())?;
    if pos == 0 {
        return Err("the bag was not closed (no index)".into());
    }
    let mut found = Found::default();
    let mut infos = Vec::new();
    while pos < data.len() {
        let r = record_at(data, pos).map_err(|e| format!("index record at {pos}: {e:?}"))?;
        match r.head.op {
            Some(OP_CONNECTION) => found.conns.push(connection(&r, pos)?),
            Some(OP_CHUNK_INFO) => infos.push(chunk_info(&r)?),
            op => return Err(format!("record op {op:?} in the index at {pos}")),
        }
        pos = r.end;
    }
    if found.conns.len() != head.conn_count as usize || infos.len() != head.chunk_count as usize {
        return Err("the index has other counts than the bag header".into());
    }
    let ids = conn_ids(&found.conns)?;
    infos.sort_by_key(|i| i.0);
    if infos.windows(2).any(|w| w[0].0 == w[1].0) {
        return Err("two chunk info records for one chunk".into());
    }
    for (chunk_pos, messages) in infos {
        let at = usize::try_from(chunk_pos).map_err(|e| e.to_string())?;
        let r = record_at(data, at).map_err(|e| format!("chunk at {at}: {e:?}"))?;
        let chunk = chunk_of(&r, at)?;
        let idx = found.chunks.len() as u32;
        let before = found.slots.len();
        index_data(data, r.end, &chunk, idx, &ids, &mut found.slots)?;
        if (found.slots.len() - before) as u64 != messages {
            return Err(format!("chunk at {at}: index data and chunk info disagree"));
        }
        found.chunks.push(chunk);
    }
    Ok(found)
}

/// Connection id -> index in `conns`; a repeated id is damage.
fn conn_ids(conns: &[RawConn]) -> Result<HashMap<u32, u32>, String> {
    let mut ids = HashMap::new();
    for (i, c) in conns.iter().enumerate() {
        if ids.insert(c.id, i as u32).is_some() {
            return Err(format!("connection {} is defined twice", c.id));
        }
    }
    Ok(ids)
}

/// A chunk info record: (chunk_pos, number of messages in the chunk).
fn chunk_info(r: &Record) -> Result<(u64, u64), String> {
    if get_u32(r.head.ver, "ver")? != 1 {
        return Err("chunk info version is not 1".into());
    }
    let pos = get_u64(r.head.chunk_pos, "chunk_pos")?;
    let n = get_u32(r.head.count, "count")? as usize;
    if r.data.len() != n.saturating_mul(8) {
        return Err("chunk info length does not match its count".into());
    }
    // Data: `count` pairs of (conn: u32, count: u32).
    let total = r
        .data
        .chunks_exact(8)
        .map(|p| u32::from_le_bytes([p[4], p[5], p[6], p[7]]) as u64);
    Ok((pos, total.sum()))
}

/// The index data records after the chunk ending at `pos`: one per connection, each a list of
/// (time: u32 sec + u32 nsec, offset: u32) entries.
fn index_data(
    data: &[u8],
    mut pos: usize,
    chunk: &Chunk,
    idx: u32,
    ids: &HashMap<u32, u32>,
    slots: &mut Vec<Slot>,
) -> Result<(), String> {
    while let Ok(r) = record_at(data, pos) {
        if r.head.op != Some(OP_INDEX_DATA) {
            break;
        }
        if get_u32(r.head.ver, "ver")? != 1 {
            return Err(format!("index data at {pos}: version is not 1"));
        }
        let id = get_u32(r.head.conn, "conn")?;
        let conn = *ids
            .get(&id)
            .ok_or(format!("index data for unknown connection {id}"))?;
        let n = get_u32(r.head.count, "count")? as usize;
        if r.data.len() != n.saturating_mul(12) {
            return Err(format!(
                "index data at {pos}: length does not match its count"
            ));
        }
        for e in r.data.chunks_exact(12) {
            let offset = u32::from_le_bytes([e[8], e[9], e[10], e[11]]) as u64;
            if offset >= chunk.size {
                return Err(format!("index data at {pos}: offset past the chunk's end"));
            }
            let time = e[..8].try_into().expect("chunks_exact(12)");
            slots.push(Slot {
                time_ns: time_ns(&time),
                offset,
                chunk: idx,
                conn,
            });
        }
        pos = r.end;
    }
    Ok(())
}

/// A chunk record's compression, sizes and where its data is.
pub(crate) fn chunk_of(r: &Record, at: usize) -> Result<Chunk, String> {
    if r.head.op != Some(OP_CHUNK) {
        return Err(format!(
            "the record at {at} is not a chunk (op {:?})",
            r.head.op
        ));
    }
    let codec = match r.head.compression.ok_or("a chunk without `compression`")? {
        b"none" => Codec::None,
        b"bz2" => Codec::Bz2,
        b"lz4" => Codec::Lz4,
        other => {
            let name = String::from_utf8_lossy(other);
            return Err(format!(
                "chunk compression `{name}`, which ROS 1 does not have"
            ));
        }
    };
    Ok(Chunk {
        pos: at,
        data: r.data_at..r.end,
        codec,
        size: get_u32(r.head.size, "size")? as u64,
        torn: false,
    })
}

/// A connection record: `conn` and `topic` in its header, the connection header (`topic`,
/// `type`, `md5sum`, `message_definition`) as its data.
pub(crate) fn connection(r: &Record, pos: usize) -> Result<RawConn, String> {
    let mut c = RawConn {
        id: get_u32(r.head.conn, "conn")?,
        pos,
        ..RawConn::default()
    };
    let text = |v: &[u8]| String::from_utf8_lossy(v).into_owned();
    for f in fields(r.data) {
        let (name, value) = f.map_err(|e| format!("connection {}: {e}", c.id))?;
        match name {
            b"topic" => c.topic = text(value),
            b"type" => c.type_name = text(value),
            b"md5sum" => c.md5 = text(value),
            b"message_definition" => c.definition = text(value),
            _ => {}
        }
    }
    // The record header's topic is the one recorded (`rosbag info` shows it); the connection
    // header's is the publisher's, which a remapping or `rosbag filter` may have changed.
    if let Some(topic) = r.head.topic.filter(|t| !t.is_empty()) {
        c.topic = text(topic);
    }
    if c.type_name.is_empty() {
        return Err(format!("connection {} has no message type", c.id));
    }
    Ok(c)
}

/// A record reaching further than this past the end of the file has a damaged length rather
/// than being cut short: no ROS writer makes records near this size.
pub(crate) const MAX_OVERSHOOT: usize = 64 << 20;

/// Scans the records from `pos` on, inflating every chunk: for bags without a usable index.
/// Damage at the very end (a record cut short, the torn last chunk of a bag whose recording
/// stopped) ends the scan with what was readable; damage before more chunks is an error. A
/// bag whose index is still in the file (`index_pos`) was not cut before it.
pub(crate) fn scan(
    path: &Path,
    data: &[u8],
    mut pos: usize,
    index_pos: u64,
) -> Result<Found, LogError> {
    // Trusted only where an index record is found.
    let intact_until = usize::try_from(index_pos)
        .ok()
        .filter(|&i| i > 0)
        .and_then(|i| record_at(data, i).ok().map(|r| (i, r.head.op)))
        .and_then(|(i, op)| matches!(op, Some(OP_CONNECTION | OP_CHUNK_INFO)).then_some(i))
        .unwrap_or(0);
    let mut s = Scan::default();
    while pos < data.len() {
        let r = match record_at(data, pos) {
            Ok(r) => r,
            Err(RecordError::Short) => {
                let end = head_at(data, pos).map(|r| r.end).ok();
                if pos < intact_until || end.is_some_and(|e| e - data.len() > MAX_OVERSHOOT) {
                    let what = "a record runs past the end of the file: its length is damaged";
                    return Err(damage(path, pos, what.into()));
                }
                s.torn_end(path, data, pos)?;
                break;
            }
            // After a chunk left open, the rest is that chunk's compressed stream.
            Err(RecordError::Bad(_)) if s.open_chunk => break,
            Err(RecordError::Bad(e)) => return Err(damage(path, pos, e)),
        };
        // In a closed bag the chunks end where the index starts.
        if pos < intact_until && r.end > intact_until {
            let what = "a record runs into the index: its length is damaged";
            return Err(damage(path, pos, what.into()));
        }
        s.record(path, data, &r, pos)?;
        if s.stop {
            break;
        }
        pos = r.end;
    }
    // A closed bag has no torn last chunk: damage in it is damage.
    match s.pending {
        Some(e) if intact_until > 0 => Err(e),
        _ => Ok(s.found),
    }
}

fn damage(path: &Path, at: usize, what: String) -> LogError {
    LogError::new(path, format!("damaged record: {what}"))
        .at(at as u64)
        .fix("the bag is damaged here; try `rosbag reindex` or `rosbag fix`, or record it again")
}

#[derive(Default)]
struct Scan {
    found: Found,
    ids: HashMap<u32, u32>,
    /// Damage in the last chunk seen: an error only if more chunks follow.
    pending: Option<LogError>,
    /// A chunk header with zero sizes was seen: `rosbag record` writes the sizes when it
    /// closes a chunk, so the bag stopped while writing it.
    open_chunk: bool,
    /// The open chunk is compressed: the rest of the file is its stream, read as a torn chunk.
    stop: bool,
}

impl Scan {
    fn record(&mut self, path: &Path, data: &[u8], r: &Record, pos: usize) -> Result<(), LogError> {
        match r.head.op {
            Some(OP_CHUNK) | Some(OP_MSG_DATA) => {
                if let Some(e) = self.pending.take() {
                    return Err(e);
                }
                if r.head.op == Some(OP_MSG_DATA) {
                    // A message outside any chunk: kept as a chunk of its own.
                    let chunk = Chunk {
                        pos,
                        data: pos..r.end,
                        codec: Codec::None,
                        size: (r.end - pos) as u64,
                        torn: false,
                    };
                    return self.chunk(path, chunk, data[pos..r.end].to_vec(), None);
                }
                let mut chunk = chunk_of(r, pos).map_err(|e| damage(path, pos, e))?;
                if chunk.size == 0 && r.data.is_empty() && chunk.codec != Codec::None {
                    self.open_chunk = true;
                    self.stop = true;
                    chunk.data = r.data_at..data.len();
                    chunk.size = u32::MAX as u64;
                    chunk.torn = true;
                } else if chunk.size == 0 && r.data.is_empty() {
                    self.open_chunk = true;
                    return Ok(());
                }
                let (bytes, why) = decompress(chunk.codec, &data[chunk.data.clone()], chunk.size);
                self.chunk(path, chunk, bytes, why)
            }
            Some(OP_CONNECTION) => {
                let c = connection(r, pos).map_err(|e| damage(path, pos, e))?;
                self.conn(c);
                Ok(())
            }
            Some(OP_INDEX_DATA) | Some(OP_CHUNK_INFO) => Ok(()),
            op => Err(damage(path, pos, format!("unexpected record (op {op:?})"))),
        }
    }

    fn conn(&mut self, c: RawConn) {
        if !self.ids.contains_key(&c.id) {
            self.ids.insert(c.id, self.found.conns.len() as u32);
            self.found.conns.push(c);
        }
    }

    /// Takes the records of an inflated chunk. Damage inside it is kept pending.
    fn chunk(
        &mut self,
        path: &Path,
        mut chunk: Chunk,
        bytes: Vec<u8>,
        why: Option<String>,
    ) -> Result<(), LogError> {
        let idx = self.found.chunks.len() as u32;
        let mut why = why;
        let mut p = 0;
        while p < bytes.len() {
            let r = match record_at(&bytes, p) {
                Ok(r) => r,
                Err(RecordError::Short) => {
                    why.get_or_insert_with(|| "the chunk ends inside a record".into());
                    break;
                }
                Err(RecordError::Bad(e)) => {
                    why = Some(format!("record at byte {p} of the inflated chunk: {e}"));
                    break;
                }
            };
            if let Err(e) = self.inner(&r, p, idx, chunk.pos) {
                why = Some(e);
                break;
            }
            p = r.end;
        }
        if let Some(why) = why {
            chunk.torn = true;
            let what = format!("chunk ({}): {why}", chunk.codec.name());
            self.pending = Some(damage(path, chunk.pos, what));
        }
        self.found.chunks.push(chunk);
        Ok(())
    }

    /// One record inside a chunk: a connection or a message.
    fn inner(&mut self, r: &Record, p: usize, idx: u32, chunk_pos: usize) -> Result<(), String> {
        match r.head.op {
            Some(OP_CONNECTION) => self.conn(connection(r, chunk_pos)?),
            Some(OP_MSG_DATA) => {
                let id = get_u32(r.head.conn, "conn")?;
                let conn = *self.ids.get(&id).ok_or(format!(
                    "a message on connection {id}, which no connection record before it defines"
                ))?;
                self.found.slots.push(Slot {
                    time_ns: get_time(r.head.time, "time")?,
                    offset: p as u64,
                    chunk: idx,
                    conn,
                });
            }
            op => return Err(format!("unexpected record in a chunk (op {op:?})")),
        }
        Ok(())
    }

    /// The file ends inside the record at `pos`: a torn last chunk is read as far as it goes.
    fn torn_end(&mut self, path: &Path, data: &[u8], pos: usize) -> Result<(), LogError> {
        let Ok(r) = head_at(data, pos) else {
            return Ok(());
        };
        if r.head.op != Some(OP_CHUNK) || r.data_at > data.len() {
            return Ok(());
        }
        if let Some(e) = self.pending.take() {
            return Err(e);
        }
        let Ok(mut chunk) = chunk_of(&r, pos) else {
            return Ok(());
        };
        chunk.data = r.data_at..data.len();
        chunk.torn = true;
        let (bytes, why) = decompress(chunk.codec, &data[chunk.data.clone()], chunk.size);
        self.chunk(path, chunk, bytes, why)?;
        self.pending = None;
        Ok(())
    }
}
