//! ROS 1 bag records (ROS wiki Bags/Format/2.0, "Records"): a `u32` header length, the header
//! (fields `u32 len`, `name=value`), a `u32` data length and the data. Parsing is bounded by
//! the buffer: a length running past its end is `Short`, never a panic.

/// Record kinds, the header's `op` field.
pub(crate) const OP_MSG_DATA: u8 = 0x02;
pub(crate) const OP_BAG_HEADER: u8 = 0x03;
pub(crate) const OP_INDEX_DATA: u8 = 0x04;
pub(crate) const OP_CHUNK: u8 = 0x05;
pub(crate) const OP_CHUNK_INFO: u8 = 0x06;
pub(crate) const OP_CONNECTION: u8 = 0x07;

/// One record, borrowed from the buffer it is in.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Record<'a> {
    pub head: Head<'a>,
    pub data: &'a [u8],
    /// Offset just past the record, where the next one starts.
    pub end: usize,
    /// Offset of the data in the buffer.
    pub data_at: usize,
}

/// Why no record could be read.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum RecordError {
    /// The record runs past the end of the buffer (a file cut short).
    Short,
    /// The bytes are not a record.
    Bad(String),
}

/// The header fields any record kind has; fields of other names are ignored.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Head<'a> {
    pub op: Option<u8>,
    pub conn: Option<&'a [u8]>,
    pub time: Option<&'a [u8]>,
    pub topic: Option<&'a [u8]>,
    pub compression: Option<&'a [u8]>,
    pub size: Option<&'a [u8]>,
    pub index_pos: Option<&'a [u8]>,
    pub conn_count: Option<&'a [u8]>,
    pub chunk_count: Option<&'a [u8]>,
    pub ver: Option<&'a [u8]>,
    pub count: Option<&'a [u8]>,
    pub chunk_pos: Option<&'a [u8]>,
    pub start_time: Option<&'a [u8]>,
    pub end_time: Option<&'a [u8]>,
}

fn le_u32(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(
        b.get(at..at.checked_add(4)?)?.try_into().ok()?,
    ))
}

/// Reads the record at `pos` of `buf`.
pub(crate) fn record_at(buf: &[u8], pos: usize) -> Result<Record<'_>, RecordError> {
    let r = head_at(buf, pos)?;
    let data = buf.get(r.data_at..r.end).ok_or(RecordError::Short)?;
    Ok(Record { data, ..r })
}

/// Reads the header of the record at `pos`, its data possibly cut short (then `data` is
/// empty and `end` past the buffer's end): what salvaging a torn last chunk needs.
pub(crate) fn head_at(buf: &[u8], pos: usize) -> Result<Record<'_>, RecordError> {
    let hlen = le_u32(buf, pos).ok_or(RecordError::Short)? as usize;
    let h_at = pos + 4;
    let h_end = h_at.checked_add(hlen).ok_or(RecordError::Short)?;
    let dlen = le_u32(buf, h_end).ok_or(RecordError::Short)? as usize;
    let data_at = h_end + 4;
    let end = data_at.checked_add(dlen).ok_or(RecordError::Short)?;
    let head = parse_head(&buf[h_at..h_end]).map_err(RecordError::Bad)?;
    Ok(Record {
        head,
        data: &[],
        end,
        data_at,
    })
}

/// The `name=value` fields of a header (or of a connection header), in order.
pub(crate) fn fields(mut h: &[u8]) -> impl Iterator<Item = Result<(&[u8], &[u8]), String>> {
    std::iter::from_fn(move || {
        if h.is_empty() {
            return None;
        }
        let Some(n) = le_u32(h, 0)
            .map(|n| n as usize)
            .filter(|&n| n <= h.len() - 4)
        else {
            h = &[];
            return Some(Err("a header field runs past the header's end".to_string()));
        };
        let field = &h[4..4 + n];
        h = &h[4 + n..];
        let Some(eq) = field.iter().position(|&b| b == b'=') else {
            h = &[];
            return Some(Err("a header field without `=`".to_string()));
        };
        Some(Ok((&field[..eq], &field[eq + 1..])))
    })
}

fn parse_head(h: &[u8]) -> Result<Head<'_>, String> {
    let mut head = Head::default();
    for f in fields(h) {
        let (name, value) = f?;
        let slot = match name {
            b"op" => {
                head.op = Some(*value.first().ok_or("an empty `op` field")?);
                continue;
            }
            b"conn" => &mut head.conn,
            b"time" => &mut head.time,
            b"topic" => &mut head.topic,
            b"compression" => &mut head.compression,
            b"size" => &mut head.size,
            b"index_pos" => &mut head.index_pos,
            b"conn_count" => &mut head.conn_count,
            b"chunk_count" => &mut head.chunk_count,
            b"ver" => &mut head.ver,
            b"count" => &mut head.count,
            b"chunk_pos" => &mut head.chunk_pos,
            b"start_time" => &mut head.start_time,
            b"end_time" => &mut head.end_time,
            _ => continue,
        };
        *slot = Some(value);
    }
    Ok(head)
}

/// A fixed-size field's value.
fn sized<const N: usize>(v: Option<&[u8]>, name: &str) -> Result<[u8; N], String> {
    let v = v.ok_or_else(|| format!("no `{name}` field"))?;
    v.try_into()
        .map_err(|_| format!("the `{name}` field has {} bytes, not {N}", v.len()))
}

pub(crate) fn get_u32(v: Option<&[u8]>, name: &str) -> Result<u32, String> {
    sized::<4>(v, name).map(u32::from_le_bytes)
}

pub(crate) fn get_u64(v: Option<&[u8]>, name: &str) -> Result<u64, String> {
    sized::<8>(v, name).map(u64::from_le_bytes)
}

/// A ROS time field (`u32` seconds, `u32` nanoseconds) as nanoseconds.
pub(crate) fn get_time(v: Option<&[u8]>, name: &str) -> Result<u64, String> {
    let b = sized::<8>(v, name)?;
    Ok(time_ns(&b))
}

/// Nanoseconds from the 8 bytes of a ROS time.
pub(crate) fn time_ns(b: &[u8; 8]) -> u64 {
    let sec = u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64;
    let nsec = u32::from_le_bytes([b[4], b[5], b[6], b[7]]) as u64;
    sec * 1_000_000_000 + nsec
}

/// Appends a record: header fields, then data.
pub(crate) fn put_record(out: &mut Vec<u8>, head: &[(&str, &[u8])], data: &[u8]) {
    let hlen: usize = head.iter().map(|(n, v)| 4 + n.len() + 1 + v.len()).sum();
    out.extend((hlen as u32).to_le_bytes());
    put_fields(out, head);
    out.extend((data.len() as u32).to_le_bytes());
    out.extend_from_slice(data);
}

/// Appends `name=value` fields, each after its `u32` length.
pub(crate) fn put_fields(out: &mut Vec<u8>, fields: &[(&str, &[u8])]) {
    for (n, v) in fields {
        out.extend(((n.len() + 1 + v.len()) as u32).to_le_bytes());
        out.extend_from_slice(n.as_bytes());
        out.push(b'=');
        out.extend_from_slice(v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_parse_and_short_ones_say_so() {
        let mut b = Vec::new();
        put_record(
            &mut b,
            &[("op", &[OP_CHUNK]), ("size", &7u32.to_le_bytes())],
            b"abc",
        );
        let r = record_at(&b, 0).unwrap();
        assert_eq!(r.head.op, Some(OP_CHUNK));
        assert_eq!(get_u32(r.head.size, "size"), Ok(7));
        assert_eq!(r.data, b"abc");
        assert_eq!(r.end, b.len());
        for cut in 0..b.len() {
            assert_eq!(record_at(&b[..cut], 0).unwrap_err(), RecordError::Short);
        }
        b[4] = 200; // a field length past the header
        assert!(matches!(record_at(&b, 0), Err(RecordError::Bad(_))));
        assert!(
            get_u64(Some(&[1, 2]), "index_pos")
                .unwrap_err()
                .contains("2 bytes")
        );
    }
}
