//! Message bytes to [`Value`]s: ROS 1 serialization and CDR, as a schema lays them out.
//!
//! ROS 1 (ROS wiki msg, "Serialization"): little endian, no padding, strings and variable
//! arrays prefixed by a `u32` count, `time`/`duration` as two 32-bit words.
//! CDR (OMG CORBA 3.0 §15.3 "CDR transfer syntax", as ROS 2 RMWs use it, XCDR1): a 4-byte
//! encapsulation header, each primitive aligned to its own size counted from the end of that
//! header, strings as a `u32` length that includes the terminating NUL, sequences as a `u32`
//! count, fixed arrays without one.

use crate::value::{Kind, Leaf, Schema, Value};
use std::fmt;

/// The byte layout of a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Wire {
    Ros1,
    /// CDR without its encapsulation header; `big` for big-endian data.
    Cdr {
        big: bool,
    },
}

/// Why a message does not fit its schema, and in which field.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct WireError {
    /// `twist.linear.x`, `data[3]`; empty for the message as a whole.
    pub path: String,
    pub what: String,
}

impl fmt::Display for WireError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.path.is_empty() {
            write!(f, "{}", self.what)
        } else {
            write!(f, "field `{}`: {}", self.path, self.what)
        }
    }
}

fn fail<T>(what: impl Into<String>) -> Result<T, WireError> {
    Err(WireError {
        path: String::new(),
        what: what.into(),
    })
}

/// Puts `step` in front of the error's field path.
fn within(step: &str) -> impl FnOnce(WireError) -> WireError + '_ {
    move |mut e| {
        e.path = match (e.path.is_empty(), e.path.starts_with('[')) {
            (true, _) => step.to_string(),
            (false, true) => format!("{step}{}", e.path),
            (false, false) => format!("{step}.{}", e.path),
        };
        e
    }
}

/// Variable arrays of zero-size elements (an empty message type) longer than this are damage.
const MAX_EMPTY_ELEMENTS: u64 = 1 << 16;

/// Decodes a whole message; bytes left over are an error (CDR allows up to 3 bytes of final
/// padding, which some RMWs add to reach a multiple of 4).
pub(crate) fn decode(schema: &Schema, bytes: &[u8], wire: Wire) -> Result<Value, WireError> {
    let mut r = Reader {
        buf: bytes,
        pos: 0,
        wire,
    };
    let v = r.fields(schema)?;
    let left = bytes.len() - r.pos;
    let allowed = if matches!(wire, Wire::Cdr { .. }) {
        3
    } else {
        0
    };
    if left > allowed {
        return fail(format!(
            "{left} bytes left over after the message ({} bytes read of {})",
            r.pos,
            bytes.len()
        ));
    }
    Ok(v)
}

/// Decodes a CDR payload with its encapsulation header (OMG DDS-XTypes 1.3 §7.6.3.1.2).
pub(crate) fn decode_cdr(schema: &Schema, payload: &[u8]) -> Result<Value, WireError> {
    let Some(head) = payload.get(..4) else {
        return fail(format!(
            "{} bytes, shorter than the CDR header",
            payload.len()
        ));
    };
    let big = match (head[0], head[1]) {
        (0, 0) => true,
        (0, 1) => false,
        (0, 2 | 3) => {
            return fail("parameter-list CDR (PL_CDR), which is not read: only plain CDR");
        }
        (0, 6..=11) => return fail("XCDR2 encoding, which is not read: only plain CDR (XCDR1)"),
        (a, b) => return fail(format!("unknown CDR encapsulation {a:#04x} {b:#04x}")),
    };
    decode(schema, &payload[4..], Wire::Cdr { big })
}

struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
    wire: Wire,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], WireError> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.buf.len());
        let Some(end) = end else {
            return fail(format!(
                "the message ends at byte {}, {n} bytes needed at byte {}",
                self.buf.len(),
                self.pos
            ));
        };
        let s = &self.buf[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    /// CDR aligns a primitive of size `n` to a multiple of `n` (max 8); ROS 1 never pads.
    fn align(&mut self, n: usize) -> Result<(), WireError> {
        if let Wire::Cdr { .. } = self.wire {
            let pad = (n - self.pos % n) % n;
            self.take(pad)?;
        }
        Ok(())
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], WireError> {
        self.align(N)?;
        let mut a: [u8; N] = self.take(N)?.try_into().expect("take returns N bytes");
        if let Wire::Cdr { big: true } = self.wire {
            a.reverse();
        }
        Ok(a)
    }

    fn u32(&mut self) -> Result<u32, WireError> {
        self.array::<4>().map(u32::from_le_bytes)
    }

    fn leaf(&mut self, leaf: Leaf) -> Result<Value, WireError> {
        Ok(match leaf {
            Leaf::Bool => Value::Bool(self.take(1)?[0] != 0),
            Leaf::I8 => Value::Int(self.take(1)?[0] as i8 as i64),
            Leaf::U8 => Value::UInt(self.take(1)?[0] as u64),
            Leaf::I16 => Value::Int(i16::from_le_bytes(self.array()?) as i64),
            Leaf::U16 => Value::UInt(u16::from_le_bytes(self.array()?) as u64),
            Leaf::I32 => Value::Int(i32::from_le_bytes(self.array()?) as i64),
            Leaf::U32 => Value::UInt(self.u32()? as u64),
            Leaf::I64 => Value::Int(i64::from_le_bytes(self.array()?)),
            Leaf::U64 => Value::UInt(u64::from_le_bytes(self.array()?)),
            Leaf::F32 => Value::Float(f32::from_le_bytes(self.array()?) as f64),
            Leaf::F64 => Value::Float(f64::from_le_bytes(self.array()?)),
            Leaf::Text => Value::Text(self.text()?),
            Leaf::Time => {
                let (s, ns) = (self.u32()?, self.u32()?);
                Value::Float(join_time(s as i64, ns as i64))
            }
            Leaf::Duration => {
                let (s, ns) = (self.u32()? as i32, self.u32()? as i32);
                Value::Float(join_time(s as i64, ns as i64))
            }
        })
    }

    fn text(&mut self) -> Result<String, WireError> {
        let n = self.u32()? as usize;
        let mut bytes = self.take(n)?;
        if let Wire::Cdr { .. } = self.wire {
            // The length counts the terminating NUL; a length of 0 (no NUL) is seen too.
            match bytes.split_last() {
                Some((0, rest)) => bytes = rest,
                Some(_) => return fail("a CDR string without its terminating NUL"),
                None => {}
            }
        }
        Ok(String::from_utf8_lossy(bytes).into_owned())
    }

    fn fields(&mut self, schema: &Schema) -> Result<Value, WireError> {
        let mut out = Vec::with_capacity(schema.fields.len());
        for f in &schema.fields {
            out.push(self.kind(&f.kind).map_err(within(&f.name))?);
        }
        Ok(Value::Struct(out))
    }

    fn kind(&mut self, kind: &Kind) -> Result<Value, WireError> {
        match kind {
            Kind::Leaf(l) => self.leaf(*l),
            Kind::Struct(_, s) => self.fields(s),
            Kind::Array(elem, len) => {
                let n = match len {
                    Some(n) => *n as u64,
                    None => self.u32()? as u64,
                };
                self.elements(elem, n)
            }
        }
    }

    fn elements(&mut self, elem: &Kind, n: u64) -> Result<Value, WireError> {
        let left = (self.buf.len() - self.pos) as u64;
        let min = min_size(elem) as u64;
        if n.saturating_mul(min) > left || (min == 0 && n > MAX_EMPTY_ELEMENTS) {
            return fail(format!(
                "an array of {n} elements does not fit in the {left} bytes left"
            ));
        }
        if let Kind::Leaf(Leaf::U8) = elem {
            return Ok(Value::Bytes(self.take(n as usize)?.to_vec()));
        }
        let mut items = Vec::with_capacity(n as usize);
        for i in 0..n {
            items.push(self.kind(elem).map_err(|e| within(&format!("[{i}]"))(e))?);
        }
        Ok(Value::Array(items))
    }
}

/// The fewest bytes a value of `kind` takes (padding not counted): bounds array counts.
fn min_size(kind: &Kind) -> usize {
    match kind {
        Kind::Leaf(l) => match l {
            Leaf::Bool | Leaf::I8 | Leaf::U8 => 1,
            Leaf::I16 | Leaf::U16 => 2,
            Leaf::I32 | Leaf::U32 | Leaf::F32 | Leaf::Text => 4,
            Leaf::I64 | Leaf::U64 | Leaf::F64 | Leaf::Time | Leaf::Duration => 8,
        },
        Kind::Struct(_, s) => s.fields.iter().map(|f| min_size(&f.kind)).sum(),
        Kind::Array(_, None) => 4,
        Kind::Array(e, Some(n)) => min_size(e).saturating_mul(*n),
    }
}

/// Seconds from a (seconds, nanoseconds) pair, the way ROS and MCAP count time.
pub(crate) fn join_time(sec: i64, nsec: i64) -> f64 {
    sec as f64 + nsec as f64 * 1e-9
}

/// Seconds from nanoseconds, without losing the nanoseconds to a large `f64` product.
pub(crate) fn ns_to_s(ns: u64) -> f64 {
    join_time((ns / 1_000_000_000) as i64, (ns % 1_000_000_000) as i64)
}

/// Seconds as (seconds, nanoseconds), nanoseconds in 0..1e9; `None` out of `i64` range or NaN.
pub(crate) fn split_time(s: f64) -> Option<(i64, u32)> {
    if !s.is_finite() || s.abs() > 9.0e18 / 1e9 {
        return None;
    }
    let mut sec = s.floor() as i64;
    let mut nsec = ((s - s.floor()) * 1e9).round() as i64;
    if nsec >= 1_000_000_000 {
        sec += 1;
        nsec -= 1_000_000_000;
    }
    Some((sec, nsec as u32))
}

/// The stamp of a message with a header (`header.stamp`), in seconds, `None` when zero. The
/// stamp is a ROS 1 `time` (a `Float`) or a ROS 2 `builtin_interfaces/Time` struct.
pub(crate) fn header_stamp(schema: &Schema, value: &Value) -> Option<f64> {
    if !schema.has_header() {
        return None;
    }
    let (Kind::Struct(_, header), Value::Struct(v)) = (&schema.fields[0].kind, value) else {
        return None;
    };
    let i = header.fields.iter().position(|f| f.name == "stamp")?;
    let Value::Struct(h) = v.first()? else {
        return None;
    };
    let s = match h.get(i)? {
        Value::Float(s) => *s,
        Value::Struct(t) => t.first()?.as_f64()? + t.get(1)?.as_f64()? * 1e-9,
        _ => return None,
    };
    (s != 0.0).then_some(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgdef::{Flavor, schema};

    #[test]
    fn cdr_aligns_from_after_the_header() {
        let s = schema(
            "uint8 a\nfloat64 b\nstring c\nint16[] d",
            "t/T",
            Flavor::Ros2,
        )
        .unwrap();
        let mut p = vec![0, 1, 0, 0, 7];
        p.extend([0; 7]);
        p.extend(2.5f64.to_le_bytes());
        p.extend(3u32.to_le_bytes());
        p.extend(b"hi\0");
        p.push(0); // pad to 4 for the count
        p.extend(2u32.to_le_bytes());
        p.extend([1, 0, 0xff, 0xff]);
        let v = decode_cdr(&s, &p).unwrap();
        let want = Value::Struct(vec![
            Value::UInt(7),
            Value::Float(2.5),
            Value::Text("hi".into()),
            Value::Array(vec![Value::Int(1), Value::Int(-1)]),
        ]);
        assert_eq!(v, want);
        p[1] = 7;
        assert!(decode_cdr(&s, &p).unwrap_err().what.contains("XCDR2"));
    }

    #[test]
    fn ros1_errors_name_the_field() {
        let s = schema("Header header\nfloat32[] data", "t/T", Flavor::Ros1).unwrap();
        let mut b = Vec::new();
        b.extend(1u32.to_le_bytes());
        b.extend([0; 8]);
        b.extend(0u32.to_le_bytes());
        b.extend(1000u32.to_le_bytes());
        let e = decode(&s, &b, Wire::Ros1).unwrap_err();
        assert_eq!(e.path, "data");
        assert!(e.what.contains("1000 elements"), "{e}");
        b.truncate(12);
        let e = decode(&s, &b, Wire::Ros1).unwrap_err();
        assert_eq!(e.path, "header.frame_id");
    }

    #[test]
    fn times_split_and_join() {
        assert_eq!(split_time(1.5), Some((1, 500_000_000)));
        assert_eq!(split_time(-0.25), Some((-1, 750_000_000)));
        assert_eq!(split_time(f64::NAN), None);
        let s = ns_to_s(1_700_000_000_123_456_789);
        assert!((s - 1_700_000_000.0 - 0.123_456_789).abs() < 3e-7, "{s}");
    }
}
