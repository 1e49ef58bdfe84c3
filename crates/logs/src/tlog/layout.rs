//! Where each field of a compiled-in MAVLink message sits on the wire, the X.25 checksum,
//! and decoding a payload into a [`Value`].
//!
//! Wire order (MAVLink serialization spec, "Field Reordering"): the base fields sorted by
//! the size of their type, largest first, keeping the XML order among equals (arrays sort by
//! their element type); then the extension fields in XML order. MAVLink 2 drops trailing
//! zero bytes of the payload, which the reader puts back.

use super::defs::{FieldDef, MESSAGES, MsgDef, Ty};
use crate::value::{Field, Kind, Leaf, Schema, Value};
use std::collections::HashMap;

impl Ty {
    pub(crate) fn size(self) -> usize {
        match self {
            Ty::U8 | Ty::I8 | Ty::Char => 1,
            Ty::U16 | Ty::I16 => 2,
            Ty::U32 | Ty::I32 | Ty::F32 => 4,
            Ty::U64 | Ty::I64 | Ty::F64 => 8,
        }
    }

    /// The C type name, as CRC_EXTRA hashes it.
    #[cfg(test)]
    fn c_name(self) -> &'static str {
        match self {
            Ty::U8 => "uint8_t",
            Ty::I8 => "int8_t",
            Ty::U16 => "uint16_t",
            Ty::I16 => "int16_t",
            Ty::U32 => "uint32_t",
            Ty::I32 => "int32_t",
            Ty::U64 => "uint64_t",
            Ty::I64 => "int64_t",
            Ty::F32 => "float",
            Ty::F64 => "double",
            Ty::Char => "char",
        }
    }

    fn leaf(self) -> Leaf {
        match self {
            Ty::U8 => Leaf::U8,
            Ty::I8 => Leaf::I8,
            Ty::U16 => Leaf::U16,
            Ty::I16 => Leaf::I16,
            Ty::U32 => Leaf::U32,
            Ty::I32 => Leaf::I32,
            Ty::U64 => Leaf::U64,
            Ty::I64 => Leaf::I64,
            Ty::F32 => Leaf::F32,
            Ty::F64 => Leaf::F64,
            Ty::Char => Leaf::Text,
        }
    }

    /// One scalar from `b` (at least `size()` bytes, little-endian as MAVLink is).
    fn decode(self, b: &[u8]) -> Value {
        let mut a = [0u8; 8];
        a[..self.size()].copy_from_slice(&b[..self.size()]);
        let u = u64::from_le_bytes(a);
        match self {
            Ty::U8 | Ty::U16 | Ty::U32 | Ty::U64 | Ty::Char => Value::UInt(u),
            Ty::I8 => Value::Int(u as u8 as i8 as i64),
            Ty::I16 => Value::Int(u as u16 as i16 as i64),
            Ty::I32 => Value::Int(u as u32 as i32 as i64),
            Ty::I64 => Value::Int(u as i64),
            Ty::F32 => Value::Float(f32::from_bits(u as u32) as f64),
            Ty::F64 => Value::Float(f64::from_bits(u)),
        }
    }
}

/// One message's layout: each field's offset (in XML order), lengths, schema.
#[derive(Debug)]
pub(crate) struct Layout {
    pub def: &'static MsgDef,
    pub offsets: Vec<usize>,
    /// The payload length with and without the extension fields.
    pub full_len: usize,
    pub base_len: usize,
    pub schema: Schema,
}

fn field_size(f: &FieldDef) -> usize {
    f.ty.size() * (f.len.max(1) as usize)
}

/// The fields' indices (into `def.fields`) in wire order.
fn wire_order(def: &MsgDef) -> Vec<usize> {
    let mut base: Vec<usize> = (0..def.fields.len())
        .filter(|&i| !def.fields[i].ext)
        .collect();
    base.sort_by_key(|&i| std::cmp::Reverse(def.fields[i].ty.size()));
    base.extend((0..def.fields.len()).filter(|&i| def.fields[i].ext));
    base
}

impl Layout {
    fn new(def: &'static MsgDef) -> Layout {
        let mut offsets = vec![0; def.fields.len()];
        let (mut at, mut base_len) = (0, 0);
        for i in wire_order(def) {
            offsets[i] = at;
            at += field_size(&def.fields[i]);
            if !def.fields[i].ext {
                base_len = at;
            }
        }
        let fields = (def.fields.iter())
            .map(|f| Field {
                name: f.name.to_string(),
                kind: match (f.ty, f.len) {
                    (Ty::Char, _) | (_, 0) => Kind::Leaf(f.ty.leaf()),
                    (t, n) => Kind::Array(Box::new(Kind::Leaf(t.leaf())), Some(n as usize)),
                },
            })
            .collect();
        Layout {
            def,
            offsets,
            full_len: at,
            base_len,
            schema: Schema { fields },
        }
    }

    /// Decodes a payload; a short one (MAVLink 2 truncation, MAVLink 1 without extensions)
    /// reads as if padded with zeros.
    pub(crate) fn decode(&self, payload: &[u8]) -> Value {
        let mut buf = [0u8; 256];
        let n = payload.len().min(self.full_len);
        buf[..n].copy_from_slice(&payload[..n]);
        let fields = self.def.fields.iter().zip(&self.offsets);
        Value::Struct(fields.map(|(f, &o)| decode_field(f, &buf[o..])).collect())
    }
}

fn decode_field(f: &FieldDef, b: &[u8]) -> Value {
    match (f.ty, f.len) {
        (Ty::Char, n) => Value::Text(crate::dataflash::text(&b[..n.max(1) as usize])),
        (t, 0) => t.decode(b),
        (t, n) => Value::Array(
            (0..n as usize)
                .map(|k| t.decode(&b[k * t.size()..]))
                .collect(),
        ),
    }
}

/// The compiled-in messages by id.
#[derive(Debug)]
pub(crate) struct Catalog {
    pub layouts: Vec<Layout>,
    by_id: HashMap<u32, usize>,
}

impl Catalog {
    pub(crate) fn new() -> Catalog {
        let layouts: Vec<Layout> = MESSAGES.iter().map(Layout::new).collect();
        let by_id = (layouts.iter().enumerate())
            .map(|(i, l)| (l.def.id, i))
            .collect();
        Catalog { layouts, by_id }
    }

    pub(crate) fn get(&self, id: u32) -> Option<&Layout> {
        self.by_id.get(&id).map(|&i| &self.layouts[i])
    }

    pub(crate) fn by_name(&self, name: &str) -> Option<&Layout> {
        self.layouts.iter().find(|l| l.def.name == name)
    }
}

/// The MAVLink checksum: CRC-16/MCRF4XX ("X.25"), `crc_accumulate` in `checksum.h`.
pub(crate) fn crc(bytes: &[u8], init: u16) -> u16 {
    bytes.iter().fold(init, |crc, &b| {
        let mut t = b ^ (crc & 0xff) as u8;
        t ^= t << 4;
        let t = t as u16;
        (crc >> 8) ^ (t << 8) ^ (t << 3) ^ (t >> 4)
    })
}

/// CRC_EXTRA as mavgen computes it: the checksum of the message name and each base field's
/// type, name and array length in wire order, folded to one byte. The table carries the
/// published values; this recomputes them to check the table.
#[cfg(test)]
fn crc_extra(def: &MsgDef) -> u8 {
    let mut c = crc(format!("{} ", def.name).as_bytes(), 0xffff);
    for i in wire_order(def).into_iter().filter(|&i| !def.fields[i].ext) {
        let f = &def.fields[i];
        c = crc(format!("{} {} ", f.ty.c_name(), f.name).as_bytes(), c);
        if f.len > 0 {
            c = crc(&[f.len], c);
        }
    }
    ((c & 0xff) ^ (c >> 8)) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_extras_match_the_published_ones() {
        assert_eq!(MESSAGES.len(), 21);
        for def in MESSAGES {
            assert_eq!(crc_extra(def), def.crc_extra, "{}", def.name);
        }
    }

    #[test]
    fn servo_output_raw_wire_order() {
        let c = Catalog::new();
        let l = c.get(36).unwrap();
        // time_usec u32 first, servo1..8 u16, then port u8, then the extensions.
        assert_eq!(&l.offsets[..4], &[0, 20, 4, 6]);
        assert_eq!((l.base_len, l.full_len), (21, 37));
    }

    #[test]
    fn x25_check_value() {
        // The CRC-16/MCRF4XX check value of "123456789".
        assert_eq!(crc(b"123456789", 0xffff), 0x6f91);
    }
}
