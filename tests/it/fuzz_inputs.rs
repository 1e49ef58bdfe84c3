//! Property tests of every importer under mutated input (a bounded fuzz budget, run by CI):
//! no panic, no hang, every message of bounded length with its file, and a number changed in
//! a data row either rejected or reflected in what was read, never silently altered. The seed
//! inputs are the shipped files (pool runs with every kind of log, a navigation log and an
//! actuator log, a STAR-CCM+ export, an OpenFOAM case's tables, log and dictionaries, a
//! run's results read together, the series template, the Slurm settings, run.yaml and
//! pipeline.yaml). `HYDROFIT_FUZZ_CASES` sets the mutations per seed file (default 800, about
//! half a minute on 2 cores).

#![allow(clippy::result_large_err)] // InputError is the library's error, as it returns it

use crate::common::manifest_dir;
use hydrofit::core::rng::Rng;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

mod cfd;

/// No message needs more than this to say what is wrong, where, and the fix.
const MAX_MESSAGE: usize = 4096;
/// A single import taking longer than this is a hang (they take milliseconds).
const HANG: Duration = Duration::from_secs(30);

fn cases_per_seed() -> usize {
    std::env::var("HYDROFIT_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(800)
}

/// Aborts the test process when one import does not return (a `spin` in a solver or a parser
/// would otherwise stall CI until its own time limit, naming nothing).
struct Watchdog {
    beat: &'static AtomicU64,
    start: Instant,
}

impl Watchdog {
    fn new(what: &'static str) -> Watchdog {
        let beat: &'static AtomicU64 = Box::leak(Box::new(AtomicU64::new(0)));
        let start = Instant::now();
        std::thread::spawn(move || {
            loop {
                std::thread::sleep(Duration::from_secs(1));
                let last = Duration::from_millis(beat.load(Ordering::Relaxed));
                if last == Duration::MAX {
                    return;
                }
                if start.elapsed().saturating_sub(last) > HANG {
                    eprintln!("{what}: one import ran for more than {HANG:?}: a hang");
                    std::process::exit(3);
                }
            }
        });
        Watchdog { beat, start }
    }

    fn beat(&self) {
        self.beat
            .store(self.start.elapsed().as_millis() as u64, Ordering::Relaxed);
    }
}

impl Drop for Watchdog {
    fn drop(&mut self) {
        self.beat.store(u64::MAX, Ordering::Relaxed);
    }
}

/// Where a number may be changed: below `header` lines, not in the `frozen` columns (that no
/// importer reads), in a row whose time (column `time_col`) is inside `span`.
#[derive(Clone, Copy)]
struct Rows<'a> {
    header: usize,
    frozen: &'a [usize],
    time_col: usize,
    span: (f64, f64),
}

/// No data rows (a YAML file, a dictionary, a solver log): no value is changed.
const TEXT: Rows = Rows {
    header: usize::MAX,
    frozen: &[],
    time_col: 0,
    span: (f64::NEG_INFINITY, f64::INFINITY),
};

/// One mutation of a text file, and whether it changed exactly one number of a data row to
/// another finite value (the case whose result must differ from the original's).
#[derive(Debug)]
struct Mutated {
    bytes: Vec<u8>,
    what: String,
    value_change: bool,
}

/// The numbers of `line` (after a separator or a bracket): their byte spans and values.
fn number_spans(line: &str) -> Vec<(usize, usize, f64)> {
    let mut out = Vec::new();
    let b = line.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit()
            || ((b[i] == b'-' || b[i] == b'.') && i + 1 < b.len() && b[i + 1].is_ascii_digit());
        let after_sep = i == 0 || matches!(b[i - 1], b',' | b'\t' | b' ' | b'(' | b'"');
        if starts && after_sep {
            let mut j = i + 1;
            while j < b.len()
                && (b[j].is_ascii_alphanumeric() || matches!(b[j], b'.' | b'-' | b'+'))
            {
                j += 1;
            }
            if let Ok(v) = line[i..j].parse::<f64>()
                && v.is_finite()
            {
                out.push((i, j, v));
            }
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

/// Replaces one number of a data line (after `skip_lines` header lines, and not in the
/// columns `frozen`, that no importer reads) with another value.
fn change_a_value(text: &str, rng: &mut Rng, rows: &Rows) -> Option<Mutated> {
    let Rows {
        header: skip_lines,
        frozen,
        time_col,
        span,
    } = *rows;
    let lines: Vec<&str> = text.split_inclusive('\n').collect();
    // A row whose time the next row repeats is superseded (the last row of a time stamp is
    // the one kept, and the notes say how many were dropped): a change there is not read.
    let time = |l: &str| l.split(',').nth(time_col).map(|t| t.trim().to_string());
    let data: Vec<usize> = (skip_lines..lines.len())
        .filter(|&i| lines[i].ends_with('\n') && !lines[i].starts_with('#'))
        .filter(|&i| {
            lines
                .get(i + 1)
                .is_none_or(|next| time(next) != time(lines[i]))
        })
        .filter(|&i| {
            time(lines[i])
                .and_then(|t| t.parse::<f64>().ok())
                .is_none_or(|t| t > span.0 && t < span.1)
        })
        .collect();
    if data.is_empty() {
        return None;
    }
    for _ in 0..20 {
        let li = data[rng.below(data.len())];
        let spans = number_spans(lines[li]);
        let usable: Vec<(usize, (usize, usize, f64))> = spans
            .into_iter()
            .enumerate()
            .filter(|(k, _)| !frozen.contains(k))
            .collect();
        if usable.is_empty() {
            continue;
        }
        let (_, (a, b, v)) = usable[rng.below(usable.len())];
        let nv = if v == 0.0 {
            0.5 + rng.uniform()
        } else {
            v * (1.0 + (0.05 + 0.5 * rng.uniform()) * if rng.uniform() < 0.5 { 1.0 } else { -1.0 })
        };
        let mut line = lines[li].to_string();
        line.replace_range(a..b, &format!("{nv:e}"));
        let mut out: String = lines[..li].concat();
        out.push_str(&line);
        out.push_str(&lines[li + 1..].concat());
        return Some(Mutated {
            bytes: out.into_bytes(),
            what: format!("line {}: {} -> {nv:e}", li + 1, v),
            value_change: true,
        });
    }
    None
}

const TOKENS: [&str; 18] = [
    "nan", "inf", "-inf", "1e300", "", ",", ";", "\t", "\"", "\u{feff}", "0", "-", "e", "..", "\r",
    "\n", "}", ": [",
];

/// One random mutation of `text`.
fn mutate(text: &str, rng: &mut Rng, rows: &Rows) -> Mutated {
    let bytes = text.as_bytes();
    let n = bytes.len().max(1);
    let line_starts: Vec<usize> = std::iter::once(0)
        .chain(text.match_indices('\n').map(|(i, _)| i + 1))
        .filter(|&i| i < text.len())
        .collect();
    let pick_line = |rng: &mut Rng| {
        let k = rng.below(line_starts.len());
        let a = line_starts[k];
        let b = line_starts.get(k + 1).copied().unwrap_or(text.len());
        (k, a, b)
    };
    match rng.below(9) {
        0 => {
            let mut b = bytes.to_vec();
            let i = rng.below(n).min(b.len().saturating_sub(1));
            b[i] ^= 1 << rng.below(8);
            Mutated {
                bytes: b,
                what: format!("bit flipped at byte {i}"),
                value_change: false,
            }
        }
        1 => {
            let i = rng.below(n);
            Mutated {
                bytes: bytes[..i].to_vec(),
                what: format!("cut at byte {i}"),
                value_change: false,
            }
        }
        2 => {
            let (k, a, b) = pick_line(rng);
            let mut v = bytes[..a].to_vec();
            v.extend_from_slice(&bytes[b..]);
            Mutated {
                bytes: v,
                what: format!("line {} deleted", k + 1),
                value_change: false,
            }
        }
        3 => {
            let (k, a, b) = pick_line(rng);
            let mut v = bytes[..b].to_vec();
            v.extend_from_slice(&bytes[a..]);
            Mutated {
                bytes: v,
                what: format!("line {} repeated", k + 1),
                value_change: false,
            }
        }
        4 => {
            let i = rng.below(n).min(bytes.len());
            let i = (0..=i)
                .rev()
                .find(|&j| text.is_char_boundary(j))
                .unwrap_or(0);
            let tok = if rng.uniform() < 0.1 {
                "Q".repeat(200_000)
            } else {
                TOKENS[rng.below(TOKENS.len())].to_string()
            };
            let mut v = bytes[..i].to_vec();
            v.extend_from_slice(tok.as_bytes());
            v.extend_from_slice(&bytes[i..]);
            let shown: String = tok.chars().take(8).collect();
            Mutated {
                bytes: v,
                what: format!("{shown:?} inserted at byte {i}"),
                value_change: false,
            }
        }
        5 => {
            let (k, a, b) = pick_line(rng);
            let mut v = bytes[..a].to_vec();
            v.extend_from_slice(b"0");
            let rest = &text[a..b];
            let cut = rest.find([',', '\t', ' ']).unwrap_or(rest.len());
            v.extend_from_slice(&bytes[a + cut..]);
            Mutated {
                bytes: v,
                what: format!("first field of line {} written over with 0", k + 1),
                value_change: false,
            }
        }
        _ => change_a_value(text, rng, rows).unwrap_or(Mutated {
            bytes: bytes.to_vec(),
            what: "unchanged".into(),
            value_change: false,
        }),
    }
}

/// Checks one import's outcome: a bounded message naming `path`, or, for a changed value, a
/// result that differs from the original's.
fn check<T: PartialEq + std::fmt::Debug, E: std::fmt::Display>(
    path: &str,
    m: &Mutated,
    original: &T,
    got: std::thread::Result<Result<T, E>>,
    failures: &mut Vec<String>,
) {
    match got {
        Err(_) => failures.push(format!("{path}: {}: panicked", m.what)),
        Ok(Err(e)) => {
            let msg = e.to_string();
            if msg.len() > MAX_MESSAGE {
                failures.push(format!(
                    "{path}: {}: message of {} bytes",
                    m.what,
                    msg.len()
                ));
            }
        }
        Ok(Ok(v)) => {
            if m.value_change && v == *original {
                failures.push(format!(
                    "{path}: {}: read, and the result is the original's: the change was lost",
                    m.what
                ));
            }
        }
    }
}

/// The first `keep` seconds of a CSV log (header kept): a short seed fuzzes faster.
fn head_seconds(text: &str, keep: f64) -> String {
    let mut out = String::new();
    for (i, l) in text.split_inclusive('\n').enumerate() {
        if i > 0
            && let Some(t) = l
                .split(',')
                .next()
                .and_then(|t| t.trim().parse::<f64>().ok())
            && t > keep
        {
            break;
        }
        out.push_str(l);
    }
    out
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(manifest_dir().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

fn report(what: &str, failures: Vec<String>, tried: usize) {
    eprintln!(
        "{what}: {tried} mutated inputs, {} failures",
        failures.len()
    );
    assert!(
        failures.is_empty(),
        "{} of {tried} mutated inputs broke a property:\n{}",
        failures.len(),
        failures
            .iter()
            .take(20)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}

/// A pool run folder in a temporary project, each of its logs cut to its first 30 s.
fn pool_seed(run: &str) -> (tempfile::TempDir, String, Vec<(String, String)>) {
    let d = tempfile::tempdir().unwrap();
    let dir = "cases/pool/r".to_string();
    std::fs::create_dir_all(d.path().join(&dir)).unwrap();
    let mut files = Vec::new();
    for e in std::fs::read_dir(manifest_dir().join(run)).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        let text = std::fs::read_to_string(&p).unwrap();
        let text = if name.ends_with(".csv") {
            head_seconds(&text, 30.0)
        } else {
            text
        };
        std::fs::write(d.path().join(&dir).join(&name), &text).unwrap();
        files.push((name, text));
    }
    (d, dir, files)
}

/// The span every CSV log of a run covers, a second in from each end: a row outside it is cut
/// off by the import (which says so in the run's repairs), so a change there is not read.
fn overlap(files: &[(String, String)]) -> (f64, f64) {
    let mut span = (f64::NEG_INFINITY, f64::INFINITY);
    for (name, text) in files.iter().filter(|(n, _)| n.ends_with(".csv")) {
        let t: Vec<f64> = text
            .lines()
            .skip(1)
            .filter_map(|l| l.split(',').next()?.trim().parse().ok())
            .collect();
        if let (Some(a), Some(b)) = (t.first(), t.last()) {
            span = (span.0.max(*a), span.1.min(*b));
        } else {
            panic!("{name} has no rows");
        }
    }
    (span.0 + 1.0, span.1 - 1.0)
}

/// Where a value of the run's file `name` may be changed. A command log written in bursts
/// by receive time gets a regular clock fitted to it (the repair the run reports): its own
/// receive times are then not read, only their lower envelope, so they are not changed.
fn rows_of<'a>(name: &str, text: &str, span: (f64, f64)) -> Rows<'a> {
    if !name.ends_with(".csv") {
        return TEXT;
    }
    let t: Vec<f64> = text
        .lines()
        .skip(1)
        .filter_map(|l| l.split(',').next()?.trim().parse().ok())
        .collect();
    let bursts = t.windows(2).filter(|w| w[1] - w[0] < 1e-3).count();
    Rows {
        header: 1,
        frozen: if bursts * 10 > t.len() { &[0] } else { &[] },
        time_col: 0,
        span,
    }
}

fn load_run(
    root: &Path,
    dir: &str,
    names: &[String],
) -> Result<String, hydrofit::core::diag::InputError> {
    let files: Vec<String> = names.iter().map(|n| format!("{dir}/{n}")).collect();
    // The whole run as read (every log, note and repair), to compare with the original's.
    hydrofit::pool::import::load(root, dir, &files, None).map(|r| format!("{r:?}"))
}

fn fuzz_pool_run(run: &str, seed: u64) {
    let (d, dir, files) = pool_seed(run);
    let names: Vec<String> = files.iter().map(|(n, _)| n.clone()).collect();
    let original = load_run(d.path(), &dir, &names).expect("the seed run loads");
    let dog = Watchdog::new("pool importer");
    let span = overlap(&files);
    let mut rng = Rng::derive(seed, run);
    let mut failures = Vec::new();
    let mut tried = 0;
    for (name, text) in &files {
        let path = PathBuf::from(d.path()).join(&dir).join(name);
        for _ in 0..cases_per_seed() {
            let m = mutate(text, &mut rng, &rows_of(name, text, span));
            std::fs::write(&path, &m.bytes).unwrap();
            dog.beat();
            let got = std::panic::catch_unwind(|| load_run(d.path(), &dir, &names));
            check(&format!("{run}/{name}"), &m, &original, got, &mut failures);
            tried += 1;
        }
        std::fs::write(&path, text).unwrap();
    }
    report(&format!("pool run {run}"), failures, tried);
}

#[test]
fn pool_logs_under_mutation() {
    fuzz_pool_run("cases/pool/mixed", 1);
    fuzz_pool_run("cases/pool/prbs_a", 2);
}

#[test]
fn navigation_and_actuator_logs_under_mutation() {
    fuzz_pool_run("examples/field_rov/cases/pool/box_1", 3);
    fuzz_pool_run("examples/dsrv/cases/pool/steady_1", 4);
}

/// run.yaml shapes a hand edit makes: each an error naming run.yaml and the line.
#[test]
fn run_yaml_shapes_are_located_errors() {
    let (d, dir, files) = pool_seed("cases/pool/prbs_a");
    let names: Vec<String> = files.iter().map(|(n, _)| n.clone()).collect();
    let path = d.path().join(&dir).join("run.yaml");
    for (text, line, says) in [
        ("role: [train]\n", 1, "not a list or a mapping"),
        ("role: {train: 1}\n", 1, "not a list or a mapping"),
        (
            "role: train\n---\nrole: validate\n",
            2,
            "second YAML document",
        ),
        (
            "role: train\ndescription: \"a\u{0}b\"\n",
            2,
            "control character",
        ),
        ("role: train\nrole: validate\n", 2, "duplicate"),
        ("role: trian\n", 1, "expected `train` or `validate`"),
    ] {
        std::fs::write(&path, text).unwrap();
        let e = load_run(d.path(), &dir, &names)
            .expect_err(text)
            .to_string();
        assert!(
            e.contains(&format!("run.yaml:{line}")),
            "{text:?}: not at line {line}: {e}"
        );
        assert!(e.contains(says), "{text:?}: {e}");
        assert!(!e.contains("YAML tag"), "{text:?}: {e}");
    }
}

#[test]
fn pipeline_yaml_under_mutation() {
    let text = read("pipeline.yaml");
    let dog = Watchdog::new("pipeline.yaml parser");
    let mut rng = Rng::derive(7, "pipeline");
    let (mut failures, mut tried) = (Vec::new(), 0);
    for _ in 0..cases_per_seed() * 3 {
        let m = mutate(&text, &mut rng, &TEXT);
        let s = String::from_utf8_lossy(&m.bytes).into_owned();
        dog.beat();
        match std::panic::catch_unwind(|| {
            hydrofit::pipeline::spec::parse("pipeline.yaml", &s, hydrofit::kinds::KINDS).map(|_| ())
        }) {
            Err(_) => failures.push(format!("pipeline.yaml: {}: panicked", m.what)),
            Ok(Err(e)) if e.to_string().len() > MAX_MESSAGE => failures.push(format!(
                "pipeline.yaml: {}: message of {} bytes",
                m.what,
                e.to_string().len()
            )),
            _ => {}
        }
        tried += 1;
    }
    report("pipeline.yaml", failures, tried);
}

/// A byte-order mark in front of any text input changes nothing.
#[test]
fn a_byte_order_mark_changes_nothing() {
    let (d, dir, files) = pool_seed("cases/pool/prbs_a");
    let names: Vec<String> = files.iter().map(|(n, _)| n.clone()).collect();
    let original = load_run(d.path(), &dir, &names).unwrap();
    for (name, text) in &files {
        let path = d.path().join(&dir).join(name);
        std::fs::write(&path, format!("\u{feff}{text}")).unwrap();
        // Only the file's hash differs; what was read is the same.
        assert_eq!(
            load_run(d.path(), &dir, &names).unwrap(),
            original,
            "{name}"
        );
        std::fs::write(&path, text).unwrap();
    }
    let spec = read("pipeline.yaml");
    assert!(
        hydrofit::pipeline::spec::parse(
            "pipeline.yaml",
            &format!("\u{feff}{spec}"),
            hydrofit::kinds::KINDS
        )
        .is_ok()
    );
}
