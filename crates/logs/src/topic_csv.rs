//! Logs written as CSV files with a time column, one topic per file: topics exported by
//! `rostopic echo -p` (or `rostopic echo -b bag -p`), PlotJuggler's and PX4's CSV exports, a
//! simulator's or an analysis tool's tables. A log is one such file (one topic, named by the
//! file's stem) or a folder of them (one topic per file), so the two topics of a run recorded
//! as `wrench_3.csv` and `navigation_state_3.csv` are read as one log. Which column is the
//! time, and in what unit, is [`crate::csv_clock`]'s: `%time` (nanoseconds) in a `rostopic`
//! file.
//!
//! - Columns become a message's fields by their names (a `rostopic` file's without `field.`),
//!   dots nesting them (`field.velocity.x` is `velocity.x`); an array's elements, which
//!   `rostopic` writes as `field.data0`, `field.data1`, keep those names.
//! - A column whose first row reads as a number is numeric (an empty or unreadable cell is
//!   NaN); any other is text.
//! - In a `rostopic` file, `field.header.stamp` (nanoseconds) is the message's stamp where it
//!   is not zero.
//! - Opening reads each file to count its rows and find its earliest and latest time, and
//!   the largest step back of its time from row to row (said in the notes: rows are read in
//!   time order, as a bag is, so a file holding two recordings reads interleaved), and the
//!   rows that repeat its header (recordings appended to one file: skipped, said); a
//!   topic's rows are parsed (and a row with more or fewer cells than the header refused) when
//!   it is read.

use crate::csv_clock::{self, Clock};
use crate::value::{Field, Kind, Leaf, Schema, Value};
use crate::{LogError, Message, Topic};
use scan::{Back, Scan, is_header, scan};
use std::path::{Path, PathBuf};

/// An open set of topic files.
#[derive(Debug)]
pub struct TopicCsv {
    files: Vec<PathBuf>,
    clocks: Vec<Clock>,
    /// CSV files of the folder that are not read: their header names no time.
    untimed: Vec<PathBuf>,
    /// Files whose last row was cut short (a logger stopped mid-write): left out.
    torn: Vec<PathBuf>,
    /// Files whose time steps back from one row to the next, with the largest such step.
    backs: Vec<(PathBuf, Back)>,
    /// Files whose header comes again among the rows (recordings appended to one file): how
    /// often, and the row (1-based, the header row 1) it first comes again at.
    repeats: Vec<(PathBuf, usize, usize)>,
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

/// Whether `path` is a folder of topic files (a folder with a CSV file whose header names a
/// time, and no rosbag2 storage: a bag's folder with a CSV export beside it is the bag), so
/// that [`crate::Log::open`] reads it as one log.
pub fn is_topic_folder(path: &Path) -> bool {
    path.is_dir() && !has_bag(path) && csv_files(path).is_ok_and(|(timed, _)| !timed.is_empty())
}

/// Whether a folder holds a rosbag2 bag (its metadata or a storage file).
fn has_bag(path: &Path) -> bool {
    let bag = |e: &std::ffi::OsStr| e.eq_ignore_ascii_case("db3") || e.eq_ignore_ascii_case("mcap");
    std::fs::read_dir(path).is_ok_and(|entries| {
        entries
            .filter_map(Result::ok)
            .any(|e| e.file_name() == "metadata.yaml" || e.path().extension().is_some_and(bag))
    })
}

/// A folder of CSV files none of which names a time, and no bag: the files, each with
/// whether its first row is numbers (a table without a header, as MATLAB's `writematrix`
/// writes it), to be listed in the error.
pub fn untimed_folder(path: &Path) -> Option<Vec<(PathBuf, bool)>> {
    if !path.is_dir() || has_bag(path) {
        return None;
    }
    let (timed, others) = csv_files(path).ok()?;
    let headerless = |p: &PathBuf| first_bytes(p).is_some_and(|d| is_headerless_table(&d));
    if !timed.is_empty() || others.is_empty() {
        return None;
    }
    let flags: Vec<bool> = others.iter().map(headerless).collect();
    Some(others.into_iter().zip(flags).collect())
}

/// Whether a file's first line is numbers only: a table without a header (MATLAB's
/// `writematrix`, numpy's `savetxt`), whose columns have no names to read them by.
pub fn is_headerless_table(data: &[u8]) -> bool {
    let cells = cells(&first_line(data));
    cells.len() > 1 && cells.iter().all(|c| c.trim().parse::<f64>().is_ok())
}

/// The first line of a file's first bytes.
fn first_line(data: &[u8]) -> std::borrow::Cow<'_, str> {
    let head = &data[..data.len().min(64 * 1024)];
    String::from_utf8_lossy(head.split(|b| *b == b'\n').next().unwrap_or_default())
}

/// Whether the bytes of a file are a CSV log: a first line with a comma that names a time.
pub fn is_timed_csv(data: &[u8]) -> bool {
    let line = first_line(data);
    let header = cells(&line);
    let second = || {
        let head = String::from_utf8_lossy(&data[..data.len().min(64 * 1024)]);
        let row = head.lines().nth(1).map(cells).unwrap_or_default();
        csv_clock::unnamed_dates(&header, row.first().map(String::as_str))
    };
    line.contains(',') && (csv_clock::names_a_time(&header) || second())
}

/// Whether the bytes of a file are a `;`-separated table whose header names a time (a
/// spreadsheet's export with decimal commas): refused with how to write it, not misread.
pub fn is_semicolon_csv(data: &[u8]) -> bool {
    let line = first_line(data);
    let cells: Vec<String> = line
        .split(';')
        .map(|c| csv_clock::bare(c).to_string())
        .collect();
    !line.contains(',') && cells.len() > 1 && csv_clock::names_a_time(&cells)
}

/// The CSV files of a folder, sorted by name: those whose header names a time, and the others.
fn csv_files(dir: &Path) -> Result<(Vec<PathBuf>, Vec<PathBuf>), LogError> {
    let read = std::fs::read_dir(dir)
        .map_err(|e| LogError::new(dir, format!("cannot list the folder: {e}")))?;
    let mut all: Vec<PathBuf> = read
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")))
        .collect();
    all.sort();
    Ok(all
        .into_iter()
        .partition(|p| first_bytes(p).is_some_and(|d| is_timed_csv(&d))))
}

/// The first 64 KiB of a file (enough for its header line).
fn first_bytes(p: &Path) -> Option<Vec<u8>> {
    use std::io::Read;
    let mut head = Vec::new();
    std::fs::File::open(p)
        .and_then(|f| f.take(64 * 1024).read_to_end(&mut head))
        .ok()?;
    Some(head)
}

/// A topic file's text.
fn read_text(f: &Path) -> Result<String, LogError> {
    std::fs::read_to_string(f)
        .map_err(|e| LogError::new(f, format!("cannot read the topic file: {e}")))
}

/// A line's cells, trimmed of blanks and quotes (a file written on Windows ends its lines
/// with `\r`; a spreadsheet may quote its names).
fn cells(line: &str) -> Vec<String> {
    line.split(',')
        .map(|s| csv_clock::bare(s).to_string())
        .collect()
}

/// The non-empty lines of a file after its header, and the header's cells.
fn lines_and_header(text: &str) -> (impl Iterator<Item = &str>, Vec<String>) {
    let mut lines = without_torn_end(text)
        .0
        .lines()
        .filter(|l| !l.trim().is_empty());
    let header = lines.next().map_or(Vec::new(), cells);
    (lines, header)
}

/// The text of a file without a last row that was cut short, and whether it had one: a last
/// line with no line break after it and fewer cells than the header names. A logger or an
/// export stopped mid-write leaves one; every row before it is whole, and a bag or an MCAP
/// file cut short is read the same way, up to its last whole record.
fn without_torn_end(text: &str) -> (&str, bool) {
    let Some(end) = text.rfind('\n').filter(|_| !text.ends_with('\n')) else {
        return (text, false);
    };
    let last = &text[end + 1..];
    let width = text
        .lines()
        .find(|l| !l.trim().is_empty())
        .map_or(0, |h| h.split(',').count());
    match !last.trim().is_empty() && last.split(',').count() < width {
        true => (&text[..end + 1], true),
        false => (text, false),
    }
}

/// The clock of a file from its header and first rows, or an error saying which names a
/// time column may have.
fn clock_of(
    path: &Path,
    header: &[String],
    first: &[Vec<String>],
    given: Option<f64>,
) -> Result<Clock, LogError> {
    csv_clock::clock(header, first.iter().map(|r| r.as_slice()), given).ok_or_else(|| {
        LogError::new(
            path,
            format!("a CSV file with no time column (its header: {})", header.join(", ")),
        )
        .fix("name the time column `time`, `timestamp`, `t` or `%time`, with its unit where it is not seconds (`time_us`, `timestamp_ms`, `t_ns`)")
    })
}

/// A row's time, s.
fn time_s<S: AsRef<str>>(path: &Path, clock: &Clock, row: &[S], k: usize) -> Result<f64, LogError> {
    let cell = row.get(clock.column).map_or("", |s| s.as_ref());
    csv_clock::seconds(cell, clock.unit_s).ok_or_else(|| {
        LogError::new(
            path,
            format!("row {}: the time `{cell}` is neither a number nor a date and time", k + 2),
        )
        .fix("every row needs a number in the time column, or a date and time such as `2023-04-18 11:03:34.123` (UTC unless it gives a zone)")
    })
}

/// A row's cells without the time column: the fields, in the order of [`field_names`].
fn fields<'a, S: AsRef<str>>(row: &'a [S], clock: &Clock) -> Vec<&'a str> {
    (row.iter().enumerate())
        .filter(|(c, _)| *c != clock.column)
        .map(|(_, s)| s.as_ref())
        .collect()
}

/// The header's field names (the time column left out; a `rostopic` file's without `field.`).
fn field_names(header: &[String], clock: &Clock) -> Vec<String> {
    let names = fields(header, clock).into_iter();
    match clock.rostopic {
        true => names
            .map(|n| n.strip_prefix("field.").unwrap_or(n).to_string())
            .collect(),
        false => names.map(str::to_string).collect(),
    }
}

/// How many rows a clock's unit is read from when the name does not give it.
const UNIT_ROWS: usize = 2000;

impl TopicCsv {
    /// Opens a topic file or a folder of them and lists the topics: each file's stem, its row
    /// count and the times of its first and last rows. `time_unit_s` is the unit of a time
    /// column whose name gives none (read from its values when `None`).
    pub fn open(path: &Path, time_unit_s: Option<f64>) -> Result<(TopicCsv, Vec<Topic>), LogError> {
        let (files, untimed) = match path.is_dir() {
            true => csv_files(path)?,
            false => (vec![path.to_path_buf()], Vec::new()),
        };
        let mut topics = Vec::new();
        let mut clocks = Vec::new();
        let mut torn = Vec::new();
        let mut backs = Vec::new();
        let mut repeats = Vec::new();
        for f in &files {
            let text = read_text(f)?;
            if without_torn_end(&text).1 {
                torn.push(f.clone());
            }
            // The header and the first rows (for the clock's unit and the fields' kinds), then
            // one pass over every row's time: the rows are parsed when the topic is read (a
            // folder may hold a day of runs).
            let (mut lines, header) = lines_and_header(&text);
            let head: Vec<&str> = lines.by_ref().take(UNIT_ROWS).collect();
            let first: Vec<Vec<String>> = head.iter().map(|l| cells(l)).collect();
            let clock = clock_of(f, &header, &first, time_unit_s)?;
            let (node, _) = tree(&field_names(&header, &clock), first.first(), &clock);
            let schema = node.schema(&mut Vec::new());
            let scanned = scan(head.iter().copied().chain(lines), &clock, &header);
            let Scan {
                first_s,
                last_s,
                back,
                count,
                ..
            } = scanned;
            // The first and last rows must have a time; the span is the earliest and the
            // latest of all rows, which are read in time order.
            if let Some(r) = first.first() {
                time_s(f, &clock, r, 0)?;
            }
            if let Some(r) = scanned.last.map(cells).filter(|r| !is_header(r, &header)) {
                time_s(f, &clock, &r, count.max(1) - 1)?;
            }
            if let Some(b) = back {
                backs.push((f.clone(), b));
            }
            if scanned.repeats > 0 {
                repeats.push((f.clone(), scanned.repeats, scanned.first_repeat + 2));
            }
            let name = f
                .file_stem()
                .map_or(String::new(), |s| s.to_string_lossy().into());
            topics.push(Topic {
                name,
                type_name: match clock.rostopic {
                    true => "rostopic CSV".into(),
                    false => "CSV".into(),
                },
                count: (count - scanned.repeats) as u64,
                first_s,
                last_s,
                schema,
            });
            clocks.push(clock);
        }
        let csv = TopicCsv {
            files,
            clocks,
            untimed,
            torn,
            backs,
            repeats,
        };
        Ok((csv, topics))
    }

    /// The file each topic is read from.
    pub fn file(&self, topic: usize) -> &Path {
        &self.files[topic]
    }

    /// Whether every file is a `rostopic echo -p` export.
    pub fn is_rostopic(&self) -> bool {
        self.clocks.iter().all(|c| c.rostopic)
    }

    /// How the time of each file whose column name gives no unit was read, which CSV files
    /// of the folder were not read (no time column), which were cut short and which have a
    /// time that steps back.
    pub fn notes(&self) -> Vec<String> {
        self.notes_of(&(0..self.files.len()).collect::<Vec<_>>())
    }

    /// [`TopicCsv::notes`] of the files of `topics` only (a folder may hold a day of runs,
    /// and a run reads a few of its files), and the files of the folder that were not read.
    pub fn notes_of(&self, topics: &[usize]) -> Vec<String> {
        let read = |f: &Path| {
            topics
                .iter()
                .any(|&t| self.files.get(t).is_some_and(|g| g == f))
        };
        let name = |f: &Path| {
            f.file_name()
                .map_or(String::new(), |n| n.to_string_lossy().into())
        };
        let inferred = (self.files.iter().zip(&self.clocks))
            .filter(|(f, c)| !c.inferred.is_empty() && read(f))
            .map(|(f, c)| format!("{}: {}", name(f), c.inferred));
        let untimed = self.untimed.iter().map(|f| {
            format!(
                "{}: not read, its header names no time column (`time`, `timestamp`, `t`, `%time`, ...)",
                name(f)
            )
        });
        let torn = self.torn.iter().filter(|f| read(f)).map(|f| {
            format!(
                "{}: its last row is cut short (the recording stopped mid-write): left out",
                name(f)
            )
        });
        let backs = (self.backs.iter()).filter(|(f, _)| read(f)).map(|(f, b)| {
            format!(
                "{}: its time steps back by {:.3} s at {:.3} s after its earliest row (a clock set back while recording, or two recordings in one file): rows are read in time order, so those written after the step are interleaved with those before it; if the file holds two runs, split it at the step",
                name(f),
                b.by_s,
                b.at_s
            )
        });
        let repeats = (self.repeats.iter()).filter(|(f, ..)| read(f)).map(|(f, n, at)| {
            format!(
                "{}: its header comes again {} among its rows, first as row {at} (recordings appended to one file): those rows are skipped",
                name(f),
                if *n == 1 { "once".to_string() } else { format!("{n} times") }
            )
        });
        let later = backs.chain(repeats);
        (inferred.chain(untimed).chain(torn).chain(later)).collect()
    }

    /// Calls `each` with every message of `wanted`, in time order across them.
    pub fn read(
        &self,
        wanted: &[usize],
        each: &mut dyn FnMut(&Message) -> Result<(), LogError>,
    ) -> Result<(), LogError> {
        let mut all: Vec<Message> = Vec::new();
        for &topic in wanted {
            let (f, clock) = (&self.files[topic], &self.clocks[topic]);
            let text = read_text(f)?;
            let (lines, header) = lines_and_header(&text);
            let mut lines = lines.peekable();
            let first = lines.peek().map(|l| cells(l));
            let (node, stamp) = tree(&field_names(&header, clock), first.as_ref(), clock);
            // Row by row, the cells borrowed from the text: a table of millions of rows is
            // neither copied cell by cell nor held twice.
            for (k, line) in lines.enumerate() {
                let r = row(f, line, k, header.len())?;
                if is_header(&r, &header) {
                    continue;
                }
                let cells = fields(&r, clock);
                let stamp_s = stamp
                    .and_then(|c| csv_clock::seconds(cells.get(c)?, 1e-9))
                    .filter(|s| s.is_finite() && *s > 0.0);
                all.push(Message {
                    topic,
                    log_time_s: time_s(f, clock, &r, k)?,
                    stamp_s,
                    value: node.value(&cells),
                });
            }
        }
        all.sort_by(|a, b| a.log_time_s.total_cmp(&b.log_time_s));
        all.iter().try_for_each(each)
    }
}

/// Row `k` (0 after the header) of a file whose header has `width` cells, its cells borrowed;
/// a row with more or fewer cells is an error with its line.
fn row<'a>(path: &Path, line: &'a str, k: usize, width: usize) -> Result<Vec<&'a str>, LogError> {
    let r: Vec<&str> = line.split(',').map(csv_clock::bare).collect();
    if r.len() != width {
        return Err(LogError::new(
            path,
            format!(
                "row {} has {} cells where the header names {width} (a field holding a comma?)",
                k + 2,
                r.len(),
            ),
        )
        .fix("export the topic again (with `rostopic echo -p` for a ROS topic), or leave the topic out"));
    }
    Ok(r)
}

/// The field tree of the field names, numeric where the first row's cell reads as a number,
/// and (in a `rostopic` file) the field of `header.stamp`.
fn tree(names: &[String], first: Option<&Vec<String>>, clock: &Clock) -> (Node, Option<usize>) {
    let first = first.map(|r| fields(r, clock));
    let mut node = Node::default();
    let mut stamp = None;
    for (c, name) in names.iter().enumerate() {
        let numeric = first.as_ref().is_none_or(|r| {
            let cell = r.get(c).map_or("", |s| s.trim());
            cell.is_empty() || cell.parse::<f64>().is_ok()
        });
        let leaf = if numeric { Leaf::F64 } else { Leaf::Text };
        if clock.rostopic && name == "header.stamp" {
            stamp = Some(c);
        }
        let path: Vec<&str> = name.split('.').collect();
        node.insert(&path, c, leaf);
    }
    (node, stamp)
}

mod scan;
#[cfg(test)]
mod tests;
