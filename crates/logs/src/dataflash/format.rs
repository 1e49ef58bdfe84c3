//! DataFlash format characters and FMT definitions: how one message type's bytes are laid out.
//!
//! Sources: ArduPilot `libraries/AP_Logger/LogStructure.h` (the format characters and the
//! `log_Format`/`log_Format_Units` records) and pymavlink `DFReader.py` (`FORMAT_TO_STRUCT`:
//! which characters are scaled, `g` as a half float, text decoding).

use crate::value::{Field, Kind, Leaf, Schema, Value};

/// The record type of FMT itself, fixed by `LogStructure.h` (`LOG_FORMAT_MSG = 128`).
pub(crate) const FMT_TYPE: u8 = 128;
/// A FMT record's whole length: header 3 + type 1 + length 1 + name 4 + format 16 + labels 64.
pub(crate) const FMT_LEN: usize = 89;
/// The first two bytes of every record (`HEAD_BYTE1`, `HEAD_BYTE2` in `LogStructure.h`).
pub(crate) const HEAD: [u8; 2] = [0xA3, 0x95];

/// One format character.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    /// `g`: IEEE half float (pymavlink `"g": ("e", ...)`).
    F16,
    F32,
    F64,
    /// `n`, `N`, `Z`: NUL-padded text of 4, 16 or 64 bytes.
    Text(usize),
    /// `c` int16 * 100, `C` uint16 * 100, `e` int32 * 100, `E` uint32 * 100: read / 100.
    Cent16,
    UCent16,
    Cent32,
    UCent32,
    /// `L`: int32 latitude or longitude in 1e-7 degrees: read / 1e7.
    LatLon,
    /// `M`: flight mode, uint8 (`LogStructure.h`; pymavlink reads it signed, same for modes < 128).
    Mode,
    /// `a`: int16[32].
    I16x32,
}

impl Ty {
    pub(crate) fn from_char(c: u8) -> Option<Ty> {
        Some(match c {
            b'b' => Ty::I8,
            b'B' => Ty::U8,
            b'h' => Ty::I16,
            b'H' => Ty::U16,
            b'i' => Ty::I32,
            b'I' => Ty::U32,
            b'q' => Ty::I64,
            b'Q' => Ty::U64,
            b'g' => Ty::F16,
            b'f' => Ty::F32,
            b'd' => Ty::F64,
            b'n' => Ty::Text(4),
            b'N' => Ty::Text(16),
            b'Z' => Ty::Text(64),
            b'c' => Ty::Cent16,
            b'C' => Ty::UCent16,
            b'e' => Ty::Cent32,
            b'E' => Ty::UCent32,
            b'L' => Ty::LatLon,
            b'M' => Ty::Mode,
            b'a' => Ty::I16x32,
            _ => return None,
        })
    }

    pub(crate) fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 | Ty::Mode => 1,
            Ty::I16 | Ty::U16 | Ty::F16 | Ty::Cent16 | Ty::UCent16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 | Ty::Cent32 | Ty::UCent32 | Ty::LatLon => 4,
            Ty::I64 | Ty::U64 | Ty::F64 => 8,
            Ty::Text(n) => n,
            Ty::I16x32 => 64,
        }
    }

    /// The field's kind in the schema: scaled integers are read as float64 in their units.
    pub(crate) fn kind(self) -> Kind {
        Kind::Leaf(match self {
            Ty::I8 => Leaf::I8,
            Ty::U8 | Ty::Mode => Leaf::U8,
            Ty::I16 => Leaf::I16,
            Ty::U16 => Leaf::U16,
            Ty::I32 => Leaf::I32,
            Ty::U32 => Leaf::U32,
            Ty::I64 => Leaf::I64,
            Ty::U64 => Leaf::U64,
            Ty::F16 | Ty::F32 => Leaf::F32,
            Ty::F64 | Ty::Cent16 | Ty::UCent16 | Ty::Cent32 | Ty::UCent32 | Ty::LatLon => Leaf::F64,
            Ty::Text(_) => Leaf::Text,
            Ty::I16x32 => return Kind::Array(Box::new(Kind::Leaf(Leaf::I16)), Some(32)),
        })
    }

    /// Decodes the field from `b`, which holds at least `size()` bytes (little-endian, as
    /// ArduPilot's packed structs are on every board it runs on).
    pub(crate) fn decode(self, b: &[u8]) -> Value {
        if let Ty::Text(n) = self {
            return Value::Text(text(&b[..n]));
        }
        if self == Ty::I16x32 {
            let items = b[..64].chunks_exact(2);
            return Value::Array(items.map(|c| Value::Int(le_i16(c) as i64)).collect());
        }
        match self.number(b) {
            Num::Int(i) => Value::Int(i),
            Num::UInt(u) => Value::UInt(u),
            Num::Float(x) => Value::Float(x),
        }
    }

    /// The field as a number (time and instance fields are read this way).
    pub(crate) fn number(self, b: &[u8]) -> Num {
        // Dividing by 100 and 1e7 rather than multiplying by 0.01 and 1e-7 gives the closest
        // double, as pymavlink does (`DFMessage.__getattr__`).
        match self {
            Ty::I8 => Num::Int(b[0] as i8 as i64),
            Ty::U8 | Ty::Mode => Num::UInt(b[0] as u64),
            Ty::I16 => Num::Int(le_i16(b) as i64),
            Ty::U16 => Num::UInt(le_u16(b) as u64),
            Ty::I32 => Num::Int(le_i32(b) as i64),
            Ty::U32 => Num::UInt(le_u32(b) as u64),
            Ty::I64 => Num::Int(le_u64(b) as i64),
            Ty::U64 => Num::UInt(le_u64(b)),
            Ty::F16 => Num::Float(half(le_u16(b)) as f64),
            Ty::F32 => Num::Float(f32::from_bits(le_u32(b)) as f64),
            Ty::F64 => Num::Float(f64::from_bits(le_u64(b))),
            Ty::Cent16 => Num::Float(le_i16(b) as f64 / 100.0),
            Ty::UCent16 => Num::Float(le_u16(b) as f64 / 100.0),
            Ty::Cent32 => Num::Float(le_i32(b) as f64 / 100.0),
            Ty::UCent32 => Num::Float(le_u32(b) as f64 / 100.0),
            Ty::LatLon => Num::Float(le_i32(b) as f64 / 1e7),
            Ty::Text(_) | Ty::I16x32 => Num::Float(f64::NAN),
        }
    }
}

/// A decoded number, before it becomes a [`Value`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Num {
    Int(i64),
    UInt(u64),
    Float(f64),
}

impl Num {
    pub(crate) fn as_f64(self) -> f64 {
        match self {
            Num::Int(i) => i as f64,
            Num::UInt(u) => u as f64,
            Num::Float(x) => x,
        }
    }
}

fn le_i16(b: &[u8]) -> i16 {
    i16::from_le_bytes([b[0], b[1]])
}
fn le_u16(b: &[u8]) -> u16 {
    u16::from_le_bytes([b[0], b[1]])
}
fn le_i32(b: &[u8]) -> i32 {
    le_u32(b) as i32
}
fn le_u32(b: &[u8]) -> u32 {
    u32::from_le_bytes([b[0], b[1], b[2], b[3]])
}
fn le_u64(b: &[u8]) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[..8]);
    u64::from_le_bytes(a)
}

/// IEEE 754 binary16 to f32.
fn half(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = ((h >> 10) & 0x1f) as i32;
    let frac = (h & 0x3ff) as f32;
    match exp {
        0 => sign * frac * (2.0f32).powi(-24),
        31 if frac == 0.0 => sign * f32::INFINITY,
        31 => f32::NAN,
        _ => sign * (1.0 + frac / 1024.0) * (2.0f32).powi(exp - 15),
    }
}

/// NUL-terminated text: UTF-8 where it is, else Latin-1 (pymavlink's fallback).
pub(crate) fn text(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    let b = &b[..end];
    match std::str::from_utf8(b) {
        Ok(s) => s.to_string(),
        Err(_) => b.iter().map(|&c| c as char).collect(),
    }
}

/// Where a message type keeps its time, and in what unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TimeField {
    pub field: usize,
    /// Counts per second: 1e6 for `TimeUS`, 1e3 for `TimeMS`.
    pub per_s: f64,
}

/// One message type as a FMT record defines it.
#[derive(Debug, Clone)]
pub(crate) struct Def {
    pub type_id: u8,
    pub name: String,
    /// The whole record's length, header included (FMT `Length`).
    pub len: usize,
    pub format: String,
    pub labels: String,
    /// Each field's type and offset in the payload (after the 3 header bytes).
    pub fields: Vec<(Ty, usize)>,
    pub schema: Schema,
    pub time: Option<TimeField>,
    /// The field FMTU marks as the instance (unit `#`): messages split into `NAME[i]` topics.
    pub instance: Option<usize>,
    /// Why the messages cannot be decoded (unknown format character, fields longer than the
    /// record); `None` when they can. Such a type still frames records by its length.
    pub broken: Option<String>,
}

impl Def {
    /// The definition of FMT itself, known before any record is read.
    pub(crate) fn fmt() -> Def {
        Def::new(
            FMT_TYPE,
            "FMT",
            FMT_LEN,
            "BBnNZ",
            "Type,Length,Name,Format,Columns",
        )
    }

    pub(crate) fn new(type_id: u8, name: &str, len: usize, format: &str, labels: &str) -> Def {
        let mut def = Def {
            type_id,
            name: name.to_string(),
            len,
            format: format.to_string(),
            labels: labels.to_string(),
            fields: Vec::new(),
            schema: Schema::default(),
            time: None,
            instance: None,
            broken: None,
        };
        def.layout();
        def
    }

    /// Works out offsets, the schema and the time field from the format and labels.
    fn layout(&mut self) {
        let labels: Vec<&str> = self.labels.split(',').collect();
        let mut offset = 0;
        for (i, c) in self.format.bytes().enumerate() {
            let Some(ty) = Ty::from_char(c) else {
                self.broken = Some(format!("format character `{}` is unknown", c as char));
                return;
            };
            let name = match labels.get(i) {
                Some(l) if !l.is_empty() => l.to_string(),
                _ => format!("field{i}"),
            };
            self.fields.push((ty, offset));
            self.schema.fields.push(Field {
                name,
                kind: ty.kind(),
            });
            offset += ty.size();
        }
        if offset + 3 > self.len {
            self.broken = Some(format!(
                "its fields take {} bytes but FMT gives the record {} (with the 3-byte header)",
                offset + 3,
                self.len
            ));
        }
        self.time = self.find_time();
    }

    /// `TimeUS` (µs since boot), or in older logs `TimeMS`, as the first field, as pymavlink's
    /// clocks read them (`DFReaderClock_usec/_msec.set_message_timestamp`); old `GPS` records
    /// keep their boot time in `T` (ms) instead.
    fn find_time(&self) -> Option<TimeField> {
        let named = |n: &str| self.schema.fields.iter().position(|f| f.name == n);
        let numeric = |i: usize| !matches!(self.fields[i].0, Ty::Text(_) | Ty::I16x32);
        let pick = if self
            .schema
            .fields
            .first()
            .is_some_and(|f| f.name == "TimeMS")
        {
            Some((0, 1e3))
        } else if let Some(i) = named("TimeUS") {
            Some((i, 1e6))
        } else if self.name.starts_with("GPS") {
            named("T").map(|i| (i, 1e3))
        } else {
            None
        };
        pick.filter(|&(i, _)| numeric(i))
            .map(|(field, per_s)| TimeField { field, per_s })
    }

    /// The bytes of field `i` in `body` (the payload); `body` is at least `len - 3` long.
    pub(crate) fn field_bytes<'a>(&self, body: &'a [u8], i: usize) -> &'a [u8] {
        let (ty, off) = self.fields[i];
        &body[off..off + ty.size()]
    }

    /// The message's time in seconds, if its type has a time field.
    pub(crate) fn time_s(&self, body: &[u8]) -> Option<f64> {
        let t = self.time?;
        let (ty, _) = self.fields[t.field];
        Some(ty.number(self.field_bytes(body, t.field)).as_f64() / t.per_s)
    }

    /// Decodes a whole message; `body` is at least `len - 3` bytes and `broken` is `None`.
    pub(crate) fn decode(&self, body: &[u8]) -> Value {
        Value::Struct(
            self.fields
                .iter()
                .map(|&(ty, off)| ty.decode(&body[off..off + ty.size()]))
                .collect(),
        )
    }

    /// How the instance value is shown in a topic name (`IMU[0]`), as pymavlink's
    /// `"%s[%s]" % (type, value)` shows it.
    pub(crate) fn instance_label(&self, raw: &[u8]) -> String {
        let Some(i) = self.instance else {
            return String::new();
        };
        match self.fields[i].0.decode(raw) {
            Value::Int(v) => v.to_string(),
            Value::UInt(v) => v.to_string(),
            Value::Float(v) => v.to_string(),
            Value::Text(s) => s,
            _ => "?".to_string(),
        }
    }
}

/// A FMT record's payload read into (type, length, name, format, labels).
pub(crate) fn parse_fmt(body: &[u8]) -> Option<(u8, usize, String, String, String)> {
    if body.len() < FMT_LEN - 3 {
        return None;
    }
    Some((
        body[0],
        body[1] as usize,
        text(&body[2..6]),
        text(&body[6..22]),
        text(&body[22..86]),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_floats() {
        assert_eq!(half(0x3c00), 1.0);
        assert_eq!(half(0xc000), -2.0);
        assert_eq!(half(0x3555), 0.333_251_95);
        assert_eq!(half(0x0001), 5.960_464_5e-8);
        assert!(half(0x7e00).is_nan());
    }

    #[test]
    fn scaled_fields_divide() {
        let b = (-1234i16).to_le_bytes();
        assert_eq!(Ty::Cent16.decode(&b), Value::Float(-12.34));
        let b = 473_977_420i32.to_le_bytes();
        assert_eq!(Ty::LatLon.decode(&b), Value::Float(47.397_742));
    }

    #[test]
    fn layout_and_time() {
        let d = Def::new(
            1,
            "ATT",
            28,
            "QccccCCCCB",
            "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw,AEKF",
        );
        assert!(d.broken.is_none());
        assert_eq!(
            d.time,
            Some(TimeField {
                field: 0,
                per_s: 1e6
            })
        );
        assert_eq!(d.fields[9], (Ty::U8, 24));
        let d = Def::new(2, "X", 10, "Qz", "TimeUS,A");
        assert!(d.broken.unwrap().contains("`z`"));
        let d = Def::new(3, "Y", 10, "QQ", "TimeUS,A");
        assert!(d.broken.unwrap().contains("19 bytes"));
        let d = Def::new(4, "OLD", 9, "IhB", "TimeMS,A");
        assert_eq!(
            d.time,
            Some(TimeField {
                field: 0,
                per_s: 1e3
            })
        );
        assert_eq!(d.schema.fields[2].name, "field2");
    }

    #[test]
    fn text_falls_back_to_latin1() {
        assert_eq!(text(b"ab\0cd"), "ab");
        assert_eq!(text(&[0x41, 0xe9, 0]), "A\u{e9}");
    }
}
