//! Topics exported as CSV by `rostopic echo -p` (or `rostopic echo -b bag -p`): one file per
//! topic, a header `%time,field.a,field.b.c,...` and one row per message, `%time` the
//! receive time in nanoseconds since the Unix epoch. A log is one such file (one topic, named
//! by the file's stem) or a folder of them (one topic per file), so the two topics of a run
//! recorded as `wrench_3.csv` and `navigation_state_3.csv` are read as one log.
//!
//! - Columns become a message's fields by their names without `field.`, dots nesting them
//!   (`field.velocity.x` is `velocity.x`); an array's elements, which `rostopic` writes as
//!   `field.data0`, `field.data1`, keep those names.
//! - A column whose first row reads as a number is numeric (an empty or unreadable cell is
//!   NaN); any other is text.
//! - `field.header.stamp` (nanoseconds) is the message's stamp where it is not zero.
//! - Opening reads each file once to count its rows and find its first and last time; a
//!   topic's rows are parsed (and a row with more or fewer cells than the header refused) when
//!   it is read.

use crate::value::{Field, Kind, Leaf, Schema, Value};
use crate::{LogError, Message, Topic};
use std::path::{Path, PathBuf};

/// The first bytes of a `rostopic echo -p` file.
pub const MAGIC: &[u8] = b"%time,";

/// An open set of topic files.
#[derive(Debug)]
pub struct TopicCsv {
    files: Vec<PathBuf>,
}

/// A tree of fields built from dotted column names, in column order.
#[derive(Default)]
struct Node {
    children: Vec<(String, Node)>,
    /// The column and kind of a leaf.
    leaf: Option<(usize, Leaf)>,
}

impl Node {
    fn insert(&mut self, path: &[&str], column: usize, leaf: Leaf) {
        let Some((first, rest)) = path.split_first() else {
            self.leaf = Some((column, leaf));
            return;
        };
        let i = match self.children.iter().position(|(n, _)| n == first) {
            Some(i) => i,
            None => {
                self.children.push((first.to_string(), Node::default()));
                self.children.len() - 1
            }
        };
        self.children[i].1.insert(rest, column, leaf);
    }

    /// The schema of this node's children, and the columns of its leaves in order.
    fn schema(&self, columns: &mut Vec<usize>) -> Schema {
        let fields = self
            .children
            .iter()
            .map(|(name, n)| {
                let kind = match (n.leaf, n.children.is_empty()) {
                    (Some((c, leaf)), true) => {
                        columns.push(c);
                        Kind::Leaf(leaf)
                    }
                    // The type is not in the file; a header is named so that it reads as one.
                    _ if name == "header" => {
                        Kind::Struct("std_msgs/Header".into(), n.schema(columns))
                    }
                    _ => Kind::Struct(String::new(), n.schema(columns)),
                };
                Field {
                    name: name.clone(),
                    kind,
                }
            })
            .collect();
        Schema { fields }
    }

    /// The value of one row, laid out as [`Node::schema`].
    fn value(&self, cells: &[&str]) -> Value {
        Value::Struct(
            self.children
                .iter()
                .map(|(_, n)| match (n.leaf, n.children.is_empty()) {
                    (Some((c, Leaf::Text)), true) => {
                        Value::Text(cells.get(c).copied().unwrap_or("").to_string())
                    }
                    (Some((c, _)), true) => Value::Float(number(cells.get(c).copied())),
                    _ => n.value(cells),
                })
                .collect(),
        )
    }
}

fn number(cell: Option<&str>) -> f64 {
    cell.and_then(|s| s.trim().parse().ok()).unwrap_or(f64::NAN)
}

/// Whether `path` is a folder of topic files (a folder with a `%time` CSV in it and no
/// rosbag2 storage), so that [`crate::Log::open`] reads it as one log.
pub fn is_topic_folder(path: &Path) -> bool {
    path.is_dir() && !topic_files(path).unwrap_or_default().is_empty()
}

/// The `rostopic echo -p` files of a folder, sorted by name.
fn topic_files(dir: &Path) -> Result<Vec<PathBuf>, LogError> {
    let read = std::fs::read_dir(dir)
        .map_err(|e| LogError::new(dir, format!("cannot list the folder: {e}")))?;
    let mut out: Vec<PathBuf> = read
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")))
        .filter(|p| starts_with_magic(p))
        .collect();
    out.sort();
    Ok(out)
}

fn starts_with_magic(p: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 6];
    std::fs::File::open(p)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|_| head == MAGIC)
}

/// A topic file's text.
fn read_text(f: &Path) -> Result<String, LogError> {
    std::fs::read_to_string(f)
        .map_err(|e| LogError::new(f, format!("cannot read the topic file: {e}")))
}

/// A line's cells, trimmed (a file written on Windows ends its lines with `\r`).
fn cells(line: &str) -> Vec<String> {
    line.split(',').map(|s| s.trim().to_string()).collect()
}

/// The non-empty lines of a file, and the header's fields (without `%time`) from the first.
fn lines_and_names(text: &str) -> (impl Iterator<Item = &str>, Vec<String>) {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let names = lines.next().map_or(Vec::new(), |h| cells(h).split_off(1));
    (lines, names)
}

/// The header's fields (without `%time`), the rows, and the path for messages.
fn split(path: &Path, text: &str) -> Result<(Vec<String>, Vec<Vec<String>>), LogError> {
    let (lines, names) = lines_and_names(text);
    let rows: Vec<Vec<String>> = lines.map(cells).collect();
    if let Some((k, r)) = rows
        .iter()
        .enumerate()
        .find(|(_, r)| r.len() != names.len() + 1)
    {
        return Err(LogError::new(
            path,
            format!(
                "row {} has {} cells where the header names {} (a field holding a comma?)",
                k + 2,
                r.len(),
                names.len() + 1
            ),
        )
        .fix("export the topic again with `rostopic echo -p`, or leave the topic out"));
    }
    Ok((names, rows))
}

/// Nanoseconds since the Unix epoch as seconds: whole nanoseconds are split before they
/// become a float, which holds 1.7e18 only to 256 ns.
fn nanos_s(cell: &str) -> Option<f64> {
    let cell = cell.trim();
    match cell.parse::<u64>() {
        Ok(ns) => Some((ns / 1_000_000_000) as f64 + (ns % 1_000_000_000) as f64 * 1e-9),
        Err(_) => cell.parse::<f64>().ok().map(|ns| ns * 1e-9),
    }
}

/// A row's `%time`, s.
fn receive_s(path: &Path, row: &[String], k: usize) -> Result<f64, LogError> {
    nanos_s(&row[0]).ok_or_else(|| {
        LogError::new(
            path,
            format!("row {}: `%time` `{}` is not a number", k + 2, row[0]),
        )
        .fix("the first column of a `rostopic echo -p` file is the receive time in nanoseconds")
    })
}

impl TopicCsv {
    /// Opens a topic file or a folder of them and lists the topics: each file's stem, its row
    /// count and the receive times of its first and last rows.
    pub fn open(path: &Path) -> Result<(TopicCsv, Vec<Topic>), LogError> {
        let files = match path.is_dir() {
            true => topic_files(path)?,
            false => vec![path.to_path_buf()],
        };
        let mut topics = Vec::new();
        for f in &files {
            let text = read_text(f)?;
            // Only the header, the first row and the times of the first and last rows: the
            // rows are read when the topic is (a folder may hold a day of runs).
            let (mut lines, names) = lines_and_names(&text);
            let first = lines.next().map(cells);
            let (count, last) =
                lines.fold((first.iter().count(), None), |(n, _), l| (n + 1, Some(l)));
            let last = last.map(cells).or_else(|| first.clone());
            let (node, _) = tree(&names, first.as_ref());
            let schema = node.schema(&mut Vec::new());
            let time = |r: &Option<Vec<String>>, k: usize| match r {
                Some(r) => receive_s(f, r, k),
                None => Ok(f64::NAN),
            };
            let (first_s, last_s) = (time(&first, 0)?, time(&last, count.max(1) - 1)?);
            let name = f
                .file_stem()
                .map_or(String::new(), |s| s.to_string_lossy().into());
            topics.push(Topic {
                name,
                type_name: "rostopic CSV".into(),
                count: count as u64,
                first_s,
                last_s,
                schema,
            });
        }
        Ok((TopicCsv { files }, topics))
    }

    /// The file each topic is read from.
    pub fn file(&self, topic: usize) -> &Path {
        &self.files[topic]
    }

    /// Calls `each` with every message of `wanted`, in receive-time order across them.
    pub fn read(
        &self,
        wanted: &[usize],
        each: &mut dyn FnMut(&Message) -> Result<(), LogError>,
    ) -> Result<(), LogError> {
        let mut all: Vec<Message> = Vec::new();
        for &topic in wanted {
            let f = &self.files[topic];
            let (names, rows) = split(f, &read_text(f)?)?;
            let (node, stamp) = tree(&names, rows.first());
            for (k, r) in rows.iter().enumerate() {
                let cells: Vec<&str> = r[1..].iter().map(|s| s.as_str()).collect();
                let stamp_s = stamp
                    .and_then(|c| nanos_s(cells.get(c)?))
                    .filter(|s| s.is_finite() && *s > 0.0);
                all.push(Message {
                    topic,
                    log_time_s: receive_s(f, r, k)?,
                    stamp_s,
                    value: node.value(&cells),
                });
            }
        }
        all.sort_by(|a, b| a.log_time_s.total_cmp(&b.log_time_s));
        all.iter().try_for_each(each)
    }
}

/// The field tree of a header (names without `%time`), numeric where the first row's cell
/// reads as a number, and the column of `field.header.stamp`.
fn tree(names: &[String], first: Option<&Vec<String>>) -> (Node, Option<usize>) {
    let mut node = Node::default();
    let mut stamp = None;
    for (c, name) in names.iter().enumerate() {
        let bare = name.strip_prefix("field.").unwrap_or(name);
        let numeric = first.is_none_or(|r| {
            let cell = r.get(c + 1).map_or("", |s| s.trim());
            cell.is_empty() || cell.parse::<f64>().is_ok()
        });
        let leaf = if numeric { Leaf::F64 } else { Leaf::Text };
        if bare == "header.stamp" {
            stamp = Some(c);
        }
        let path: Vec<&str> = bare.split('.').collect();
        node.insert(&path, c, leaf);
    }
    (node, stamp)
}

#[cfg(test)]
mod tests {
    use super::*;

    const NAV: &str = "%time,field.header.seq,field.header.stamp,field.header.frame_id,field.velocity.x,field.velocity.y,field.orientation.z
1669909208877428140,11387,1669909208830211715,,0.5,-0.25,0.4
1669909208977451040,11388,1669909208949668236,odom,0.6,,0.41
";
    const WRENCH: &str = "%time,field.force.x,field.torque.z
1669909208900000000,1.5,-0.2
1669909208920000000,1.6,-0.1
";

    /// A fresh scratch folder of this test process.
    fn scratch(name: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("hydrofit-topic-csv-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_folder_of_topic_files_reads_as_one_log_in_time_order() {
        let d = scratch("folder");
        std::fs::write(d.as_path().join("navigation_state_3.csv"), NAV).unwrap();
        std::fs::write(d.as_path().join("wrench_3.csv"), WRENCH).unwrap();
        std::fs::write(d.as_path().join("notes.csv"), "a,b\n1,2\n").unwrap();
        assert!(is_topic_folder(d.as_path()));
        let log = crate::Log::open(d.as_path()).unwrap();
        assert_eq!(log.format, crate::Format::TopicCsv);
        let names: Vec<&str> = log.topics.iter().map(|t| t.name.as_str()).collect();
        assert_eq!(names, ["navigation_state_3", "wrench_3"]);
        assert_eq!(log.topics[0].count, 2);
        assert!((log.topics[1].first_s - 1669909208.9).abs() < 1e-6);
        let vx = log.topics[0].schema.select("velocity.x").unwrap();
        let vy = log.topics[0].schema.select("velocity.y").unwrap();
        let n = log.topics[1].schema.select("torque.z").unwrap();
        let mut seen = Vec::new();
        log.read(&[0, 1], &mut |m| {
            let x = match m.topic {
                0 => vx.get(&m.value).unwrap(),
                _ => n.get(&m.value).unwrap(),
            };
            let y = (m.topic == 0).then(|| vy.get(&m.value).unwrap());
            seen.push((m.topic, m.log_time_s, m.stamp_s, x, y));
            Ok(())
        })
        .unwrap();
        assert_eq!(seen.iter().map(|s| s.0).collect::<Vec<_>>(), [0, 1, 1, 0]);
        assert!((seen[0].2.unwrap() - 1_669_909_208.830_211_7).abs() < 1e-6);
        assert_eq!(seen[0].3, 0.5);
        assert!(seen[3].4.unwrap().is_nan(), "an empty cell is NaN");
        assert_eq!(seen[2].3, -0.1);
        assert_eq!(seen[1].2, None, "no header, no stamp");
        std::fs::remove_dir_all(d).unwrap();
    }

    #[test]
    fn a_row_with_more_cells_than_the_header_is_an_error_with_its_line() {
        let d = scratch("row");
        let p = d.as_path().join("t.csv");
        std::fs::write(&p, "%time,field.x\n1,2\n3,4,5\n").unwrap();
        let log = crate::Log::open(&p).unwrap();
        let e = log.read(&[0], &mut |_| Ok(())).unwrap_err();
        assert!(e.what.contains("row 3"), "{}", e.what);
        // A first row shorter than the header, and Windows line ends: opened, then refused
        // when read, never a panic.
        std::fs::write(&p, "%time,field.x,field.y\r\n1,2\r\n3,4,5\r\n").unwrap();
        let log = crate::Log::open(&p).unwrap();
        assert_eq!(log.topics[0].schema.leaves().len(), 2);
        let e = log.read(&[0], &mut |_| Ok(())).unwrap_err();
        assert!(e.what.contains("row 2"), "{}", e.what);
        std::fs::remove_dir_all(d).unwrap();
    }
}
