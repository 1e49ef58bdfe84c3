//! MCAP records (MCAP spec, "Records"): an opcode byte, a `u64` length and the body; strings
//! and byte arrays with a `u32` length, maps with a `u32` byte length, all little endian.
//! Every read is bounded by the body: a length past its end is an error, never a panic.

pub(crate) const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
pub(crate) const OP_HEADER: u8 = 0x01;
pub(crate) const OP_FOOTER: u8 = 0x02;
pub(crate) const OP_SCHEMA: u8 = 0x03;
pub(crate) const OP_CHANNEL: u8 = 0x04;
pub(crate) const OP_MESSAGE: u8 = 0x05;
pub(crate) const OP_CHUNK: u8 = 0x06;
pub(crate) const OP_MESSAGE_INDEX: u8 = 0x07;
pub(crate) const OP_CHUNK_INDEX: u8 = 0x08;
pub(crate) const OP_STATISTICS: u8 = 0x0B;
pub(crate) const OP_SUMMARY_OFFSET: u8 = 0x0E;
pub(crate) const OP_DATA_END: u8 = 0x0F;

/// One record, borrowed from its buffer.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Rec<'a> {
    pub op: u8,
    pub body: &'a [u8],
    /// Offset of the body in the buffer.
    pub body_at: usize,
    /// Offset just past the record.
    pub end: usize,
}

/// The record at `pos`: `Err(None)` when it runs past the end of `buf` (a file cut short).
pub(crate) fn rec_at(buf: &[u8], pos: usize) -> Result<Rec<'_>, Option<String>> {
    let op = *buf.get(pos).ok_or(None)?;
    let len = buf.get(pos + 1..pos + 9).ok_or(None)?;
    let len = u64::from_le_bytes(len.try_into().expect("8 bytes"));
    let body_at = pos + 9;
    let end = usize::try_from(len)
        .ok()
        .and_then(|l| body_at.checked_add(l))
        .filter(|&e| e <= buf.len())
        .ok_or(None)?;
    Ok(Rec {
        op,
        body: &buf[body_at..end],
        body_at,
        end,
    })
}

/// Reads a record body field by field.
pub(crate) struct Cur<'a> {
    b: &'a [u8],
    p: usize,
}

impl<'a> Cur<'a> {
    pub(crate) fn new(b: &'a [u8]) -> Cur<'a> {
        Cur { b, p: 0 }
    }

    pub(crate) fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.p.checked_add(n).filter(|&e| e <= self.b.len());
        let end = end.ok_or_else(|| {
            format!(
                "a field runs past the record's end ({n} bytes at {})",
                self.p
            )
        })?;
        let s = &self.b[self.p..end];
        self.p = end;
        Ok(s)
    }

    pub(crate) fn u16(&mut self) -> Result<u16, String> {
        Ok(u16::from_le_bytes(
            self.take(2)?.try_into().expect("2 bytes"),
        ))
    }

    pub(crate) fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }

    pub(crate) fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }

    /// A `u32`-prefixed byte array (also a map's bytes).
    pub(crate) fn bytes(&mut self) -> Result<&'a [u8], String> {
        let n = self.u32()? as usize;
        self.take(n)
    }

    pub(crate) fn string(&mut self) -> Result<String, String> {
        Ok(String::from_utf8_lossy(self.bytes()?).into_owned())
    }

    /// What is left of the body.
    pub(crate) fn rest(&mut self) -> &'a [u8] {
        let s = &self.b[self.p..];
        self.p = self.b.len();
        s
    }

    pub(crate) fn at(&self) -> usize {
        self.p
    }
}

/// Schema: id, name, encoding (`ros2msg`), data (the definition text).
#[derive(Debug, Clone)]
pub(crate) struct SchemaRec {
    pub id: u16,
    pub name: String,
    pub encoding: String,
    pub data: Vec<u8>,
}

pub(crate) fn schema(body: &[u8]) -> Result<SchemaRec, String> {
    let mut c = Cur::new(body);
    Ok(SchemaRec {
        id: c.u16()?,
        name: c.string()?,
        encoding: c.string()?,
        data: c.bytes()?.to_vec(),
    })
}

/// Channel: id, schema id, topic, message encoding (`cdr`); its metadata is not needed.
#[derive(Debug, Clone)]
pub(crate) struct ChannelRec {
    pub id: u16,
    pub schema_id: u16,
    pub topic: String,
    pub encoding: String,
    /// Offset of the record in the file (of its chunk, if in one), for errors.
    pub at: usize,
}

pub(crate) fn channel(body: &[u8]) -> Result<ChannelRec, String> {
    let mut c = Cur::new(body);
    Ok(ChannelRec {
        id: c.u16()?,
        schema_id: c.u16()?,
        topic: c.string()?,
        encoding: c.string()?,
        at: 0,
    })
}

/// Message: channel id, sequence, log time, publish time, then the payload.
pub(crate) fn message(body: &[u8]) -> Result<(u16, u64, &[u8]), String> {
    let mut c = Cur::new(body);
    let ch = c.u16()?;
    c.u32()?;
    let log_time = c.u64()?;
    c.u64()?;
    Ok((ch, log_time, c.rest()))
}

/// Chunk: start and end time, inflated size and CRC, compression, then the records.
#[derive(Debug, Clone)]
pub(crate) struct ChunkRec<'a> {
    pub size: u64,
    pub crc: u32,
    pub compression: String,
    pub records: &'a [u8],
    /// Offset of `records` in the record body.
    pub records_at: usize,
}

pub(crate) fn chunk(body: &[u8]) -> Result<ChunkRec<'_>, String> {
    let mut c = Cur::new(body);
    c.u64()?;
    c.u64()?;
    let size = c.u64()?;
    let crc = c.u32()?;
    let compression = c.string()?;
    let n = usize::try_from(c.u64()?).map_err(|e| e.to_string())?;
    let records_at = c.at();
    Ok(ChunkRec {
        size,
        crc,
        compression,
        records: c.take(n)?,
        records_at,
    })
}

/// Message index: channel id, then (log time, offset in the inflated chunk) pairs.
pub(crate) fn message_index(body: &[u8]) -> Result<(u16, Vec<(u64, u64)>), String> {
    let mut c = Cur::new(body);
    let ch = c.u16()?;
    let pairs = c.bytes()?;
    if pairs.len() % 16 != 0 {
        return Err("a message index of a length not a multiple of 16".into());
    }
    let u = |b: &[u8]| u64::from_le_bytes(b.try_into().expect("8 bytes"));
    Ok((
        ch,
        pairs
            .chunks_exact(16)
            .map(|p| (u(&p[..8]), u(&p[8..])))
            .collect(),
    ))
}

/// Chunk index: where a chunk is and where its message index records are.
#[derive(Debug, Clone)]
pub(crate) struct ChunkIndexRec {
    pub chunk_at: u64,
    pub chunk_len: u64,
    /// (channel id, offset of its message index record in the file).
    pub indexes: Vec<(u16, u64)>,
}

pub(crate) fn chunk_index(body: &[u8]) -> Result<ChunkIndexRec, String> {
    let mut c = Cur::new(body);
    c.u64()?;
    c.u64()?;
    let chunk_at = c.u64()?;
    let chunk_len = c.u64()?;
    let mut map = Cur::new(c.bytes()?);
    let mut indexes = Vec::new();
    while map.at() < map.b.len() {
        indexes.push((map.u16()?, map.u64()?));
    }
    Ok(ChunkIndexRec {
        chunk_at,
        chunk_len,
        indexes,
    })
}

/// Appends a record.
pub(crate) fn put(out: &mut Vec<u8>, op: u8, body: &[u8]) {
    out.push(op);
    out.extend((body.len() as u64).to_le_bytes());
    out.extend_from_slice(body);
}

/// Appends a `u32`-prefixed string or byte array.
pub(crate) fn put_bytes(out: &mut Vec<u8>, b: &[u8]) {
    out.extend((b.len() as u32).to_le_bytes());
    out.extend_from_slice(b);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_and_fields_are_bounded() {
        let mut body = Vec::new();
        body.extend(3u16.to_le_bytes());
        put_bytes(&mut body, b"pkg/msg/T");
        put_bytes(&mut body, b"ros2msg");
        put_bytes(&mut body, b"int32 a");
        let mut rec = Vec::new();
        put(&mut rec, OP_SCHEMA, &body);
        let r = rec_at(&rec, 0).unwrap();
        assert_eq!(r.op, OP_SCHEMA);
        let s = schema(r.body).unwrap();
        assert_eq!(
            (s.id, s.name.as_str(), s.data.as_slice()),
            (3, "pkg/msg/T", &b"int32 a"[..])
        );
        for cut in 0..rec.len() {
            assert!(rec_at(&rec[..cut], 0).unwrap_err().is_none());
        }
        for cut in 0..body.len() {
            assert!(schema(&body[..cut]).is_err());
        }
    }
}
