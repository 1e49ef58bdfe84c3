//! Decoded messages and their layout. A [`Schema`] is built once per topic from the log's own
//! description of it (a ROS message definition, an MCAP schema, a DataFlash FMT record); every
//! message of the topic decodes into a [`Value`] laid out as the schema says, and a field is
//! picked by a [`Selector`] compiled once from its path.

use std::fmt;

/// The primitive types a message field can have.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Leaf {
    Bool,
    I8,
    I16,
    I32,
    I64,
    U8,
    U16,
    U32,
    U64,
    F32,
    F64,
    /// Text (ROS `string`, DataFlash `n`/`N`/`Z` characters).
    Text,
    /// ROS 1 `time` (seconds and nanoseconds), decoded as seconds.
    Time,
    /// ROS 1 `duration`, decoded as seconds.
    Duration,
}

impl Leaf {
    pub fn name(self) -> &'static str {
        match self {
            Leaf::Bool => "bool",
            Leaf::I8 => "int8",
            Leaf::I16 => "int16",
            Leaf::I32 => "int32",
            Leaf::I64 => "int64",
            Leaf::U8 => "uint8",
            Leaf::U16 => "uint16",
            Leaf::U32 => "uint32",
            Leaf::U64 => "uint64",
            Leaf::F32 => "float32",
            Leaf::F64 => "float64",
            Leaf::Text => "string",
            Leaf::Time => "time",
            Leaf::Duration => "duration",
        }
    }

    pub fn is_numeric(self) -> bool {
        !matches!(self, Leaf::Text)
    }
}

/// What one field holds.
#[derive(Debug, Clone, PartialEq)]
pub enum Kind {
    Leaf(Leaf),
    /// A nested message, with its type name (`geometry_msgs/Vector3`).
    Struct(String, Schema),
    /// An array of `Kind`, of fixed length when `Some`.
    Array(Box<Kind>, Option<usize>),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    pub name: String,
    pub kind: Kind,
}

/// The layout of a message: its fields in order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Schema {
    pub fields: Vec<Field>,
}

/// A decoded message or part of one. A `Struct` holds its fields' values in the schema's
/// order (the names are in the schema, not repeated in every message).
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Bool(bool),
    Int(i64),
    UInt(u64),
    Float(f64),
    Text(String),
    /// A `uint8[]`/`byte[]` array, kept as bytes.
    Bytes(Vec<u8>),
    Array(Vec<Value>),
    Struct(Vec<Value>),
}

impl Value {
    /// The value as a number: integers and booleans converted, text and arrays not.
    pub fn as_f64(&self) -> Option<f64> {
        match *self {
            Value::Bool(b) => Some(if b { 1.0 } else { 0.0 }),
            Value::Int(i) => Some(i as f64),
            Value::UInt(u) => Some(u as f64),
            Value::Float(x) => Some(x),
            _ => None,
        }
    }
}

/// One step of a field path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step {
    Field(usize),
    Index(usize),
}

/// A field path compiled against a schema: `twist.twist.linear.x` or `data[3]` (also
/// `data.3`). Picks a number out of a message without looking names up again.
#[derive(Debug, Clone, PartialEq)]
pub struct Selector {
    pub path: String,
    steps: Vec<Step>,
    /// The selected field is a `sec`/`nanosec` (or `secs`/`nsecs`) stamp struct, read as seconds.
    stamp: bool,
}

impl Schema {
    /// Every selectable leaf as (path, type), arrays shown as `name[]` (`name[0..6]` when fixed),
    /// in field order: what `hydrofit inspect` lists.
    pub fn leaves(&self) -> Vec<(String, String)> {
        let mut out = Vec::new();
        self.walk("", &mut out);
        out
    }

    fn walk(&self, prefix: &str, out: &mut Vec<(String, String)>) {
        for f in &self.fields {
            let path = if prefix.is_empty() {
                f.name.clone()
            } else {
                format!("{prefix}.{}", f.name)
            };
            walk_kind(&f.kind, &path, out);
        }
    }

    /// Whether the message starts with a ROS header (`header.stamp`).
    pub fn has_header(&self) -> bool {
        matches!(self.fields.first(), Some(Field { name, kind: Kind::Struct(t, _) })
            if name == "header" && t.ends_with("Header"))
    }

    /// Compiles `path`. The error lists the paths the schema has, for the message a user sees.
    pub fn select(&self, path: &str) -> Result<Selector, String> {
        // A table's column named with brackets or dots of its own (`channels[0]`): the whole
        // path is one field's name.
        if let Some(i) = self.fields.iter().position(|f| f.name == path)
            && matches!(&self.fields[i].kind, Kind::Leaf(l) if l.is_numeric())
            && split_path(path).count() > 1
        {
            return Ok(Selector {
                path: path.to_string(),
                steps: vec![Step::Field(i)],
                stamp: false,
            });
        }
        let mut steps = Vec::new();
        let mut kind_here: Option<&Kind> = None;
        let mut schema = Some(self);
        for part in split_path(path) {
            let part = part.map_err(|e| format!("`{path}`: {e}"))?;
            match part {
                Part::Name(name) => {
                    let Some(s) = schema else {
                        return Err(self.no_such(path));
                    };
                    let Some(i) = s.fields.iter().position(|f| f.name == name) else {
                        return Err(self.no_such(path));
                    };
                    steps.push(Step::Field(i));
                    kind_here = Some(&s.fields[i].kind);
                }
                Part::Index(k) => match kind_here {
                    Some(Kind::Array(elem, len)) => {
                        if let Some(n) = len
                            && k >= *n
                        {
                            return Err(format!(
                                "`{path}`: index {k} is past the array's {n} elements"
                            ));
                        }
                        steps.push(Step::Index(k));
                        kind_here = Some(elem);
                    }
                    _ => return Err(self.no_such(path)),
                },
            }
            schema = match kind_here {
                Some(Kind::Struct(_, s)) => Some(s),
                _ => None,
            };
        }
        let stamp = match kind_here {
            Some(Kind::Leaf(l)) if l.is_numeric() => false,
            Some(Kind::Struct(_, s)) if is_stamp(s) => true,
            _ => {
                return Err(format!(
                    "`{path}` is not a number; numeric fields: {}",
                    self.numeric_list()
                ));
            }
        };
        Ok(Selector {
            path: path.to_string(),
            steps,
            stamp,
        })
    }

    fn no_such(&self, path: &str) -> String {
        format!(
            "no field `{path}`; the message has: {}",
            self.numeric_list()
        )
    }

    fn numeric_list(&self) -> String {
        let all: Vec<String> = self
            .leaves()
            .into_iter()
            .filter(|(_, t)| t != "string")
            .map(|(p, _)| p)
            .collect();
        if all.len() > 40 {
            format!("{} ... ({} in all)", all[..40].join(", "), all.len())
        } else {
            all.join(", ")
        }
    }
}

fn walk_kind(kind: &Kind, path: &str, out: &mut Vec<(String, String)>) {
    match kind {
        Kind::Leaf(l) => out.push((path.to_string(), l.name().to_string())),
        Kind::Struct(t, s) if is_stamp(s) => out.push((path.to_string(), t.clone())),
        Kind::Struct(_, s) => s.walk(path, out),
        Kind::Array(elem, len) => {
            let p = match len {
                Some(n) => format!("{path}[0..{n}]"),
                None => format!("{path}[]"),
            };
            walk_kind(elem, &p, out)
        }
    }
}

/// A ROS 2 `builtin_interfaces/Time` or a ROS 1-style stamp written as a struct.
fn is_stamp(s: &Schema) -> bool {
    let names: Vec<&str> = s.fields.iter().map(|f| f.name.as_str()).collect();
    names == ["sec", "nanosec"] || names == ["secs", "nsecs"]
}

enum Part<'a> {
    Name(&'a str),
    Index(usize),
}

/// Splits `a.b[2].c` (or `a.b.2.c`) into names and indices.
fn split_path(path: &str) -> impl Iterator<Item = Result<Part<'_>, String>> {
    path.split('.').flat_map(|seg| {
        let mut parts = Vec::new();
        let (name, rest) = match seg.find('[') {
            Some(i) => (&seg[..i], &seg[i..]),
            None => (seg, ""),
        };
        if let Ok(k) = name.parse::<usize>() {
            parts.push(Ok(Part::Index(k)));
        } else if name.is_empty() && rest.is_empty() {
            parts.push(Err("an empty name".to_string()));
        } else if !name.is_empty() {
            parts.push(Ok(Part::Name(name)));
        }
        let mut rest = rest;
        while !rest.is_empty() {
            let Some(end) = rest.find(']') else {
                parts.push(Err("a `[` without `]`".to_string()));
                break;
            };
            match rest[1..end].trim().parse::<usize>() {
                Ok(k) => parts.push(Ok(Part::Index(k))),
                Err(_) => parts.push(Err(format!("`{}` is not an index", &rest[..=end]))),
            }
            rest = &rest[end + 1..];
        }
        parts
    })
}

impl Selector {
    /// The selected number in `value`, or `None` where the message does not have it (a
    /// variable-length array too short, a value of another shape).
    pub fn get(&self, value: &Value) -> Option<f64> {
        let mut v = value;
        for step in &self.steps {
            v = match (step, v) {
                (Step::Field(i), Value::Struct(fields)) => fields.get(*i)?,
                (Step::Index(k), Value::Array(items)) => items.get(*k)?,
                (Step::Index(k), Value::Bytes(b)) => return b.get(*k).map(|&x| x as f64),
                _ => return None,
            };
        }
        if self.stamp {
            let Value::Struct(f) = v else { return None };
            return Some(f.first()?.as_f64()? + f.get(1)?.as_f64()? * 1e-9);
        }
        v.as_f64()
    }
}

impl Selector {
    /// Sets the selected number in `value`, keeping the value's variant (an integer field
    /// stays an integer; a stamp struct gets whole seconds and nanoseconds). `false` where the
    /// message does not have it. For writers building messages.
    pub fn set(&self, value: &mut Value, x: f64) -> bool {
        let mut v = value;
        for step in &self.steps {
            v = match (step, v) {
                (Step::Field(i), Value::Struct(fields)) => match fields.get_mut(*i) {
                    Some(f) => f,
                    None => return false,
                },
                (Step::Index(k), Value::Array(items)) => match items.get_mut(*k) {
                    Some(f) => f,
                    None => return false,
                },
                (Step::Index(k), Value::Bytes(b)) => match b.get_mut(*k) {
                    Some(byte) => {
                        *byte = x as u8;
                        return true;
                    }
                    None => return false,
                },
                _ => return false,
            };
        }
        if self.stamp {
            let Value::Struct(f) = v else { return false };
            let sec = x.floor();
            let nsec = ((x - sec) * 1e9).round().min(999_999_999.0);
            return f.len() == 2 && set_number(&mut f[0], sec) && set_number(&mut f[1], nsec);
        }
        set_number(v, x)
    }
}

fn set_number(v: &mut Value, x: f64) -> bool {
    *v = match v {
        Value::Bool(_) => Value::Bool(x != 0.0),
        Value::Int(_) => Value::Int(x as i64),
        Value::UInt(_) => Value::UInt(x as u64),
        Value::Float(_) => Value::Float(x),
        _ => return false,
    };
    true
}

impl fmt::Display for Schema {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, (p, t)) in self.leaves().iter().enumerate() {
            if i > 0 {
                write!(f, ", ")?;
            }
            write!(f, "{p}: {t}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vec3() -> Schema {
        Schema {
            fields: ["x", "y", "z"]
                .iter()
                .map(|n| Field {
                    name: n.to_string(),
                    kind: Kind::Leaf(Leaf::F64),
                })
                .collect(),
        }
    }

    fn twist_msg() -> Schema {
        let stamp = Schema {
            fields: vec![
                Field {
                    name: "sec".into(),
                    kind: Kind::Leaf(Leaf::I32),
                },
                Field {
                    name: "nanosec".into(),
                    kind: Kind::Leaf(Leaf::U32),
                },
            ],
        };
        let header = Schema {
            fields: vec![
                Field {
                    name: "stamp".into(),
                    kind: Kind::Struct("builtin_interfaces/Time".into(), stamp),
                },
                Field {
                    name: "frame_id".into(),
                    kind: Kind::Leaf(Leaf::Text),
                },
            ],
        };
        Schema {
            fields: vec![
                Field {
                    name: "header".into(),
                    kind: Kind::Struct("std_msgs/Header".into(), header),
                },
                Field {
                    name: "linear".into(),
                    kind: Kind::Struct("geometry_msgs/Vector3".into(), vec3()),
                },
                Field {
                    name: "data".into(),
                    kind: Kind::Array(Box::new(Kind::Leaf(Leaf::U16)), None),
                },
            ],
        }
    }

    fn twist_value() -> Value {
        Value::Struct(vec![
            Value::Struct(vec![
                Value::Struct(vec![Value::Int(10), Value::UInt(500_000_000)]),
                Value::Text("base".into()),
            ]),
            Value::Struct(vec![
                Value::Float(1.5),
                Value::Float(-2.0),
                Value::Float(0.25),
            ]),
            Value::Array(vec![Value::UInt(1500), Value::UInt(1600)]),
        ])
    }

    #[test]
    fn selects_by_path() {
        let s = twist_msg();
        let v = twist_value();
        assert_eq!(s.select("linear.y").unwrap().get(&v), Some(-2.0));
        assert_eq!(s.select("data[1]").unwrap().get(&v), Some(1600.0));
        assert_eq!(s.select("data.0").unwrap().get(&v), Some(1500.0));
        assert_eq!(s.select("data[5]").unwrap().get(&v), None);
        assert_eq!(s.select("header.stamp").unwrap().get(&v), Some(10.5));
        assert!(s.has_header());
        let mut w = v.clone();
        assert!(s.select("header.stamp").unwrap().set(&mut w, 12.25));
        assert!(s.select("data[1]").unwrap().set(&mut w, 7.0));
        assert!(!s.select("data[5]").unwrap().set(&mut w, 7.0));
        assert_eq!(s.select("header.stamp").unwrap().get(&w), Some(12.25));
        assert_eq!(s.select("data[1]").unwrap().get(&w), Some(7.0));
    }

    #[test]
    fn a_wrong_path_lists_the_fields() {
        let s = twist_msg();
        let e = s.select("linear.w").unwrap_err();
        assert!(e.contains("linear.x") && e.contains("data[]"), "{e}");
        let e = s.select("header.frame_id").unwrap_err();
        assert!(e.contains("not a number"), "{e}");
        assert!(s.select("data[x]").unwrap_err().contains("not an index"));
    }

    #[test]
    fn leaves_in_order() {
        let l: Vec<String> = twist_msg().leaves().into_iter().map(|x| x.0).collect();
        assert_eq!(
            l,
            [
                "header.stamp",
                "header.frame_id",
                "linear.x",
                "linear.y",
                "linear.z",
                "data[]"
            ]
        );
    }
}
