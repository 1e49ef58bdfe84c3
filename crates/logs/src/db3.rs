//! ROS 2 bags in SQLite (`.db3`), rosbag2's default storage up to ROS 2 Iron (and still
//! written by `ros2 bag record -s sqlite3`): a `topics` table (id, name, type, serialization
//! format) and a `messages` table (topic id, receive time in nanoseconds, the CDR bytes).
//! Since Iron a `message_definitions` table carries each type's `.msg` text; a Humble bag has
//! none, so the common types of [`ros_types`](crate::ros_types) are decoded from the
//! definitions built in, and another type from its `.msg` file where one is found
//! ([`msg_files`](crate::msg_files): the folders the user names, a sourced ROS 2
//! installation's, or beside the bag). A topic of a type found nowhere is listed but refused
//! when read (with the fix: name the folder of its package, or convert the bag to MCAP, which
//! carries its definitions). Messages compressed one
//! by one (`ros2 bag record --compression-mode message`, zstd) are inflated; a bag compressed
//! as a whole file (`.db3.zstd`) is refused with the command that inflates it.
//!
//! A rosbag2 recording is a folder (`metadata.yaml` and one or more storage files):
//! [`storage_file`] finds the file in it.
//!
//! The database is opened read-only and immutable (SQLite's `immutable=1`: no lock, no
//! journal, nothing written beside it), so a bag on a read-only disk or copied without its
//! `-wal` file reads the same.

mod writer;

pub use writer::{Layout, Writer};

use crate::compress::unzstd_whole;
use crate::msg_files;
use crate::msgdef::{self, Flavor};
use crate::value::Schema;
use crate::{LogError, Message, Topic, ros_types, wire};
use rusqlite::{Connection, OpenFlags};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The first bytes of an SQLite database.
pub(crate) const MAGIC: &[u8] = b"SQLite format 3\0";

/// The first bytes of a zstd frame (a message compressed by rosbag2's `message` mode).
const ZSTD_MAGIC: &[u8] = &[0x28, 0xB5, 0x2F, 0xFD];

/// The largest message inflated (a camera image is a few MB; this stops a damaged frame
/// header from asking for gigabytes).
const MAX_MESSAGE: u64 = 256 << 20;

/// The fix for a damaged database.
const DAMAGED: &str = "the bag is damaged or was cut short: copy it again from the vehicle, or \
                       try `sqlite3 bag.db3 .recover | sqlite3 fixed.db3`";

/// An open `.db3` bag: per topic (in the listing's order) its ids in the `topics` table, the
/// `.msg` files its definition was read from and, for a topic that cannot be decoded, why.
#[derive(Debug)]
pub struct Db3 {
    ids: Vec<Vec<i64>>,
    msg_files: Vec<Vec<PathBuf>>,
    refused: Vec<Option<(String, String)>>,
    notes: Vec<String>,
}

/// One row of `topics`.
struct TopicRow {
    id: i64,
    name: String,
    type_name: String,
    format: String,
}

impl Db3 {
    /// Reads the bag's tables and lists its topics (counts and spans from `messages`); a type
    /// the bag does not define is looked for in `msg_folders` ([`msg_files::search_folders`]).
    pub fn open(path: &Path, msg_folders: &[PathBuf]) -> Result<(Db3, Vec<Topic>), LogError> {
        let db = connect(path)?;
        let tables = tables(&db, path)?;
        for t in ["topics", "messages"] {
            if !tables.iter().any(|n| n == t) {
                return Err(LogError::new(
                    path,
                    format!(
                        "an SQLite database, but not a ROS 2 bag: it has no `{t}` table (tables: {})",
                        tables.join(", ")
                    ),
                )
                .fix("give the .db3 file `ros2 bag record` wrote"));
            }
        }
        let defs = if tables.iter().any(|n| n == "message_definitions") {
            definitions(&db, path)?
        } else {
            HashMap::new()
        };
        let rows = topic_rows(&db, path)?;
        let spans = spans(&db, path)?;
        let folders = msg_files::search_folders(path, msg_folders);
        Ok(listing(rows, &defs, &folders, &spans))
    }

    /// Why topic `t` cannot be decoded, and the fix (`None` for a topic that can).
    pub fn refused(&self, t: usize) -> Option<(String, String)> {
        self.refused.get(t).cloned().flatten()
    }

    /// The `.msg` files the definitions of `topics` were read from (none where the bag or the
    /// built-in definitions gave them).
    pub fn msg_files(&self, topics: &[usize]) -> Vec<PathBuf> {
        let mut out: Vec<PathBuf> = (topics.iter())
            .filter_map(|&t| self.msg_files.get(t))
            .flatten()
            .cloned()
            .collect();
        out.sort();
        out.dedup();
        out
    }

    /// What the reader noted: topics whose messages cannot be decoded, and why.
    pub fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    /// Decodes the messages of the topics `wanted`, in receive-time order, and calls `each`.
    pub fn read(
        &self,
        path: &Path,
        topics: &[Topic],
        wanted: &[usize],
        each: &mut dyn FnMut(&Message) -> Result<(), LogError>,
    ) -> Result<(), LogError> {
        if topics.len() != self.ids.len() {
            return Err(LogError::new(
                path,
                "read with other topics than the log's own",
            ));
        }
        let mut of_id: HashMap<i64, usize> = HashMap::new();
        for &w in wanted.iter().filter(|&&w| w < topics.len()) {
            if let Some((what, fix)) = &self.refused[w] {
                return Err(LogError::new(
                    path,
                    format!("topic {} ({}): {what}", topics[w].name, topics[w].type_name),
                )
                .fix(fix.clone()));
            }
            of_id.extend(self.ids[w].iter().map(|&id| (id, w)));
        }
        if of_id.is_empty() {
            return Ok(());
        }
        let list: Vec<String> = of_id.keys().map(i64::to_string).collect();
        let sql = format!(
            "SELECT topic_id, timestamp, data FROM messages WHERE topic_id IN ({}) \
             ORDER BY timestamp, id",
            list.join(",")
        );
        let db = connect(path)?;
        let mut last_s = None;
        let damaged = |e: rusqlite::Error, last: Option<f64>| {
            let after = last.map_or(String::new(), |t: f64| {
                format!(" after the message at t = {t:.6} s")
            });
            LogError::new(
                path,
                format!("the messages table cannot be read{after}: {e}"),
            )
            .fix(DAMAGED)
        };
        let mut stmt = db.prepare(&sql).map_err(|e| damaged(e, None))?;
        let mut rows = stmt.query([]).map_err(|e| damaged(e, None))?;
        while let Some(row) = rows.next().map_err(|e| damaged(e, last_s))? {
            let (id, ns, data): (i64, i64, Vec<u8>) =
                (|| Ok::<_, rusqlite::Error>((row.get(0)?, row.get(1)?, row.get(2)?)))()
                    .map_err(|e| damaged(e, last_s))?;
            let t = of_id[&id];
            let msg = message(path, &topics[t], t, ns, &data)?;
            last_s = Some(msg.log_time_s);
            each(&msg)?;
        }
        Ok(())
    }
}

/// The rosbag2 folder's storage file, or `path` itself when it is a file. A folder must hold
/// exactly one `.db3` or `.mcap` file (a bag split by `--max-bag-size` is one run per file).
pub fn storage_file(path: &Path) -> Result<PathBuf, LogError> {
    if !path.is_dir() {
        return Ok(path.to_path_buf());
    }
    let read = std::fs::read_dir(path)
        .map_err(|e| LogError::new(path, format!("cannot list the folder: {e}")))?;
    let mut found: Vec<PathBuf> = read
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            p.extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("db3") || e.eq_ignore_ascii_case("mcap"))
        })
        .collect();
    found.sort();
    match found.len() {
        1 => Ok(found.remove(0)),
        0 => Err(LogError::new(
            path,
            "a folder with no .db3 or .mcap file (a rosbag2 folder holds metadata.yaml and its storage files)",
        )
        .fix("give the bag's folder or its .db3 / .mcap file")),
        n => Err(LogError::new(
            path,
            format!(
                "a bag split into {n} files ({})",
                found
                    .iter()
                    .filter_map(|p| p.file_name())
                    .map(|n| n.to_string_lossy())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )
        .fix("give one file as `log.file` (one run folder per file), or merge them with `ros2 bag convert`")),
    }
}

/// Opens the database read-only and immutable (see the module's text).
fn connect(path: &Path) -> Result<Connection, LogError> {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let uri = format!("file:{}?immutable=1", uri_path(&abs));
    let flags = OpenFlags::SQLITE_OPEN_READ_ONLY
        | OpenFlags::SQLITE_OPEN_URI
        | OpenFlags::SQLITE_OPEN_NO_MUTEX;
    Connection::open_with_flags(&uri, flags).map_err(|e| {
        LogError::new(path, format!("cannot open the bag's database: {e}")).fix(DAMAGED)
    })
}

/// A path as an SQLite URI path: bytes other than unreserved ones and `/` percent-encoded.
fn uri_path(p: &Path) -> String {
    let mut out = String::new();
    for b in p.to_string_lossy().bytes() {
        if b.is_ascii_alphanumeric() || b"/-._~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

fn sql_error(path: &Path, what: &str) -> impl Fn(rusqlite::Error) -> LogError {
    move |e| LogError::new(path, format!("{what}: {e}")).fix(DAMAGED)
}

fn tables(db: &Connection, path: &Path) -> Result<Vec<String>, LogError> {
    let fail = sql_error(path, "the database's table list cannot be read");
    let mut stmt = db
        .prepare("SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")
        .map_err(&fail)?;
    let names = stmt.query_map([], |r| r.get(0)).map_err(&fail)?;
    names.collect::<Result<_, _>>().map_err(&fail)
}

/// `message_definitions`: per type name, (encoding, text).
fn definitions(
    db: &Connection,
    path: &Path,
) -> Result<HashMap<String, (String, String)>, LogError> {
    let fail = sql_error(path, "the message_definitions table cannot be read");
    let mut stmt = db
        .prepare("SELECT topic_type, encoding, encoded_message_definition FROM message_definitions")
        .map_err(&fail)?;
    let rows = stmt
        .query_map([], |r| Ok((r.get(0)?, (r.get(1)?, r.get(2)?))))
        .map_err(&fail)?;
    rows.collect::<Result<_, _>>().map_err(&fail)
}

fn topic_rows(db: &Connection, path: &Path) -> Result<Vec<TopicRow>, LogError> {
    let fail = sql_error(path, "the topics table cannot be read");
    let mut stmt = db
        .prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY name, id")
        .map_err(&fail)?;
    let rows = stmt
        .query_map([], |r| {
            Ok(TopicRow {
                id: r.get(0)?,
                name: r.get(1)?,
                type_name: r.get(2)?,
                format: r.get(3)?,
            })
        })
        .map_err(&fail)?;
    rows.collect::<Result<_, _>>().map_err(&fail)
}

/// Per topic id: (message count, first and last receive time in nanoseconds).
fn spans(db: &Connection, path: &Path) -> Result<HashMap<i64, (u64, i64, i64)>, LogError> {
    let fail = sql_error(path, "the messages table cannot be read");
    let mut stmt = db
        .prepare(
            "SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp) FROM messages GROUP BY topic_id",
        )
        .map_err(&fail)?;
    let rows = stmt
        .query_map([], |r| {
            Ok((
                r.get(0)?,
                (r.get::<_, i64>(1)? as u64, r.get(2)?, r.get(3)?),
            ))
        })
        .map_err(&fail)?;
    rows.collect::<Result<_, _>>().map_err(&fail)
}

/// The topics, one per name and type (rows of one topic, as rosbag2 writes when a topic is
/// recorded again after a restart, are merged).
fn listing(
    rows: Vec<TopicRow>,
    defs: &HashMap<String, (String, String)>,
    folders: &[PathBuf],
    spans: &HashMap<i64, (u64, i64, i64)>,
) -> (Db3, Vec<Topic>) {
    let mut db3 = Db3 {
        ids: Vec::new(),
        msg_files: Vec::new(),
        refused: Vec::new(),
        notes: Vec::new(),
    };
    let mut topics: Vec<Topic> = Vec::new();
    for row in rows {
        let (count, first, last) = spans.get(&row.id).copied().unwrap_or((0, 0, 0));
        let to_s = |ns: i64| wire::ns_to_s(ns.max(0) as u64);
        if let Some(t) = topics
            .iter()
            .position(|t| t.name == row.name && t.type_name == row.type_name)
        {
            db3.ids[t].push(row.id);
            let topic = &mut topics[t];
            if count > 0 {
                if topic.count == 0 {
                    (topic.first_s, topic.last_s) = (to_s(first), to_s(last));
                }
                topic.first_s = topic.first_s.min(to_s(first));
                topic.last_s = topic.last_s.max(to_s(last));
                topic.count += count;
            }
            continue;
        }
        let (schema, files, refused) = match schema_of(&row, defs, folders) {
            Ok((s, files)) => (s, files, None),
            Err((what, fix)) => {
                db3.notes.push(format!(
                    "topic {} ({}) cannot be decoded: {what}",
                    row.name, row.type_name
                ));
                (Schema { fields: Vec::new() }, Vec::new(), Some((what, fix)))
            }
        };
        db3.ids.push(vec![row.id]);
        db3.msg_files.push(files);
        db3.refused.push(refused);
        topics.push(Topic {
            name: row.name,
            type_name: row.type_name,
            count,
            first_s: if count > 0 { to_s(first) } else { 0.0 },
            last_s: if count > 0 { to_s(last) } else { 0.0 },
            schema,
        });
    }
    (db3, topics)
}

/// The layout of a topic's messages, and the `.msg` files it was read from: from the bag's
/// own definition, else from the ones built in, else from a `.msg` file under `folders`;
/// `Err((what, fix))` when none gives one.
fn schema_of(
    row: &TopicRow,
    defs: &HashMap<String, (String, String)>,
    folders: &[PathBuf],
) -> Result<(Schema, Vec<PathBuf>), (String, String)> {
    if row.format != "cdr" {
        return Err((
            format!("its messages are serialized as `{}`, not CDR", row.format),
            "record the topic with rosbag2's default (CDR) serialization".into(),
        ));
    }
    let own = defs
        .get(&row.type_name)
        .filter(|(enc, text)| enc == "ros2msg" && !text.trim().is_empty());
    let (text, files, damaged) = match own {
        Some((_, text)) => (text.clone(), Vec::new(), BAG_DEFINITION_DAMAGED),
        None => match ros_types::ros2(&row.type_name) {
            Some(text) => (text, Vec::new(), BAG_DEFINITION_DAMAGED),
            None => match msg_files::definition(&row.type_name, folders) {
                Ok(Some(found)) => (found.text, found.files, MSG_FILE_DAMAGED),
                Ok(None) => return Err(not_defined(row, defs, folders)),
                Err(e) => return Err((
                    format!("its .msg file was found, but: {e}"),
                    "give every .msg file the type uses, in its package's `msg/` folder (run.yaml `log: {message_folders: [...]}`)".into(),
                )),
            },
        },
    };
    let schema = msgdef::schema(&text, &row.type_name, Flavor::Ros2).map_err(|e| {
        let shown: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
        let from = match shown.is_empty() {
            true => String::new(),
            false => format!(" (read from {})", shown.join(", ")),
        };
        (
            format!("its definition cannot be read{from}: {e}"),
            damaged.into(),
        )
    })?;
    Ok((schema, files))
}

const BAG_DEFINITION_DAMAGED: &str =
    "the bag's message_definitions table is damaged or was written by a non-standard tool";
const MSG_FILE_DAMAGED: &str =
    "check the .msg file against the one the vehicle's software was built with";

/// Why a topic's type has no definition, and the fixes.
fn not_defined(
    row: &TopicRow,
    defs: &HashMap<String, (String, String)>,
    folders: &[PathBuf],
) -> (String, String) {
    let why = match defs.get(&row.type_name) {
        Some((enc, _)) if enc != "ros2msg" => {
            format!("the bag defines the type as `{enc}`, which is not read")
        }
        _ => format!(
            "the bag does not carry its definition (a .db3 of ROS 2 Humble or older never \
             does), hydrofit has none built in, and no `{}.msg` was found in {} (nor in a \
             subfolder of one)",
            ros_types::ros2_name(&row.type_name),
            folders
                .iter()
                .map(|f| f.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let fix = format!(
        "name the folder holding the type's package (`{}/msg/*.msg`, from the vehicle's \
         workspace) in run.yaml's `log: {{message_folders: [...]}}` (`hydrofit inspect \
         --msg-folder DIR`), or source the ROS 2 workspace that builds it \
         (`AMENT_PREFIX_PATH`), or convert the bag to MCAP, which carries every type's \
         definition (`ros2 bag convert -i BAG -o out.yaml` with `storage_id: mcap`); the \
         built-in types: {}",
        msgdef::short_name(&row.type_name)
            .split('/')
            .next()
            .unwrap_or_default(),
        ros_types::COMMON.join(", ")
    );
    (why, fix)
}

/// Decodes one row of `messages`.
fn message(
    path: &Path,
    topic: &Topic,
    t: usize,
    ns: i64,
    data: &[u8],
) -> Result<Message, LogError> {
    let time_s = wire::ns_to_s(ns.max(0) as u64);
    let fail = |what: String| {
        LogError::new(
            path,
            format!(
                "topic {} ({}), the message at t = {time_s:.6} s: {what}",
                topic.name, topic.type_name
            ),
        )
    };
    let inflated;
    let payload = if data.starts_with(ZSTD_MAGIC) {
        inflated = unzstd_whole(data, MAX_MESSAGE).map_err(|e| fail(e).fix(DAMAGED))?;
        &inflated[..]
    } else {
        data
    };
    let value = wire::decode_cdr(&topic.schema, payload).map_err(|e| {
        fail(format!("it does not match its type: {e}"))
            .fix("the bag was written with another version of this message type, or is damaged")
    })?;
    Ok(Message {
        topic: t,
        log_time_s: time_s,
        stamp_s: wire::header_stamp(&topic.schema, &value),
        value,
    })
}
