//! Writing logs: the ROS 1 bag, MCAP and ROS 2 SQLite (`.db3`) writers, and helpers to build the [`Value`] of a
//! message from its schema by field paths, for tests and for simulators that write their
//! synthetic runs as logs.
//!
//! ```no_run
//! use hydrofit_logs::write::{self, BagWriter, BagCompression};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let mut bag = BagWriter::create("run.bag".as_ref(), BagCompression::Lz4)?;
//! let odom = bag.add_topic("/odom", "nav_msgs/Odometry")?;
//! let schema = bag.schema(odom).unwrap().clone();
//! let msg = write::message(&schema, &[("header.stamp", 1.7e9), ("twist.twist.linear.x", 0.5)])?;
//! bag.write(odom, 1.7e9, &msg)?;
//! bag.finish()?;
//! # Ok(()) }
//! ```

pub use crate::db3::{Layout as Db3Layout, Writer as Db3Writer};
pub use crate::mcap::{Compression as McapCompression, Writer as McapWriter};
pub use crate::ros1::{Compression as BagCompression, Writer as BagWriter};

use crate::value::{Kind, Leaf, Schema, Value};

/// A message of `schema` with every number zero, every text empty, variable arrays empty and
/// fixed arrays full of zeros.
pub fn zero(schema: &Schema) -> Value {
    Value::Struct(schema.fields.iter().map(|f| zero_kind(&f.kind)).collect())
}

fn zero_kind(kind: &Kind) -> Value {
    match kind {
        Kind::Leaf(l) => match l {
            Leaf::Bool => Value::Bool(false),
            Leaf::I8 | Leaf::I16 | Leaf::I32 | Leaf::I64 => Value::Int(0),
            Leaf::U8 | Leaf::U16 | Leaf::U32 | Leaf::U64 => Value::UInt(0),
            Leaf::F32 | Leaf::F64 | Leaf::Time | Leaf::Duration => Value::Float(0.0),
            Leaf::Text => Value::Text(String::new()),
        },
        Kind::Struct(_, s) => zero(s),
        Kind::Array(e, len) => match (&**e, len) {
            (Kind::Leaf(Leaf::U8), n) => Value::Bytes(vec![0; n.unwrap_or(0)]),
            (e, Some(n)) => Value::Array(vec![zero_kind(e); *n]),
            (_, None) => Value::Array(Vec::new()),
        },
    }
}

/// Sets the number at `path` (`twist.twist.linear.x`, `header.stamp` in seconds, `data[2]`).
pub fn set(schema: &Schema, value: &mut Value, path: &str, x: f64) -> Result<(), String> {
    if schema.select(path)?.set(value, x) {
        Ok(())
    } else {
        Err(format!(
            "`{path}` is not in this message (a variable array too short?)"
        ))
    }
}

/// A zero message (see [`zero`]) with the numbers at the given paths set.
pub fn message(schema: &Schema, numbers: &[(&str, f64)]) -> Result<Value, String> {
    let mut v = zero(schema);
    for (path, x) in numbers {
        set(schema, &mut v, path, *x)?;
    }
    Ok(v)
}

/// Fills the variable (or fixed) array of numbers at `path` (`data`, `channels`), a field of
/// nested messages named by dots.
pub fn set_array(schema: &Schema, value: &mut Value, path: &str, xs: &[f64]) -> Result<(), String> {
    let mut s = schema;
    let mut v = value;
    let mut parts = path.split('.').peekable();
    while let Some(name) = parts.next() {
        let i = s
            .fields
            .iter()
            .position(|f| f.name == name)
            .ok_or(format!("no field `{name}` in `{path}`"))?;
        let Value::Struct(vals) = v else {
            return Err(format!("`{path}`: not a message"));
        };
        v = vals
            .get_mut(i)
            .ok_or(format!("`{path}`: the value lacks field `{name}`"))?;
        match (&s.fields[i].kind, parts.peek()) {
            (Kind::Struct(_, sub), Some(_)) => s = sub,
            (Kind::Array(e, len), None) => return fill(e, *len, v, xs, path),
            _ => return Err(format!("`{path}` is not an array of numbers")),
        }
    }
    Err(format!("`{path}` is not an array of numbers"))
}

fn fill(
    elem: &Kind,
    len: Option<usize>,
    v: &mut Value,
    xs: &[f64],
    path: &str,
) -> Result<(), String> {
    if len.is_some_and(|n| n != xs.len()) {
        return Err(format!(
            "`{path}` holds {} numbers, {} given",
            len.unwrap_or(0),
            xs.len()
        ));
    }
    let Kind::Leaf(leaf) = elem else {
        return Err(format!("`{path}` is not an array of numbers"));
    };
    *v = match leaf {
        Leaf::U8 => Value::Bytes(xs.iter().map(|&x| x as u8).collect()),
        Leaf::I8 | Leaf::I16 | Leaf::I32 | Leaf::I64 => {
            Value::Array(xs.iter().map(|&x| Value::Int(x as i64)).collect())
        }
        Leaf::U16 | Leaf::U32 | Leaf::U64 => {
            Value::Array(xs.iter().map(|&x| Value::UInt(x as u64)).collect())
        }
        Leaf::Bool => Value::Array(xs.iter().map(|&x| Value::Bool(x != 0.0)).collect()),
        Leaf::Text => return Err(format!("`{path}` is an array of text")),
        _ => Value::Array(xs.iter().map(|&x| Value::Float(x)).collect()),
    };
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgdef::{Flavor, schema};
    use crate::ros_types;

    #[test]
    fn builds_messages_by_path() {
        let s = schema(
            &ros_types::ros2("mavros_msgs/RCOut").unwrap(),
            "mavros_msgs/RCOut",
            Flavor::Ros2,
        )
        .unwrap();
        let mut v = message(&s, &[("header.stamp", 5.5)]).unwrap();
        set_array(&s, &mut v, "channels", &[1500.0, 1600.0]).unwrap();
        assert_eq!(s.select("channels[1]").unwrap().get(&v), Some(1600.0));
        assert_eq!(s.select("header.stamp").unwrap().get(&v), Some(5.5));
        assert!(set(&s, &mut v, "channels[2]", 1.0).is_err());
        assert!(set_array(&s, &mut v, "header", &[]).is_err());
    }
}
