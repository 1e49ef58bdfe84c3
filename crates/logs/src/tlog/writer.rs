//! Writes `.tlog` files of the compiled-in messages, MAVLink 1 or 2, for tests, examples and
//! simulators.

use super::defs::{FieldDef, Ty};
use super::layout::{Catalog, Layout, crc};
use crate::dataflash::{ToField, int};
use crate::value::Value;

/// Builds a tlog in memory: one record per `write`, a sequence number per packet.
///
/// ```
/// use hydrofit_logs::tlog::Writer;
/// let mut w = Writer::new(true);
/// let t = 1_683_220_541_000_000; // µs since 1970
/// w.write(t, (1, 1), "ATTITUDE", &[1000.0, 0.1, -0.2, 3.0, 0.0, 0.0, 0.0]).unwrap();
/// assert_eq!(w.bytes()[8], 0xFD);
/// ```
pub struct Writer {
    buf: Vec<u8>,
    catalog: Catalog,
    seq: u8,
    /// MAVLink 2 packets (`FD`, payload zero-truncated) when true, MAVLink 1 (`FE`) else.
    pub mavlink2: bool,
}

impl Writer {
    pub fn new(mavlink2: bool) -> Writer {
        Writer {
            buf: Vec::new(),
            catalog: Catalog::new(),
            seq: 0,
            mavlink2,
        }
    }

    /// Writes message `name` from system/component `from`, received at `time_us` (µs since
    /// the Unix epoch), one value per field in the XML order (the topic's schema); trailing
    /// extension fields may be left out (sent as zero).
    pub fn write<V: ToField>(
        &mut self,
        time_us: u64,
        from: (u8, u8),
        name: &str,
        values: &[V],
    ) -> Result<(), String> {
        let layout = self
            .catalog
            .by_name(name)
            .ok_or(format!("`{name}` is not compiled in"))?;
        let payload = encode(layout, values).map_err(|e| format!("`{name}`: {e}"))?;
        let id = layout.def.id;
        let payload = self.trimmed(layout, &payload);
        let mut pkt = Vec::with_capacity(payload.len() + 12);
        if self.mavlink2 {
            let [a, b, c, _] = id.to_le_bytes();
            pkt.extend_from_slice(&[
                0xFD,
                payload.len() as u8,
                0,
                0,
                self.seq,
                from.0,
                from.1,
                a,
                b,
                c,
            ]);
        } else {
            let id = u8::try_from(id).map_err(|_| format!("`{name}` (id {id}) needs MAVLink 2"))?;
            pkt.extend_from_slice(&[0xFE, payload.len() as u8, self.seq, from.0, from.1, id]);
        }
        pkt.extend_from_slice(payload);
        let sum = crc(&[layout.def.crc_extra], crc(&pkt[1..], 0xffff));
        pkt.extend_from_slice(&sum.to_le_bytes());
        self.buf.extend_from_slice(&time_us.to_be_bytes());
        self.buf.extend_from_slice(&pkt);
        self.seq = self.seq.wrapping_add(1);
        Ok(())
    }

    /// MAVLink 1 sends the base fields only; MAVLink 2 drops trailing zeros but keeps at
    /// least one byte (serialization spec, "Empty-byte payload truncation").
    fn trimmed<'p>(&self, layout: &Layout, payload: &'p [u8]) -> &'p [u8] {
        if !self.mavlink2 {
            return &payload[..layout.base_len];
        }
        let n = payload.iter().rposition(|&b| b != 0).map_or(1, |i| i + 1);
        &payload[..n]
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
}

/// The full payload (extensions included) with each field at its wire offset.
fn encode<V: ToField>(layout: &Layout, values: &[V]) -> Result<Vec<u8>, String> {
    let fields = layout.def.fields;
    let base = fields.iter().filter(|f| !f.ext).count();
    if values.len() < base || values.len() > fields.len() {
        return Err(format!(
            "{} values for {base}..={} fields",
            values.len(),
            fields.len()
        ));
    }
    let mut out = vec![0u8; layout.full_len];
    for ((f, &off), v) in fields.iter().zip(&layout.offsets).zip(values) {
        put(f, &v.to_field(), &mut out[off..]).ok_or(format!(
            "{} does not fit `{}`",
            show(v),
            f.name
        ))?;
    }
    Ok(out)
}

fn show<V: ToField>(v: &V) -> String {
    format!("{:?}", v.to_field())
}

/// Writes one field (scalar, array or `char[n]` text) at the start of `out`.
fn put(f: &FieldDef, v: &Value, out: &mut [u8]) -> Option<()> {
    match (f.ty, f.len, v) {
        (Ty::Char, n, Value::Text(s)) if s.len() <= n.max(1) as usize => {
            out[..s.len()].copy_from_slice(s.as_bytes());
        }
        (t, n, Value::Array(items)) if n > 0 && items.len() <= n as usize => {
            for (k, item) in items.iter().enumerate() {
                scalar(t, item, &mut out[k * t.size()..])?;
            }
        }
        (t, 0, v) => scalar(t, v, out)?,
        _ => return None,
    }
    Some(())
}

fn scalar(t: Ty, v: &Value, out: &mut [u8]) -> Option<()> {
    let bytes: Vec<u8> = match t {
        Ty::U8 | Ty::Char => vec![int(v, 0, 255)? as u8],
        Ty::I8 => (int(v, -128, 127)? as i8).to_le_bytes().to_vec(),
        Ty::U16 => (int(v, 0, 65535)? as u16).to_le_bytes().to_vec(),
        Ty::I16 => (int(v, -32768, 32767)? as i16).to_le_bytes().to_vec(),
        Ty::U32 => (int(v, 0, u32::MAX as i128)? as u32).to_le_bytes().to_vec(),
        Ty::I32 => (int(v, i32::MIN as i128, i32::MAX as i128)? as i32)
            .to_le_bytes()
            .to_vec(),
        Ty::U64 => (int(v, 0, u64::MAX as i128)? as u64).to_le_bytes().to_vec(),
        Ty::I64 => (int(v, i64::MIN as i128, i64::MAX as i128)? as i64)
            .to_le_bytes()
            .to_vec(),
        Ty::F32 => (v.as_f64()? as f32).to_le_bytes().to_vec(),
        Ty::F64 => v.as_f64()?.to_le_bytes().to_vec(),
    };
    out[..bytes.len()].copy_from_slice(&bytes);
    Some(())
}
