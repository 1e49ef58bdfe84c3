//! A ULog message format (`F` record, `name:type field;type field;...`) compiled into the plan
//! that decodes its bytes: fields packed in order with no alignment, fixed arrays
//! (`float[4]`), nested formats by name, `_padding` fields stepped over.
//!
//! Source: PX4's "ULog File Format" (docs.px4.io, `dev_log/ulog_file_format`) and pyulog's
//! `core.py` (which a test checks the reader against).

use crate::value::{Field, Kind, Leaf, Schema, Value};
use std::collections::HashMap;

/// How one field's bytes are read.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Plan {
    Leaf(Leaf),
    /// `char[n]`: text, NUL-terminated or not.
    Text(usize),
    Array(Box<Plan>, usize),
    /// A nested format: its name and its fields (`None` for padding, read past, not shown).
    Struct(String, Vec<(Option<String>, Plan)>),
}

/// Nested formats deeper than this are refused (a format naming itself).
const MAX_DEPTH: usize = 16;

impl Plan {
    pub(crate) fn size(&self) -> usize {
        match self {
            Plan::Leaf(l) => leaf_size(*l),
            Plan::Text(n) => *n,
            Plan::Array(p, n) => p.size().saturating_mul(*n),
            Plan::Struct(_, fields) => {
                (fields.iter()).fold(0, |a, (_, p)| a.saturating_add(p.size()))
            }
        }
    }

    /// The bytes of trailing padding, which the logger does not write.
    pub(crate) fn trailing_padding(&self) -> usize {
        let Plan::Struct(_, fields) = self else {
            return 0;
        };
        (fields.iter().rev())
            .take_while(|(name, _)| name.is_none())
            .map(|(_, p)| p.size())
            .sum()
    }

    pub(crate) fn schema(&self) -> Schema {
        let Plan::Struct(_, fields) = self else {
            return Schema::default();
        };
        let fields = (fields.iter())
            .filter_map(|(name, p)| {
                let name = name.clone()?;
                Some(Field {
                    name,
                    kind: p.kind(),
                })
            })
            .collect();
        Schema { fields }
    }

    fn kind(&self) -> Kind {
        match self {
            Plan::Leaf(l) => Kind::Leaf(*l),
            Plan::Text(_) => Kind::Leaf(Leaf::Text),
            Plan::Array(p, n) => Kind::Array(Box::new(p.kind()), Some(*n)),
            Plan::Struct(name, _) => Kind::Struct(name.clone(), self.schema()),
        }
    }

    /// The value of bytes `b`, which hold at least [`Plan::size`] bytes.
    pub(crate) fn decode(&self, b: &[u8]) -> Value {
        match self {
            Plan::Leaf(l) => leaf(*l, b),
            Plan::Text(n) => {
                let s = &b[..*n];
                let end = s.iter().position(|&c| c == 0).unwrap_or(s.len());
                Value::Text(String::from_utf8_lossy(&s[..end]).into_owned())
            }
            Plan::Array(p, n) => {
                let size = p.size();
                Value::Array((0..*n).map(|i| p.decode(&b[i * size..])).collect())
            }
            Plan::Struct(_, fields) => {
                let mut at = 0;
                let mut out = Vec::with_capacity(fields.len());
                for (name, p) in fields {
                    if name.is_some() {
                        out.push(p.decode(&b[at..]));
                    }
                    at += p.size();
                }
                Value::Struct(out)
            }
        }
    }

    /// The byte offset of top-level field `name` when it is a `uint64_t` (the `timestamp`).
    pub(crate) fn u64_field(&self, name: &str) -> Option<usize> {
        let Plan::Struct(_, fields) = self else {
            return None;
        };
        let mut at = 0;
        for (n, p) in fields {
            if n.as_deref() == Some(name) {
                return (*p == Plan::Leaf(Leaf::U64)).then_some(at);
            }
            at += p.size();
        }
        None
    }
}

fn leaf_size(l: Leaf) -> usize {
    match l {
        Leaf::Bool | Leaf::I8 | Leaf::U8 => 1,
        Leaf::I16 | Leaf::U16 => 2,
        Leaf::I32 | Leaf::U32 | Leaf::F32 => 4,
        _ => 8,
    }
}

fn leaf(l: Leaf, b: &[u8]) -> Value {
    let n = |k: usize| {
        let mut a = [0u8; 8];
        a[..k].copy_from_slice(&b[..k]);
        u64::from_le_bytes(a)
    };
    match l {
        Leaf::Bool => Value::Bool(b[0] != 0),
        Leaf::I8 => Value::Int(b[0] as i8 as i64),
        Leaf::I16 => Value::Int(n(2) as u16 as i16 as i64),
        Leaf::I32 => Value::Int(n(4) as u32 as i32 as i64),
        Leaf::I64 => Value::Int(n(8) as i64),
        Leaf::F32 => Value::Float(f32::from_bits(n(4) as u32) as f64),
        Leaf::F64 => Value::Float(f64::from_bits(n(8))),
        _ => Value::UInt(n(leaf_size(l))),
    }
}

/// The C type names ULog uses.
fn leaf_of(ty: &str) -> Option<Leaf> {
    Some(match ty {
        "int8_t" => Leaf::I8,
        "uint8_t" => Leaf::U8,
        "int16_t" => Leaf::I16,
        "uint16_t" => Leaf::U16,
        "int32_t" => Leaf::I32,
        "uint32_t" => Leaf::U32,
        "int64_t" => Leaf::I64,
        "uint64_t" => Leaf::U64,
        "float" => Leaf::F32,
        "double" => Leaf::F64,
        "bool" => Leaf::Bool,
        _ => return None,
    })
}

/// An `F` record's text split into its name and its `(type, field)` pairs.
pub(crate) fn parse(text: &str) -> Result<(String, Vec<(String, String)>), String> {
    let (name, rest) = text
        .split_once(':')
        .ok_or_else(|| format!("format `{text}` has no `:` after its name"))?;
    let fields = (rest.split(';'))
        .map(str::trim)
        .filter(|f| !f.is_empty())
        .map(|f| {
            let (ty, field) = (f.rsplit_once(' '))
                .ok_or_else(|| format!("format `{name}`: field `{f}` has no type"))?;
            Ok((ty.trim().to_string(), field.trim().to_string()))
        })
        .collect::<Result<Vec<_>, String>>()?;
    Ok((name.trim().to_string(), fields))
}

/// The plan of format `name` among `formats` (name -> fields), nested formats resolved. A
/// format larger than a record can hold is refused (a damaged array length).
pub(crate) fn compile(
    name: &str,
    formats: &HashMap<String, Vec<(String, String)>>,
) -> Result<Plan, String> {
    let plan = compile_at(name, formats, 0)?;
    match plan.size() {
        n if n > u16::MAX as usize => Err(format!(
            "format `{name}` is {n} bytes, more than a record holds"
        )),
        _ => Ok(plan),
    }
}

fn compile_at(
    name: &str,
    formats: &HashMap<String, Vec<(String, String)>>,
    depth: usize,
) -> Result<Plan, String> {
    if depth > MAX_DEPTH {
        return Err(format!("format `{name}` nests deeper than {MAX_DEPTH}"));
    }
    let fields = formats
        .get(name)
        .ok_or_else(|| format!("no format `{name}` is defined"))?;
    let mut out = Vec::with_capacity(fields.len());
    for (ty, field) in fields {
        let (base, len) = match ty.split_once('[') {
            Some((b, n)) => {
                let n: usize = (n.strip_suffix(']').and_then(|n| n.parse().ok()))
                    .ok_or_else(|| format!("format `{name}`: `{ty}` is not a type"))?;
                (b, Some(n))
            }
            None => (ty.as_str(), None),
        };
        let one = match (base, leaf_of(base)) {
            ("char", _) => Plan::Text(len.unwrap_or(1)),
            (_, Some(l)) => Plan::Leaf(l),
            _ => compile_at(base, formats, depth + 1)?,
        };
        let plan = match (base, len) {
            ("char", _) | (_, None) => one,
            (_, Some(n)) => Plan::Array(Box::new(one), n),
        };
        let shown = (!field.starts_with("_padding")).then(|| field.clone());
        out.push((shown, plan));
    }
    Ok(Plan::Struct(name.to_string(), out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_nested_format_with_arrays_and_padding_decodes() {
        let mut formats = HashMap::new();
        for text in [
            "esc_report:uint32_t esc_rpm;float esc_voltage;",
            "esc_status:uint64_t timestamp;uint8_t esc_count;uint8_t[3] _padding0;esc_report[2] esc;char[4] name;uint8_t[4] _padding1;",
        ] {
            let (n, f) = parse(text).unwrap();
            formats.insert(n, f);
        }
        let plan = compile("esc_status", &formats).unwrap();
        assert_eq!(plan.size(), 8 + 1 + 3 + 2 * 8 + 4 + 4);
        assert_eq!(plan.trailing_padding(), 4);
        assert_eq!(plan.u64_field("timestamp"), Some(0));
        let mut b = 1_500_000u64.to_le_bytes().to_vec();
        b.extend([2, 9, 9, 9]);
        for (rpm, v) in [(1200u32, 15.5f32), (1300, 15.25)] {
            b.extend(rpm.to_le_bytes());
            b.extend(v.to_le_bytes());
        }
        b.extend(b"ab\0\0");
        b.extend([0; 4]);
        let Value::Struct(v) = plan.decode(&b) else {
            panic!()
        };
        assert_eq!(v.len(), 4, "padding is not a field");
        assert_eq!(v[0], Value::UInt(1_500_000));
        assert_eq!(v[1], Value::UInt(2));
        let Value::Array(esc) = &v[2] else { panic!() };
        assert_eq!(
            esc[1],
            Value::Struct(vec![Value::UInt(1300), Value::Float(15.25)])
        );
        assert_eq!(v[3], Value::Text("ab".into()));
        let schema = plan.schema();
        assert!(schema.select("esc[1].esc_voltage").is_ok());
        assert!(schema.select("_padding0").is_err());
    }

    #[test]
    fn bad_formats_are_said() {
        assert!(parse("no colon").unwrap_err().contains("no `:`"));
        let mut formats = HashMap::new();
        let (n, f) = parse("loop:loop inner;").unwrap();
        formats.insert(n, f);
        assert!(compile("loop", &formats).unwrap_err().contains("deeper"));
        let (n, f) = parse("a:float[x] y;").unwrap();
        formats.insert(n, f);
        assert!(compile("a", &formats).unwrap_err().contains("not a type"));
        assert!(
            compile("b", &formats)
                .unwrap_err()
                .contains("no format `b`")
        );
        let (n, f) = parse("big:uint8_t[4000000000] _padding0;").unwrap();
        formats.insert(n, f);
        assert!(
            compile("big", &formats)
                .unwrap_err()
                .contains("more than a record")
        );
    }
}
