//! [`Value`]s to message bytes (ROS 1 serialization, little-endian CDR), for the writers: the
//! inverse of [`crate::wire`], with the same layout rules.

use crate::value::{Kind, Leaf, Schema, Value};
use crate::wire::{Wire, WireError, split_time};

/// Encodes `value`, laid out as `schema`, in ROS 1 serialization.
pub(crate) fn ros1(schema: &Schema, value: &Value) -> Result<Vec<u8>, WireError> {
    let mut w = Out {
        buf: Vec::with_capacity(256),
        start: 0,
        wire: Wire::Ros1,
    };
    w.fields(schema, value)?;
    Ok(w.buf)
}

/// Encodes `value` as little-endian CDR with its encapsulation header (`00 01 00 00`).
pub(crate) fn cdr(schema: &Schema, value: &Value) -> Result<Vec<u8>, WireError> {
    let mut w = Out {
        buf: Vec::with_capacity(256),
        start: 4,
        wire: Wire::Cdr { big: false },
    };
    w.buf.extend([0, 1, 0, 0]);
    w.fields(schema, value)?;
    Ok(w.buf)
}

fn fail<T>(what: String) -> Result<T, WireError> {
    Err(WireError {
        path: String::new(),
        what,
    })
}

fn within(step: String) -> impl FnOnce(WireError) -> WireError {
    move |mut e| {
        e.path = match (e.path.is_empty(), e.path.starts_with('[')) {
            (true, _) => step,
            (false, true) => format!("{step}{}", e.path),
            (false, false) => format!("{step}.{}", e.path),
        };
        e
    }
}

struct Out {
    buf: Vec<u8>,
    /// Where CDR alignment is counted from (after the encapsulation header).
    start: usize,
    wire: Wire,
}

impl Out {
    fn put(&mut self, bytes: &[u8]) {
        if let Wire::Cdr { .. } = self.wire {
            let n = bytes.len();
            let pad = (n - (self.buf.len() - self.start) % n) % n;
            self.buf.extend(std::iter::repeat_n(0, pad));
        }
        self.buf.extend_from_slice(bytes);
    }

    fn count(&mut self, n: usize) -> Result<(), WireError> {
        let n = u32::try_from(n).or_else(|_| fail(format!("{n} elements, over 2^32")))?;
        self.put(&n.to_le_bytes());
        Ok(())
    }

    fn fields(&mut self, schema: &Schema, value: &Value) -> Result<(), WireError> {
        let Value::Struct(vals) = value else {
            return fail(format!("a message expected, {} given", shape(value)));
        };
        if vals.len() != schema.fields.len() {
            return fail(format!(
                "{} fields expected, {} given",
                schema.fields.len(),
                vals.len()
            ));
        }
        for (f, v) in schema.fields.iter().zip(vals) {
            self.kind(&f.kind, v).map_err(within(f.name.clone()))?;
        }
        Ok(())
    }

    fn kind(&mut self, kind: &Kind, value: &Value) -> Result<(), WireError> {
        match (kind, value) {
            (Kind::Leaf(l), v) => self.leaf(*l, v),
            (Kind::Struct(_, s), v) => self.fields(s, v),
            (Kind::Array(e, len), Value::Bytes(b)) if **e == Kind::Leaf(Leaf::U8) => {
                self.length(*len, b.len())?;
                self.buf.extend_from_slice(b);
                Ok(())
            }
            (Kind::Array(e, len), Value::Array(items)) => {
                self.length(*len, items.len())?;
                for (i, v) in items.iter().enumerate() {
                    self.kind(e, v).map_err(within(format!("[{i}]")))?;
                }
                Ok(())
            }
            (Kind::Array(..), v) => fail(format!("an array expected, {} given", shape(v))),
        }
    }

    /// Writes a variable array's count, or checks a fixed array's length.
    fn length(&mut self, fixed: Option<usize>, n: usize) -> Result<(), WireError> {
        match fixed {
            None => self.count(n),
            Some(k) if k == n => Ok(()),
            Some(k) => fail(format!("{k} elements expected, {n} given")),
        }
    }

    fn leaf(&mut self, leaf: Leaf, v: &Value) -> Result<(), WireError> {
        match leaf {
            Leaf::Bool => self.put(&[int(v, 0, 1)? as u8]),
            Leaf::I8 => self.put(&(int(v, i8::MIN.into(), i8::MAX.into())? as i8).to_le_bytes()),
            Leaf::U8 => self.put(&[int(v, 0, u8::MAX.into())? as u8]),
            Leaf::I16 => {
                self.put(&(int(v, i16::MIN.into(), i16::MAX.into())? as i16).to_le_bytes())
            }
            Leaf::U16 => self.put(&(int(v, 0, u16::MAX.into())? as u16).to_le_bytes()),
            Leaf::I32 => {
                self.put(&(int(v, i32::MIN.into(), i32::MAX.into())? as i32).to_le_bytes())
            }
            Leaf::U32 => self.put(&(int(v, 0, u32::MAX.into())? as u32).to_le_bytes()),
            Leaf::I64 => {
                self.put(&(int(v, i64::MIN.into(), i64::MAX.into())? as i64).to_le_bytes())
            }
            Leaf::U64 => self.put(&(int(v, 0, u64::MAX.into())? as u64).to_le_bytes()),
            Leaf::F32 => self.put(&(float(v)? as f32).to_le_bytes()),
            Leaf::F64 => self.put(&float(v)?.to_le_bytes()),
            Leaf::Text => return self.text(v),
            Leaf::Time | Leaf::Duration => return self.time(leaf, v),
        }
        Ok(())
    }

    fn text(&mut self, v: &Value) -> Result<(), WireError> {
        let Value::Text(s) = v else {
            return fail(format!("text expected, {} given", shape(v)));
        };
        let cdr = matches!(self.wire, Wire::Cdr { .. });
        // CDR counts and writes the terminating NUL; ROS 1 has neither.
        self.count(s.len() + cdr as usize)?;
        self.buf.extend_from_slice(s.as_bytes());
        if cdr {
            self.buf.push(0);
        }
        Ok(())
    }

    /// ROS 1 `time` (unsigned seconds) or `duration` (signed), from seconds.
    fn time(&mut self, leaf: Leaf, v: &Value) -> Result<(), WireError> {
        let s = float(v)?;
        let (sec, nsec) = split_time(s).ok_or_else(|| err(format!("{s} s is not a time")))?;
        let sec_ok = match leaf {
            Leaf::Time => u32::try_from(sec).map(|x| x.to_le_bytes()).ok(),
            _ => i32::try_from(sec).map(|x| x.to_le_bytes()).ok(),
        };
        let sec = sec_ok
            .ok_or_else(|| err(format!("{s} s is out of a ROS 1 {}'s range", leaf.name())))?;
        self.put(&sec);
        self.put(&nsec.to_le_bytes());
        Ok(())
    }
}

fn err(what: String) -> WireError {
    WireError {
        path: String::new(),
        what,
    }
}

/// An integer in `lo..=hi` from a value (a float must be whole).
fn int(v: &Value, lo: i128, hi: i128) -> Result<i128, WireError> {
    let x = match *v {
        Value::Bool(b) => b as i128,
        Value::Int(i) => i as i128,
        Value::UInt(u) => u as i128,
        Value::Float(f) if f.fract() == 0.0 && f.abs() < 1.9e19 => f as i128,
        _ => return fail(format!("an integer expected, {} given", shape(v))),
    };
    if x < lo || x > hi {
        return fail(format!("{x} is out of the field's range {lo}..={hi}"));
    }
    Ok(x)
}

fn float(v: &Value) -> Result<f64, WireError> {
    v.as_f64()
        .ok_or_else(|| err(format!("a number expected, {} given", shape(v))))
}

fn shape(v: &Value) -> String {
    match v {
        Value::Bool(b) => format!("bool {b}"),
        Value::Int(i) => format!("integer {i}"),
        Value::UInt(u) => format!("integer {u}"),
        Value::Float(f) => format!("number {f}"),
        Value::Text(_) => "text".into(),
        Value::Bytes(b) => format!("{} bytes", b.len()),
        Value::Array(a) => format!("an array of {}", a.len()),
        Value::Struct(f) => format!("a message of {} fields", f.len()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgdef::{Flavor, schema};
    use crate::wire::{decode, decode_cdr};

    #[test]
    fn round_trips_both_wires() {
        let text = "Header header\nuint8[] raw\nint8 b\nfloat32[2] f\nduration d\nstring s";
        let s = schema(text, "t/T", Flavor::Ros1).unwrap();
        let v = Value::Struct(vec![
            Value::Struct(vec![
                Value::UInt(3),
                Value::Float(1.25),
                Value::Text("base".into()),
            ]),
            Value::Bytes(vec![1, 2, 3]),
            Value::Int(-4),
            Value::Array(vec![Value::Float(0.5), Value::Float(-1.0)]),
            Value::Float(-1.5),
            Value::Text("x".into()),
        ]);
        assert_eq!(decode(&s, &ros1(&s, &v).unwrap(), Wire::Ros1).unwrap(), v);
        let s2 = schema(
            "int8 a\nfloat64 b\nstring c\nuint16[] d",
            "t/T",
            Flavor::Ros2,
        )
        .unwrap();
        let v2 = Value::Struct(vec![
            Value::Int(-1),
            Value::Float(2.0),
            Value::Text("abc".into()),
            Value::Array(vec![Value::UInt(9)]),
        ]);
        assert_eq!(decode_cdr(&s2, &cdr(&s2, &v2).unwrap()).unwrap(), v2);
    }

    #[test]
    fn a_value_of_the_wrong_shape_is_an_error() {
        let s = schema("uint8 a\nfloat64[3] b", "t/T", Flavor::Ros1).unwrap();
        let bad = Value::Struct(vec![Value::Int(300), Value::Array(vec![])]);
        let e = ros1(&s, &bad).unwrap_err();
        assert_eq!(e.path, "a");
        let bad = Value::Struct(vec![Value::Int(3), Value::Array(vec![])]);
        assert!(
            ros1(&s, &bad)
                .unwrap_err()
                .what
                .contains("3 elements expected")
        );
    }
}
