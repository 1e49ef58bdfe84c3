//! ROS message definitions (ROS 1 `message_definition`, ROS 2 `ros2msg`) parsed into a
//! [`Schema`], and the ROS 1 MD5 sum of a definition.
//!
//! Both texts are laid out alike (ROS wiki `msg`, `rosbag` connection headers, rosbag2's MCAP
//! storage plugin): the main type's lines first, then each dependency after a line of `=` and a
//! `MSG: pkg/Type` (ROS 2: `MSG: pkg/msg/Type`) line. Every field line is `type name`, with ROS 2
//! allowing a default value after the name; `type NAME=value` lines are constants, skipped.

use crate::value::{Field, Kind, Leaf, Schema};

/// Which ROS the definition comes from: the primitive types and `Header` differ.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flavor {
    Ros1,
    Ros2,
}

/// Nesting deeper than this is taken as damage (real messages nest a handful of levels).
const MAX_DEPTH: usize = 32;
/// Fields in a whole expanded schema; bounds the work a crafted definition can cause.
const MAX_NODES: usize = 100_000;
/// Longest fixed array accepted (`float64[36]` is typical).
const MAX_FIXED: usize = 1 << 20;

/// How a field is repeated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rep {
    One,
    Fixed(usize),
    /// `T[]` or bounded `T[<=N]`: a length on the wire, then the elements.
    Var,
}

/// One field line as written.
#[derive(Debug, Clone)]
struct Line {
    /// The type token as written (`float64[36]`), which the ROS 1 MD5 text uses.
    written: String,
    /// The element type without array or bound (`float64`, `geometry_msgs/Point`, `Header`).
    base: String,
    rep: Rep,
    name: String,
}

/// One message type's block.
#[derive(Debug, Clone)]
struct Block {
    /// `pkg/Type` (ROS 2 `pkg/msg/Type` shortened to it).
    name: String,
    lines: Vec<Line>,
    /// Constants as the MD5 text has them: `type NAME=value`.
    constants: Vec<String>,
}

/// A parsed definition: the main type and the types it uses.
#[derive(Debug, Clone)]
pub struct Definition {
    flavor: Flavor,
    blocks: Vec<Block>,
    /// Blocks from here on are built-in fallbacks, looked at only when the text lacks a type.
    fallback_from: usize,
}

/// Parses `text`, the definition of `type_name`, into a schema.
pub fn schema(text: &str, type_name: &str, flavor: Flavor) -> Result<Schema, String> {
    Definition::parse(text, type_name, flavor)?.schema()
}

/// The non-primitive types one type's own text uses, as written (`Header`, `Point`), in order.
pub(crate) fn used_types(text: &str, flavor: Flavor) -> Result<Vec<String>, String> {
    let mut b = Block::new(String::new());
    for line in text.lines() {
        b.add(line)?;
    }
    let bases = b.lines.into_iter().map(|l| l.base);
    Ok(bases.filter(|t| primitive(t, flavor).is_none()).collect())
}

/// `pkg/msg/Type` -> `pkg/Type`; other names unchanged.
pub fn short_name(name: &str) -> String {
    let parts: Vec<&str> = name.trim().split('/').collect();
    match parts.as_slice() {
        [pkg, "msg", ty] => format!("{pkg}/{ty}"),
        _ => name.trim().to_string(),
    }
}

impl Definition {
    /// Splits `text` into its blocks and parses their lines.
    pub fn parse(text: &str, type_name: &str, flavor: Flavor) -> Result<Definition, String> {
        let mut blocks = vec![Block::new(short_name(type_name))];
        let mut lines = text.lines().enumerate();
        while let Some((no, raw)) = lines.next() {
            let line = raw.trim();
            if line.len() >= 3 && line.bytes().all(|b| b == b'=') {
                let next = lines
                    .by_ref()
                    .map(|(_, l)| l.trim())
                    .find(|l| !l.is_empty());
                let Some(name) = next.and_then(|l| l.strip_prefix("MSG:")) else {
                    return Err(format!(
                        "line {}: a `===` separator not followed by `MSG: pkg/Type`",
                        no + 1
                    ));
                };
                blocks.push(Block::new(short_name(name)));
                continue;
            }
            let block = blocks.last_mut().expect("blocks starts non-empty");
            block.add(line).map_err(|e| {
                format!(
                    "line {} (`{}`) of the `{}` definition: {e}",
                    no + 1,
                    clip(line),
                    block.name
                )
            })?;
        }
        let fallback_from = blocks.len();
        for (name, def) in fallbacks(flavor) {
            if !blocks.iter().any(|b| b.name == *name) {
                let mut b = Block::new(name.to_string());
                for line in def.lines() {
                    b.add(line).expect("built-in definitions parse");
                }
                blocks.push(b);
            }
        }
        Ok(Definition {
            flavor,
            blocks,
            fallback_from,
        })
    }

    /// The main type's schema, every nested type expanded.
    pub fn schema(&self) -> Result<Schema, String> {
        let mut budget = MAX_NODES;
        self.build(0, &mut Vec::new(), &mut budget)
    }

    fn build(
        &self,
        idx: usize,
        stack: &mut Vec<usize>,
        budget: &mut usize,
    ) -> Result<Schema, String> {
        if stack.contains(&idx) {
            return Err(format!(
                "`{}` contains itself (a recursive definition)",
                self.blocks[idx].name
            ));
        }
        if stack.len() >= MAX_DEPTH {
            return Err(format!("types nest deeper than {MAX_DEPTH} levels"));
        }
        stack.push(idx);
        let block = &self.blocks[idx];
        let mut fields = Vec::with_capacity(block.lines.len());
        for line in &block.lines {
            *budget = budget
                .checked_sub(1)
                .ok_or_else(|| format!("the expanded message has more than {MAX_NODES} fields"))?;
            let elem = match primitive(&line.base, self.flavor) {
                Some(leaf) => Kind::Leaf(leaf),
                None => {
                    let sub = self.resolve(&line.base, &block.name)?;
                    Kind::Struct(
                        self.blocks[sub].name.clone(),
                        self.build(sub, stack, budget)?,
                    )
                }
            };
            let kind = match line.rep {
                Rep::One => elem,
                Rep::Fixed(n) => Kind::Array(Box::new(elem), Some(n)),
                Rep::Var => Kind::Array(Box::new(elem), None),
            };
            fields.push(Field {
                name: line.name.clone(),
                kind,
            });
        }
        stack.pop();
        Ok(Schema { fields })
    }

    /// The block a non-primitive type `base`, used in block `from`, refers to.
    fn resolve(&self, base: &str, from: &str) -> Result<usize, String> {
        let real = &self.blocks[..self.fallback_from];
        let all = &self.blocks;
        let find = |bs: &[Block], name: &str| bs.iter().position(|b| b.name == name);
        if base.contains('/') {
            let name = short_name(base);
            return find(all, &name).ok_or_else(|| unknown(base, from));
        }
        // ROS 1: a bare `Header` is std_msgs/Header (ROS wiki msg, "Header").
        if self.flavor == Flavor::Ros1 && base == "Header" {
            return find(all, "std_msgs/Header").ok_or_else(|| unknown(base, from));
        }
        let pkg = from.split_once('/').map_or("", |(p, _)| p);
        if let Some(i) = find(real, &format!("{pkg}/{base}")) {
            return Ok(i);
        }
        let suffix = format!("/{base}");
        let ends: Vec<usize> = (0..real.len())
            .filter(|&i| real[i].name.ends_with(&suffix))
            .collect();
        match ends.as_slice() {
            [i] => Ok(*i),
            [] => (self.fallback_from..all.len())
                .find(|&i| all[i].name.ends_with(&suffix))
                .ok_or_else(|| unknown(base, from)),
            _ => Err(format!(
                "type `{base}` in `{from}` is ambiguous: {}",
                ends.iter()
                    .map(|&i| real[i].name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        }
    }

    /// The ROS 1 MD5 sum of the main type, as `genmsg` computes it: the MD5 of the constants
    /// (`type NAME=value`), then the fields, a nested type written as its own MD5 sum
    /// (ROS wiki ROS/Technical Overview, "Message serialization and msg MD5 sums").
    pub fn md5(&self) -> Result<String, String> {
        self.md5_of(0, 0)
    }

    fn md5_of(&self, idx: usize, depth: usize) -> Result<String, String> {
        if depth > MAX_DEPTH {
            return Err(format!("types nest deeper than {MAX_DEPTH} levels"));
        }
        let block = &self.blocks[idx];
        let mut text: Vec<String> = block.constants.clone();
        for line in &block.lines {
            if primitive(&line.base, self.flavor).is_some() {
                text.push(format!("{} {}", line.written, line.name));
            } else {
                let sub = self.resolve(&line.base, &block.name)?;
                text.push(format!("{} {}", self.md5_of(sub, depth + 1)?, line.name));
            }
        }
        Ok(format!("{:x}", md5::compute(text.join("\n").as_bytes())))
    }
}

/// At most 60 characters of `s`, for error messages about damaged text.
fn clip(s: &str) -> String {
    match s.char_indices().nth(60) {
        Some((i, _)) => format!("{}...", &s[..i]),
        None => s.to_string(),
    }
}

fn unknown(base: &str, from: &str) -> String {
    let (base, from) = (clip(base), clip(from));
    format!("unknown type `{base}` in `{from}` (the definition has no `MSG:` block for it)")
}

impl Block {
    fn new(name: String) -> Block {
        Block {
            name,
            lines: Vec::new(),
            constants: Vec::new(),
        }
    }

    /// Adds one line of text: a field, a constant, or nothing (blank, comment).
    fn add(&mut self, line: &str) -> Result<(), String> {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            return Ok(());
        }
        let (written, rest) = line
            .split_once(char::is_whitespace)
            .ok_or("no field name")?;
        let rest = rest.trim_start();
        let name_len = rest
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .unwrap_or(rest.len());
        let (name, after) = rest.split_at(name_len);
        if name.is_empty() || !name.starts_with(|c: char| c.is_ascii_alphabetic()) {
            return Err("no valid field name".into());
        }
        let after = after.trim_start();
        if let Some(value) = after.strip_prefix('=') {
            // A constant. ROS 1 string constants run to the end of the line, `#` included
            // (genmsg msg_loader); other values end at a comment.
            let value = if written == "string" {
                value
            } else {
                value.split('#').next().unwrap_or("")
            };
            self.constants
                .push(format!("{written} {name}={}", value.trim()));
            return Ok(());
        }
        let spaced = rest[name_len..].starts_with(char::is_whitespace);
        if !(after.is_empty() || after.starts_with('#') || spaced) {
            return Err(format!(
                "`{}` after the field name",
                &after[..after.len().min(20)]
            ));
        }
        let (base, rep) = split_type(written)?;
        self.lines.push(Line {
            written: written.to_string(),
            base,
            rep,
            name: name.to_string(),
        });
        Ok(())
    }
}

/// `float64[36]` -> (`float64`, Fixed(36)); `string<=8[<=4]` -> (`string`, Var).
fn split_type(written: &str) -> Result<(String, Rep), String> {
    let (base, rep) = match written.find('[') {
        None => (written, Rep::One),
        Some(i) => {
            let inner = written[i + 1..]
                .strip_suffix(']')
                .ok_or("a `[` without `]`")?;
            let rep = if inner.is_empty() || inner.starts_with("<=") {
                Rep::Var
            } else {
                match inner.parse::<usize>() {
                    Ok(n) if n <= MAX_FIXED => Rep::Fixed(n),
                    _ => return Err(format!("`[{}]` is not an array length", clip(inner))),
                }
            };
            (&written[..i], rep)
        }
    };
    // Bounded strings (ROS 2 `string<=N`) are strings on the wire.
    let base = match base.split_once("<=") {
        Some((b @ ("string" | "wstring"), n)) if n.parse::<usize>().is_ok() => b,
        _ => base,
    };
    let ok = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '/';
    if base.is_empty() || !base.chars().all(ok) {
        return Err(format!("`{written}` is not a type"));
    }
    Ok((base.to_string(), rep))
}

/// The primitive a type name is, if it is one.
fn primitive(base: &str, flavor: Flavor) -> Option<Leaf> {
    Some(match base {
        "bool" => Leaf::Bool,
        "int8" => Leaf::I8,
        "int16" => Leaf::I16,
        "int32" => Leaf::I32,
        "int64" => Leaf::I64,
        // `byte` and `char` are 8-bit codes; arrays of them are bytes (rospy, rosbags).
        "uint8" | "byte" | "char" => Leaf::U8,
        "octet" if flavor == Flavor::Ros2 => Leaf::U8,
        "uint16" => Leaf::U16,
        "uint32" => Leaf::U32,
        "uint64" => Leaf::U64,
        "float32" => Leaf::F32,
        "float64" => Leaf::F64,
        "string" => Leaf::Text,
        // Read as a string, as `rosbags` does (RMWs differ on the wire for wide strings).
        "wstring" if flavor == Flavor::Ros2 => Leaf::Text,
        "time" if flavor == Flavor::Ros1 => Leaf::Time,
        "duration" if flavor == Flavor::Ros1 => Leaf::Duration,
        _ => return None,
    })
}

/// Definitions a text may leave out because every ROS installation has them.
fn fallbacks(flavor: Flavor) -> &'static [(&'static str, &'static str)] {
    match flavor {
        Flavor::Ros1 => &[("std_msgs/Header", "uint32 seq\ntime stamp\nstring frame_id")],
        Flavor::Ros2 => &[
            (
                "std_msgs/Header",
                "builtin_interfaces/Time stamp\nstring frame_id",
            ),
            ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec"),
            ("builtin_interfaces/Duration", "int32 sec\nuint32 nanosec"),
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(s: &Schema) -> Vec<String> {
        s.leaves()
            .into_iter()
            .map(|(p, t)| format!("{p}:{t}"))
            .collect()
    }

    #[test]
    fn ros1_definitions_with_constants_comments_and_header() {
        let text = "# a comment\nHeader header  # trailing\nuint8 MODE_A=1\nstring S= x # kept\n\
            int32 X = -3\nPoint[] pts\nbyte[] raw\nchar c\nduration d\n\
            ================================================================================\n\
            MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n\
            ================================================================================\n\
            MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n";
        let d = Definition::parse(text, "my_pkg/Thing", Flavor::Ros1).unwrap();
        let s = d.schema().unwrap();
        assert_eq!(
            names(&s),
            [
                "header.seq:uint32",
                "header.stamp:time",
                "header.frame_id:string",
                "pts[].x:float64",
                "pts[].y:float64",
                "pts[].z:float64",
                "raw[]:uint8",
                "c:uint8",
                "d:duration"
            ]
        );
        assert!(s.has_header());
        assert_eq!(
            d.blocks[0].constants,
            ["uint8 MODE_A=1", "string S=x # kept", "int32 X=-3"]
        );
    }

    #[test]
    fn ros2_definitions_with_bounds_defaults_and_msg_names() {
        let text = "std_msgs/Header header\nstring<=8 name \"abc\"\nint32[<=4] small [1, 2]\n\
            float64[3] v [0.0, 0.0, 1.0]\nwstring w\noctet o\nbyte b\nuint8 LEVEL=2\nState state\n\
            ================================================================================\n\
            MSG: std_msgs/msg/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n\
            ================================================================================\n\
            MSG: builtin_interfaces/msg/Time\nint32 sec\nuint32 nanosec\n\
            ================================================================================\n\
            MSG: my_msgs/msg/State\nbool ok\n";
        let s = schema(text, "my_msgs/msg/Report", Flavor::Ros2).unwrap();
        assert_eq!(
            names(&s),
            [
                "header.stamp:builtin_interfaces/Time",
                "header.frame_id:string",
                "name:string",
                "small[]:int32",
                "v[0..3]:float64",
                "w:string",
                "o:uint8",
                "b:uint8",
                "state.ok:bool"
            ]
        );
        assert!(s.has_header());
        // A Header without its MSG block still resolves (every ROS 2 has it).
        let s = schema("std_msgs/Header header\nfloat32 x", "a/msg/B", Flavor::Ros2).unwrap();
        assert_eq!(names(&s)[0], "header.stamp:builtin_interfaces/Time");
    }

    #[test]
    fn unqualified_types_resolve_by_package_then_by_unique_name() {
        let sep = format!("\n{}\n", "=".repeat(80));
        let text =
            format!("Inner a\nOther b{sep}MSG: pkg/Inner\nint8 x{sep}MSG: other/Other\nint16 y");
        let s = schema(&text, "pkg/Outer", Flavor::Ros1).unwrap();
        assert_eq!(names(&s), ["a.x:int8", "b.y:int16"]);
        let text = format!("Dup d{sep}MSG: p1/Dup\nint8 x{sep}MSG: p2/Dup\nint8 x");
        let e = schema(&text, "pkg/Outer", Flavor::Ros1).unwrap_err();
        assert!(e.contains("ambiguous"), "{e}");
    }

    #[test]
    fn errors_are_said() {
        let e = schema("Missing m", "pkg/T", Flavor::Ros1).unwrap_err();
        assert!(e.contains("unknown type `Missing`"), "{e}");
        let sep = format!("\n{}\n", "=".repeat(80));
        let e = schema(
            &format!("A a{sep}MSG: pkg/A\nB b{sep}MSG: pkg/B\nA a"),
            "pkg/T",
            Flavor::Ros1,
        )
        .unwrap_err();
        assert!(e.contains("recursive"), "{e}");
        let e = schema("float64[x] v", "pkg/T", Flavor::Ros1).unwrap_err();
        assert!(e.contains("line 1") && e.contains("array length"), "{e}");
        assert!(schema("float64", "pkg/T", Flavor::Ros1).is_err());
        assert!(schema("time t", "pkg/T", Flavor::Ros2).is_err());
        let e = schema(&format!("int8 a{sep}int8 b"), "pkg/T", Flavor::Ros1).unwrap_err();
        assert!(e.contains("MSG:"), "{e}");
    }

    #[test]
    fn crafted_nesting_is_bounded() {
        // Each type holds the next one 16 times: 16^8 fields if expanded.
        let sep = format!("\n{}\n", "=".repeat(80));
        let mut text = String::from("T0 a");
        for i in 0..8 {
            let fields: Vec<String> = (0..16).map(|k| format!("T{} f{k}", i + 1)).collect();
            text.push_str(&format!("{sep}MSG: pkg/T{i}\n{}", fields.join("\n")));
        }
        text.push_str(&format!("{sep}MSG: pkg/T8\nint8 x"));
        let e = schema(&text, "pkg/Top", Flavor::Ros1).unwrap_err();
        assert!(e.contains("more than"), "{e}");
    }
}
