//! Finding an MCAP file's schemas, channels, chunks and messages: from its summary section
//! (chunk indexes pointing at each chunk's message index records) when it has a usable one,
//! else by scanning the data section record by record (MCAP spec, "Summary Section", "Chunk
//! Index", "Message Index"; readers skip opcodes they do not know).

use super::records::*;
use super::{Chunk, Found};
use crate::LogError;
use crate::compress::{Codec, decompress};
use crate::merge::Slot;
use std::collections::HashMap;
use std::path::Path;

/// A record reaching further than this past the end of the file has a damaged length rather
/// than being cut short: chunks are megabytes.
const MAX_OVERSHOOT: u64 = 64 << 20;

/// Footer record (opcode, length 20, summary_start, summary_offset_start, summary_crc) and the
/// closing magic.
const FOOTER_LEN: usize = 1 + 8 + 20;

/// Where the footer says the summary starts, if it has a footer and a summary.
fn summary_start(data: &[u8]) -> Option<usize> {
    let f = rec_at(data, data.len().checked_sub(MAGIC.len() + FOOTER_LEN)?).ok()?;
    let start = usize::try_from(Cur::new(f.body).u64().ok()?).ok()?;
    (f.op == OP_FOOTER && start > MAGIC.len() && start < data.len()).then_some(start)
}

/// Reads the summary. Anything missing or inconsistent is an `Err`: the caller then scans.
pub(crate) fn read_summary(data: &[u8]) -> Result<Found, String> {
    if data.len() < MAGIC.len() * 2 + FOOTER_LEN || !data.ends_with(MAGIC) {
        return Err("no closing magic: the file was not finished".into());
    }
    let footer_at = data.len() - MAGIC.len() - FOOTER_LEN;
    let f = rec_at(data, footer_at).map_err(|_| "no footer")?;
    if f.op != OP_FOOTER || f.end != data.len() - MAGIC.len() {
        return Err("no footer record".into());
    }
    let start = Cur::new(f.body).u64()?;
    let mut pos = usize::try_from(start).map_err(|e| e.to_string())?;
    if pos == 0 || pos > footer_at {
        return Err("no summary section".into());
    }
    let mut found = Found::default();
    let mut indexes = Vec::new();
    let mut expected = None;
    while pos < footer_at {
        let r = rec_at(data, pos)
            .ok()
            .filter(|r| r.end <= footer_at)
            .ok_or("a summary record runs past the footer")?;
        match r.op {
            OP_SCHEMA => found.add_schema(schema(r.body)?),
            OP_CHANNEL => found.add_channel(channel(r.body)?, pos),
            OP_CHUNK_INDEX => indexes.push(chunk_index(r.body)?),
            OP_STATISTICS => expected = Some(Cur::new(r.body).u64()?),
            _ => {}
        }
        pos = r.end;
    }
    if indexes.is_empty() {
        return Err("no chunk indexes (messages outside chunks, or none)".into());
    }
    indexes.sort_by_key(|c| c.chunk_at);
    top_level(data, start as usize, indexes.len())?;
    for ci in &indexes {
        indexed_chunk(data, ci, &mut found)?;
    }
    if expected.is_some_and(|n| n != found.slots.len() as u64) {
        return Err("the statistics count other messages than the chunk indexes".into());
    }
    Ok(found)
}

/// Checks the data section's top-level records against the summary: as many chunks as
/// chunk indexes, and no message outside a chunk (which no index would list).
fn top_level(data: &[u8], end: usize, chunks: usize) -> Result<(), String> {
    let mut pos = MAGIC.len();
    let mut seen = 0;
    while pos < end {
        let r = rec_at(data, pos).map_err(|_| format!("a damaged record at {pos}"))?;
        match r.op {
            OP_CHUNK => seen += 1,
            OP_MESSAGE => return Err("messages outside chunks".into()),
            OP_DATA_END => break,
            _ => {}
        }
        pos = r.end;
    }
    if seen != chunks {
        return Err(format!("{seen} chunks, {chunks} chunk indexes"));
    }
    Ok(())
}

/// One chunk and the message index records its chunk index points at.
fn indexed_chunk(data: &[u8], ci: &ChunkIndexRec, found: &mut Found) -> Result<(), String> {
    let at = usize::try_from(ci.chunk_at).map_err(|e| e.to_string())?;
    let r = rec_at(data, at).map_err(|_| format!("chunk index points past the end ({at})"))?;
    if r.op != OP_CHUNK || (r.end - at) as u64 != ci.chunk_len {
        return Err(format!("chunk index points at no chunk ({at})"));
    }
    let chunk = chunk_of(&r, at)?;
    if ci.indexes.is_empty() {
        return Err(format!("chunk at {at} has no message indexes"));
    }
    let idx = found.chunks.len() as u32;
    for &(ch, off) in &ci.indexes {
        let off = usize::try_from(off).map_err(|e| e.to_string())?;
        let m = rec_at(data, off).map_err(|_| "message index past the end".to_string())?;
        if m.op != OP_MESSAGE_INDEX {
            return Err(format!("chunk index points at no message index ({off})"));
        }
        let (id, entries) = message_index(m.body)?;
        let conn = *found
            .ids
            .get(&id)
            .ok_or("message index of an unknown channel")?;
        if id != ch {
            return Err(format!(
                "chunk index points at another channel's index ({off})"
            ));
        }
        for (time_ns, offset) in entries {
            if offset >= chunk.size {
                return Err(format!(
                    "message index at {off}: offset past the chunk's end"
                ));
            }
            found.slots.push(Slot {
                time_ns,
                offset,
                chunk: idx,
                conn,
            });
        }
    }
    found.chunks.push(chunk);
    Ok(())
}

/// A chunk record's compression, sizes and where its records are.
pub(crate) fn chunk_of(r: &Rec, at: usize) -> Result<Chunk, String> {
    let c = chunk(r.body)?;
    let codec = match c.compression.as_str() {
        "" => Codec::None,
        "zstd" => Codec::Zstd,
        "lz4" => Codec::Lz4,
        other => {
            return Err(format!(
                "chunk compression `{other}`, which is not read (only zstd, lz4, none)"
            ));
        }
    };
    let start = r.body_at + c.records_at;
    Ok(Chunk {
        pos: at,
        records: start..start + c.records.len(),
        codec,
        size: c.size,
        crc: c.crc,
        torn: false,
    })
}

fn damage(path: &Path, at: usize, what: String) -> LogError {
    LogError::new(path, format!("damaged record: {what}"))
        .at(at as u64)
        .fix("the file is damaged here; `mcap recover` may save what is readable")
}

/// Scans the data section: for files without a usable summary. Damage at the very end (a
/// record cut short) ends the scan with what was readable; damage before more messages is an
/// error.
pub(crate) fn scan(path: &Path, data: &[u8]) -> Result<Found, LogError> {
    let mut found = Found::default();
    let mut pending: Option<LogError> = None;
    let mut pos = MAGIC.len();
    match rec_at(data, pos) {
        Ok(r) if r.op == OP_HEADER => pos = r.end,
        _ => return Err(damage(path, pos, "no header record after the magic".into())),
    }
    // A file ending in the magic was closed, not cut short: its records are all complete, and
    // those of the data section end where the summary starts.
    let closed = data.len() >= 2 * MAGIC.len() + FOOTER_LEN && data.ends_with(MAGIC);
    let summary = if closed { summary_start(data) } else { None };
    while pos < data.len() {
        let r = match rec_at(data, pos) {
            Ok(r) => r,
            Err(_) => {
                cut_short(path, data, pos, closed)?;
                if let Some(e) = pending.take().filter(|_| data[pos] == OP_CHUNK) {
                    return Err(e);
                }
                torn_chunk(data, pos, &mut found);
                break;
            }
        };
        if summary.is_some_and(|s| pos < s && r.end > s) {
            let what = "a record runs into the summary: its length is damaged";
            return Err(damage(path, pos, what.into()));
        }
        if matches!(r.op, OP_MESSAGE | OP_CHUNK)
            && let Some(e) = pending.take()
        {
            return Err(e);
        }
        let bad = |e: String| damage(path, pos, e);
        match r.op {
            OP_SCHEMA => found.add_schema(schema(r.body).map_err(bad)?),
            OP_CHANNEL => found.add_channel(channel(r.body).map_err(bad)?, pos),
            OP_MESSAGE => found.loose_message(data, &r, pos).map_err(bad)?,
            OP_CHUNK => {
                let chunk = chunk_of(&r, pos).map_err(bad)?;
                let (bytes, why) =
                    decompress(chunk.codec, &data[chunk.records.clone()], chunk.size);
                if let Some(why) = found.chunk(chunk, &bytes, why) {
                    pending = Some(damage(path, pos, why));
                }
            }
            OP_DATA_END | OP_FOOTER => break,
            _ => {}
        }
        pos = r.end;
    }
    // A closed file has no torn last chunk: damage in it is damage.
    match pending {
        Some(e) if closed => Err(e),
        _ => Ok(found),
    }
}

/// A record at `pos` runs past the end of the file: fine for the last record of a file cut
/// short, damage in a closed file or when the length is far beyond any real record's.
fn cut_short(path: &Path, data: &[u8], pos: usize, closed: bool) -> Result<(), LogError> {
    let len = data
        .get(pos + 1..pos + 9)
        .map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")));
    let overshoot =
        len.is_some_and(|l| l.saturating_add((pos + 9) as u64) - data.len() as u64 > MAX_OVERSHOOT);
    if closed || overshoot {
        let what = "a record runs past the end of the file: its length is damaged";
        return Err(damage(path, pos, what.into()));
    }
    Ok(())
}

/// A chunk cut off by the end of the file: its records as far as they inflate.
fn torn_chunk(data: &[u8], pos: usize, found: &mut Found) {
    if data.get(pos) != Some(&OP_CHUNK) || data.len() < pos + 9 {
        return;
    }
    let fake = Rec {
        op: OP_CHUNK,
        body: &data[pos + 9..],
        body_at: pos + 9,
        end: data.len(),
    };
    // The records' length field says more than is left: read the head, cut the records.
    let mut c = Cur::new(fake.body);
    let head = (|| -> Result<(Codec, u64, usize), String> {
        c.take(16)?;
        let size = c.u64()?;
        c.u32()?;
        let codec = match c.string()?.as_str() {
            "" => Codec::None,
            "zstd" => Codec::Zstd,
            "lz4" => Codec::Lz4,
            _ => return Err(String::new()),
        };
        c.u64()?;
        Ok((codec, size, c.at()))
    })();
    let Ok((codec, size, at)) = head else { return };
    let start = pos + 9 + at;
    let chunk = Chunk {
        pos,
        records: start..data.len(),
        codec,
        size,
        crc: 0,
        torn: true,
    };
    let (bytes, why) = decompress(codec, &data[chunk.records.clone()], size);
    found.chunk(chunk, &bytes, why);
}

impl Found {
    pub(crate) fn add_schema(&mut self, s: SchemaRec) {
        if !self.schemas.iter().any(|x| x.id == s.id) {
            self.schemas.push(s);
        }
    }

    /// Adds a channel whose record is at `at` (its chunk's offset if in a chunk).
    pub(crate) fn add_channel(&mut self, mut c: ChannelRec, at: usize) {
        c.at = at;
        if !self.ids.contains_key(&c.id) {
            self.ids.insert(c.id, self.channels.len() as u32);
            self.channels.push(c);
        }
    }

    /// A message outside any chunk: its offset is in the file, read through a chunk standing
    /// for the whole file.
    fn loose_message(&mut self, data: &[u8], r: &Rec, pos: usize) -> Result<(), String> {
        let (ch, time_ns, _) = message(r.body)?;
        let conn = self.channel_of(ch)?;
        let idx = *self.file_chunk.get_or_insert_with(|| {
            self.chunks.push(Chunk {
                pos: 0,
                records: 0..data.len(),
                codec: Codec::None,
                size: data.len() as u64,
                crc: 0,
                torn: false,
            });
            self.chunks.len() as u32 - 1
        });
        self.slots.push(Slot {
            time_ns,
            offset: pos as u64,
            chunk: idx,
            conn,
        });
        Ok(())
    }

    fn channel_of(&self, id: u16) -> Result<u32, String> {
        self.ids.get(&id).copied().ok_or(format!(
            "a message on channel {id}, which no channel record before it defines"
        ))
    }

    /// Takes the records of an inflated chunk; returns the damage in it, if any.
    fn chunk(&mut self, mut chunk: Chunk, bytes: &[u8], mut why: Option<String>) -> Option<String> {
        let idx = self.chunks.len() as u32;
        let mut p = 0;
        while p < bytes.len() {
            let r = match rec_at(bytes, p) {
                Ok(r) => r,
                Err(_) => {
                    why.get_or_insert_with(|| "the chunk ends inside a record".into());
                    break;
                }
            };
            let res = match r.op {
                OP_SCHEMA => schema(r.body).map(|s| self.add_schema(s)),
                OP_CHANNEL => channel(r.body).map(|c| self.add_channel(c, chunk.pos)),
                OP_MESSAGE => message(r.body).and_then(|(ch, time_ns, _)| {
                    let conn = self.channel_of(ch)?;
                    let offset = p as u64;
                    self.slots.push(Slot {
                        time_ns,
                        offset,
                        chunk: idx,
                        conn,
                    });
                    Ok(())
                }),
                _ => Ok(()),
            };
            if let Err(e) = res {
                why = Some(format!("record at byte {p} of the inflated chunk: {e}"));
                break;
            }
            p = r.end;
        }
        chunk.torn |= why.is_some();
        self.chunks.push(chunk);
        why.map(|w| format!("chunk: {w}"))
    }
}

/// Channel id -> index in `channels`.
pub(crate) type Ids = HashMap<u16, u32>;
