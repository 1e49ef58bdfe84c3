//! Writes DataFlash logs (FMT, FMTU and messages) for tests, examples and simulators, laid
//! out as ArduPilot's `AP_Logger` writes them (`LogStructure.h`).

use super::format::{FMT_LEN, FMT_TYPE, HEAD, Ty};
use crate::value::Value;
use std::collections::HashMap;

/// A value a [`Writer`] can put in a field: numbers (in the field's units: `TimeUS` in µs,
/// a `c` field in its scaled unit, an `L` field in degrees), text, or a [`Value`].
pub trait ToField {
    fn to_field(&self) -> Value;
}

impl ToField for f64 {
    fn to_field(&self) -> Value {
        Value::Float(*self)
    }
}
impl ToField for i64 {
    fn to_field(&self) -> Value {
        Value::Int(*self)
    }
}
impl ToField for u64 {
    fn to_field(&self) -> Value {
        Value::UInt(*self)
    }
}
impl ToField for &str {
    fn to_field(&self) -> Value {
        Value::Text(self.to_string())
    }
}
impl ToField for Value {
    fn to_field(&self) -> Value {
        self.clone()
    }
}

struct Type {
    id: u8,
    fields: Vec<Ty>,
    timed: bool,
}

/// Builds a DataFlash log in memory: `define` a message type (writes its FMT record),
/// optionally `units` (writes its FMTU record, where `#` marks the instance field), then
/// `write` messages.
///
/// ```
/// use hydrofit_logs::dataflash::Writer;
/// let mut w = Writer::new();
/// w.define("ATT", "QccC", "TimeUS,Roll,Pitch,Yaw").unwrap();
/// w.write("ATT", &[1_000_000.0, 1.5, -2.25, 359.99]).unwrap();
/// let bytes = w.into_bytes();
/// assert_eq!(&bytes[..2], &[0xA3, 0x95]);
/// ```
pub struct Writer {
    buf: Vec<u8>,
    types: HashMap<String, Type>,
    used: [bool; 256],
    /// The last `TimeUS` written, given to FMTU records.
    clock_us: f64,
}

impl Default for Writer {
    fn default() -> Writer {
        Writer::new()
    }
}

impl Writer {
    /// A log that starts, as ArduPilot's do, with the FMT record describing FMT.
    pub fn new() -> Writer {
        let mut w = Writer {
            buf: Vec::new(),
            types: HashMap::new(),
            used: [false; 256],
            clock_us: 0.0,
        };
        w.used[FMT_TYPE as usize] = true;
        w.fmt_record(
            FMT_TYPE,
            FMT_LEN as u8,
            "FMT",
            "BBnNZ",
            "Type,Length,Name,Format,Columns",
        );
        w
    }

    /// Defines message type `name` (at most 4 characters) with `format` (format characters,
    /// at most 16) and comma-separated `labels`, writing its FMT record.
    pub fn define(&mut self, name: &str, format: &str, labels: &str) -> Result<(), String> {
        if name.is_empty() || name.len() > 4 || format.len() > 16 || labels.len() > 64 {
            return Err(format!("`{name}`: name, format or labels too long for FMT"));
        }
        if self.types.contains_key(name) {
            return Err(format!("`{name}` is already defined"));
        }
        let fields = (format.bytes())
            .map(|c| Ty::from_char(c).ok_or(format!("`{name}`: unknown format `{}`", c as char)))
            .collect::<Result<Vec<Ty>, String>>()?;
        if labels.split(',').count() != fields.len() {
            return Err(format!(
                "`{name}`: {} labels for {} fields",
                labels.split(',').count(),
                fields.len()
            ));
        }
        let len = 3 + fields.iter().map(|t| t.size()).sum::<usize>();
        let len = u8::try_from(len).map_err(|_| format!("`{name}`: {len} bytes, over 255"))?;
        // Types 129.. first, as ArduPilot numbers its own from 128 up; then the rest.
        let id = (129..=255u8)
            .chain(0..128)
            .find(|&i| !self.used[i as usize])
            .ok_or("all 255 message types are in use")?;
        self.used[id as usize] = true;
        self.fmt_record(id, len, name, format, labels);
        let timed = labels.starts_with("TimeUS,") || labels == "TimeUS";
        self.types
            .insert(name.to_string(), Type { id, fields, timed });
        Ok(())
    }

    /// Writes an FMTU record for `name`: one unit and one multiplier character per field
    /// (`-` for none); `#` as a unit marks the instance field.
    pub fn units(&mut self, name: &str, unit_ids: &str, mult_ids: &str) -> Result<(), String> {
        if !self.types.contains_key("FMTU") {
            self.define("FMTU", "QBNN", "TimeUS,FmtType,UnitIds,MultIds")?;
        }
        let id = self
            .types
            .get(name)
            .ok_or(format!("`{name}` is not defined"))?
            .id;
        let values = [
            Value::Float(self.clock_us),
            Value::UInt(id as u64),
            Value::Text(unit_ids.into()),
            Value::Text(mult_ids.into()),
        ];
        self.write("FMTU", &values)
    }

    /// Writes one message of type `name`, one value per field.
    pub fn write<V: ToField>(&mut self, name: &str, values: &[V]) -> Result<(), String> {
        let t = self
            .types
            .get(name)
            .ok_or(format!("`{name}` is not defined"))?;
        if values.len() != t.fields.len() {
            return Err(format!(
                "`{name}`: {} values for {} fields",
                values.len(),
                t.fields.len()
            ));
        }
        let start = self.buf.len();
        self.buf.extend_from_slice(&[HEAD[0], HEAD[1], t.id]);
        for (ty, v) in t.fields.iter().zip(values) {
            if let Err(e) = encode(*ty, &v.to_field(), &mut self.buf) {
                self.buf.truncate(start);
                return Err(format!("`{name}`: {e}"));
            }
        }
        if t.timed {
            self.clock_us = values[0].to_field().as_f64().unwrap_or(self.clock_us);
        }
        Ok(())
    }

    /// Appends bytes as they are (damage, for tests).
    pub fn raw(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    pub fn len(&self) -> usize {
        self.buf.len()
    }

    pub fn is_empty(&self) -> bool {
        self.buf.is_empty()
    }

    pub fn bytes(&self) -> &[u8] {
        &self.buf
    }

    pub fn into_bytes(self) -> Vec<u8> {
        self.buf
    }

    fn fmt_record(&mut self, id: u8, len: u8, name: &str, format: &str, labels: &str) {
        self.buf
            .extend_from_slice(&[HEAD[0], HEAD[1], FMT_TYPE, id, len]);
        for (s, n) in [(name, 4), (format, 16), (labels, 64)] {
            let b = &s.as_bytes()[..s.len().min(n)];
            self.buf.extend_from_slice(b);
            self.buf.resize(self.buf.len() + n - b.len(), 0);
        }
    }
}

/// Appends `v` as a field of type `ty`.
fn encode(ty: Ty, v: &Value, out: &mut Vec<u8>) -> Result<(), String> {
    match (ty, v) {
        (Ty::Text(n), Value::Text(s)) if s.len() <= n => {
            out.extend_from_slice(s.as_bytes());
            out.resize(out.len() + n - s.len(), 0);
        }
        (Ty::I16x32, Value::Array(items)) if items.len() <= 32 => {
            for i in 0..32 {
                let x = items
                    .get(i)
                    .map_or(Some(0), |v| int(v, i16::MIN as i128, i16::MAX as i128));
                let x = x.ok_or("an `a` element is not an int16")? as i16;
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        (Ty::Text(_) | Ty::I16x32, _) => return Err(format!("{v:?} does not fit a {ty:?} field")),
        _ => encode_number(ty, v, out).ok_or(format!("{v:?} does not fit a {ty:?} field"))?,
    }
    Ok(())
}

fn encode_number(ty: Ty, v: &Value, out: &mut Vec<u8>) -> Option<()> {
    let x = v.as_f64()?;
    // Scaled fields store round(value * scale), what `LogStructure.h`'s `* 100` means.
    let scaled = |s: f64| Value::Float((x * s).round());
    match ty {
        Ty::I8 => out.push(int(v, -128, 127)? as i8 as u8),
        Ty::U8 | Ty::Mode => out.push(int(v, 0, 255)? as u8),
        Ty::I16 => out.extend_from_slice(&(int(v, -32768, 32767)? as i16).to_le_bytes()),
        Ty::U16 => out.extend_from_slice(&(int(v, 0, 65535)? as u16).to_le_bytes()),
        Ty::I32 => out
            .extend_from_slice(&(int(v, i32::MIN as i128, i32::MAX as i128)? as i32).to_le_bytes()),
        Ty::U32 => out.extend_from_slice(&(int(v, 0, u32::MAX as i128)? as u32).to_le_bytes()),
        Ty::I64 => out
            .extend_from_slice(&(int(v, i64::MIN as i128, i64::MAX as i128)? as i64).to_le_bytes()),
        Ty::U64 => out.extend_from_slice(&(int(v, 0, u64::MAX as i128)? as u64).to_le_bytes()),
        Ty::F16 => out.extend_from_slice(&to_half(x as f32).to_le_bytes()),
        Ty::F32 => out.extend_from_slice(&(x as f32).to_le_bytes()),
        Ty::F64 => out.extend_from_slice(&x.to_le_bytes()),
        Ty::Cent16 => return encode_number(Ty::I16, &scaled(100.0), out),
        Ty::UCent16 => return encode_number(Ty::U16, &scaled(100.0), out),
        Ty::Cent32 => return encode_number(Ty::I32, &scaled(100.0), out),
        Ty::UCent32 => return encode_number(Ty::U32, &scaled(100.0), out),
        Ty::LatLon => return encode_number(Ty::I32, &scaled(1e7), out),
        Ty::Text(_) | Ty::I16x32 => return None,
    }
    Some(())
}

/// `v` as an integer in `lo..=hi`: exact for integer values, rounded for floats.
pub(crate) fn int(v: &Value, lo: i128, hi: i128) -> Option<i128> {
    let i = match *v {
        Value::Int(i) => i as i128,
        Value::UInt(u) => u as i128,
        Value::Bool(b) => b as i128,
        Value::Float(x) if x.is_finite() => x.round() as i128,
        _ => return None,
    };
    (lo..=hi).contains(&i).then_some(i)
}

/// f32 to IEEE binary16, rounding to nearest.
fn to_half(x: f32) -> u16 {
    let sign = ((x.to_bits() >> 16) & 0x8000) as u16;
    let a = x.abs();
    if x.is_nan() {
        return sign | 0x7e00;
    }
    if a >= 65520.0 {
        return sign | 0x7c00;
    }
    if a < 6.103_515_6e-5 {
        // Subnormal: a multiple of 2^-24 (a rounded 1024 is the smallest normal, 0x0400).
        return sign | (a / 5.960_464_5e-8).round() as u16;
    }
    let mut exp = ((a.to_bits() >> 23) & 0xff) as i32 - 127;
    let mut m = ((a / 2f32.powi(exp) - 1.0) * 1024.0).round() as u16;
    if m == 1024 {
        exp += 1;
        m = 0;
    }
    sign | (((exp + 15) as u16) << 10) | m
}
