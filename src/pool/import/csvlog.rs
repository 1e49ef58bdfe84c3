//! Sensor and command logs: comma-separated, a header line, a time column `t` first, numbers
//! only. Every problem is an `InputError` naming file, line, column and the fix.

use crate::core::diag::InputError;
use crate::core::input::{PLAUSIBLE, clip};

/// A parsed log: the time column and the requested columns, in the requested order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Log {
    pub t: Vec<f64>,
    pub cols: Vec<Vec<f64>>,
    /// What was done to the data (repeated times dropped, extra columns ignored).
    pub notes: Vec<String>,
    /// Which of the requested columns (after `t`) the file has; a missing one is all NaN.
    pub present: Vec<bool>,
}

impl Log {
    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    pub fn row(&self, k: usize) -> Vec<f64> {
        self.cols.iter().map(|c| c[k]).collect()
    }

    /// Whether column `c` (0 = the first after `t`) was in the file.
    pub fn has(&self, c: usize) -> bool {
        self.present.get(c).copied().unwrap_or(false)
    }

    /// The column, when the file had it.
    pub fn col(&self, c: usize) -> Option<&[f64]> {
        self.has(c).then(|| self.cols[c].as_slice())
    }

    /// Keeps the last of the rows that share a time stamp (a logger writing twice in one
    /// tick, inner iterations written out), and says how many were dropped.
    pub fn dedupe_times(&mut self, path: &str) {
        let n = self.t.len();
        let keep: Vec<usize> = (0..n)
            .filter(|&k| k + 1 == n || self.t[k + 1] != self.t[k])
            .collect();
        if keep.len() == n {
            return;
        }
        self.notes.push(format!(
            "{path}: {} rows repeated a time stamp; the last of each was kept",
            n - keep.len()
        ));
        self.keep_rows(&keep);
    }

    /// Keeps rows `rows` (ascending) of the time and every column.
    pub fn keep_rows(&mut self, rows: &[usize]) {
        self.t = rows.iter().map(|&k| self.t[k]).collect();
        for c in &mut self.cols {
            *c = rows.iter().map(|&k| c[k]).collect();
        }
    }
}

fn unquote(s: &str) -> &str {
    let s = s.trim();
    s.strip_prefix('"')
        .and_then(|x| x.strip_suffix('"'))
        .unwrap_or(s)
}

/// Parses `text` (the file `path`) expecting the columns `columns`, the first of which is the
/// time `t`. Column names match ignoring case and surrounding quotes; extra columns are ignored.
/// `what` names the log for messages ("UWB log"), `source` says where such a file comes from.
pub fn parse(
    path: &str,
    text: &str,
    columns: &[&str],
    what: &str,
    min_rows: usize,
) -> Result<Log, InputError> {
    let mut log = parse_columns(path, text, columns, columns.len(), what, min_rows)?;
    log.dedupe_times(path);
    Ok(log)
}

/// As [`parse`], but rows that repeat a time stamp are kept: a log written by receive time
/// holds many distinct rows within one tick of its clock, which only a clock repair
/// ([`crate::pool::import::timing`]) can place; call [`Log::dedupe_times`] when no repair applies. Only the
/// first `required` columns must be there (the others are NaN when missing).
pub fn parse_keeping_repeats(
    path: &str,
    text: &str,
    columns: &[&str],
    required: usize,
    what: &str,
    min_rows: usize,
) -> Result<Log, InputError> {
    parse_columns(path, text, columns, required, what, min_rows)
}

/// As [`parse`], but only `t` and the first `required - 1` data columns must be there; the
/// others may be missing (a navigation log without rates, an AHRS without accelerometers),
/// are NaN in the log, and are named in its notes. A file with none of them is an error.
pub fn parse_subset(
    path: &str,
    text: &str,
    columns: &[&str],
    what: &str,
    min_rows: usize,
) -> Result<Log, InputError> {
    let mut log = parse_columns(path, text, columns, 1, what, min_rows)?;
    log.dedupe_times(path);
    Ok(log)
}

/// As [`parse_subset`], and a value may be missing in a row (empty, or `nan` as loggers
/// write it: a DVL that lost bottom lock): it is NaN in the log, left out of its channel, and
/// counted in the notes. Time must still be a number in every row.
pub fn parse_subset_with_gaps(
    path: &str,
    text: &str,
    columns: &[&str],
    what: &str,
    min_rows: usize,
) -> Result<Log, InputError> {
    let mut log = parse_columns_gaps(path, text, columns, 1, what, min_rows, true)?;
    log.dedupe_times(path);
    Ok(log)
}

fn parse_columns(
    path: &str,
    text: &str,
    columns: &[&str],
    required: usize,
    what: &str,
    min_rows: usize,
) -> Result<Log, InputError> {
    parse_columns_gaps(path, text, columns, required, what, min_rows, false)
}

fn parse_columns_gaps(
    path: &str,
    text: &str,
    columns: &[&str],
    required: usize,
    what: &str,
    min_rows: usize,
    gaps: bool,
) -> Result<Log, InputError> {
    let whole = crate::core::input::Text::new(text);
    let (text, torn) = whole.complete_lines(path);
    let spec = Spec {
        path,
        text,
        columns,
        required,
        what,
        min_rows,
        gaps,
    };
    let mut lines = numbered_lines(text);
    let Some((hline, header)) = lines.next() else {
        return Err(spec.empty());
    };
    let layout = spec.read_header(hline, header)?;
    let mut log = Log {
        t: Vec::new(),
        cols: vec![Vec::new(); columns.len() - 1],
        notes: spec.header_notes(&layout).into_iter().chain(torn).collect(),
        present: layout.present[1..].to_vec(),
    };
    let mut missing_values = 0usize;
    for (lno, line) in lines {
        let row = spec.read_row(lno, line, &layout, &mut missing_values)?;
        spec.push_row(&mut log, lno, row)?;
    }
    spec.finish(log, hline, missing_values)
}

/// The non-blank lines of `text`, numbered from 1, without a trailing `\r`.
fn numbered_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
        .filter(|(_, l)| !l.trim().is_empty())
}

/// 1-based character column where field `i` of a split line starts.
fn column_of(fields: &[&str], i: usize) -> usize {
    fields[..i].iter().map(|f| f.len() + 1).sum::<usize>() + 1
}

/// What the caller expects of one log, and the text it is read from.
struct Spec<'a> {
    path: &'a str,
    text: &'a str,
    columns: &'a [&'a str],
    /// How many of `columns`, from `t` on, the header must have.
    required: usize,
    what: &'a str,
    min_rows: usize,
    /// Whether a data value may be missing (empty or `nan`).
    gaps: bool,
}

/// The header as read: its column names, and where each expected column is.
struct Layout<'t> {
    names: Vec<&'t str>,
    /// Position in the file of each expected column; `usize::MAX` when it is absent.
    index: Vec<usize>,
    /// Whether each expected column is in the file.
    present: Vec<bool>,
}

impl Spec<'_> {
    /// An error located at `line` (and `col`) with that line of the file shown.
    fn err(&self, line: usize, col: Option<usize>, msg: String, fix: String) -> InputError {
        InputError::file(self.path, msg, fix)
            .at(line, col)
            .with_source(self.text)
    }

    /// The error for a file without even a header.
    fn empty(&self) -> InputError {
        let what = self.what;
        InputError::file(
            self.path,
            format!("the {what} is empty"),
            format!(
                "write the header `{}` and one row per sample",
                self.columns.join(",")
            ),
        )
    }

    /// Splits the header and finds the expected columns in it.
    fn read_header<'t>(&self, hline: usize, header: &'t str) -> Result<Layout<'t>, InputError> {
        let names: Vec<&str> = header.split(',').map(unquote).collect();
        self.check_delimiter(hline, header, &names)?;
        self.check_repeated(hline, &names)?;
        let mut index = Vec::with_capacity(self.columns.len());
        let mut present = Vec::with_capacity(self.columns.len());
        for (ci, c) in self.columns.iter().enumerate() {
            match names.iter().position(|n| n.eq_ignore_ascii_case(c)) {
                Some(i) => {
                    index.push(i);
                    present.push(true);
                }
                None if ci >= self.required => {
                    index.push(usize::MAX);
                    present.push(false);
                }
                None => return Err(self.missing_column(hline, c, &names)),
            }
        }
        self.check_any_optional(hline, &present)?;
        Ok(Layout {
            names,
            index,
            present,
        })
    }

    /// A column name used twice (ignoring case): which one is meant cannot be told.
    fn check_repeated(&self, hline: usize, names: &[&str]) -> Result<(), InputError> {
        for (i, n) in names.iter().enumerate() {
            if let Some(j) = names[..i].iter().position(|m| m.eq_ignore_ascii_case(n)) {
                let fields: Vec<&str> = names.to_vec();
                return Err(self.err(
                    hline,
                    Some(column_of(&fields, i)),
                    format!(
                        "column `{}` appears twice in the header (columns {} and {})",
                        clip(n, 60),
                        j + 1,
                        i + 1
                    ),
                    "rename or remove one of them: which one holds the data cannot be told".into(),
                ));
            }
        }
        Ok(())
    }

    /// A header of one column when more are expected: another delimiter, most likely.
    fn check_delimiter(
        &self,
        hline: usize,
        header: &str,
        names: &[&str],
    ) -> Result<(), InputError> {
        if names.len() != 1 || self.columns.len() <= 1 {
            return Ok(());
        }
        let delim = [';', '\t', ' '].into_iter().find(|d| header.contains(*d));
        let fix = match delim {
            Some(d) => format!(
                "the file is separated by {:?}; write it with commas: `{}`",
                d,
                self.columns.join(",")
            ),
            None => format!("the header must be `{}`", self.columns.join(",")),
        };
        Err(self.err(
            hline,
            Some(1),
            format!(
                "the header has one column; expected {}",
                self.columns.join(",")
            ),
            fix,
        ))
    }

    /// The error for a required column `c` the header lacks, naming a close unexpected name.
    fn missing_column(&self, hline: usize, c: &str, names: &[&str]) -> InputError {
        let (columns, what) = (self.columns, self.what);
        let hint = crate::core::diag::nearest(
            c,
            names
                .iter()
                .copied()
                .filter(|n| !columns.iter().any(|x| x.eq_ignore_ascii_case(n))),
        )
        .map_or(String::new(), |n| {
            format!(" (`{}` is close; rename it)", clip(n, 60))
        });
        self.err(
            hline,
            None,
            format!("the {what} has no `{c}` column{hint}"),
            format!(
                "the header must name the columns {} (in any order)",
                columns.join(",")
            ),
        )
    }

    /// A log whose data columns are all optional must still have one of them.
    fn check_any_optional(&self, hline: usize, present: &[bool]) -> Result<(), InputError> {
        let (columns, what) = (self.columns, self.what);
        if self.required < columns.len() && !present[1..].iter().any(|p| *p) {
            return Err(self.err(
                hline,
                None,
                format!(
                    "the {what} has none of its columns {}",
                    columns[1..].join(",")
                ),
                format!(
                    "the header must be `t` and any of {}",
                    columns[1..].join(",")
                ),
            ));
        }
        Ok(())
    }

    /// Notes on the header: the expected columns it lacks, the columns it has that are ignored.
    fn header_notes(&self, layout: &Layout) -> Vec<String> {
        let path = self.path;
        let mut notes = Vec::new();
        let missing: Vec<&str> = self
            .columns
            .iter()
            .zip(&layout.present)
            .filter(|(_, p)| !**p)
            .map(|(c, _)| *c)
            .collect();
        if !missing.is_empty() {
            notes.push(format!(
                "{path}: no {} column{}; used what is there",
                missing.join(", "),
                if missing.len() > 1 { "s" } else { "" }
            ));
        }
        let extra: Vec<String> = layout
            .names
            .iter()
            .enumerate()
            .filter(|(i, _)| !layout.index.contains(i))
            .map(|(_, n)| clip(n, 60))
            .collect();
        if !extra.is_empty() {
            notes.push(format!(
                "{path}: ignored columns {}",
                clip(&extra.join(", "), 400)
            ));
        }
        notes
    }

    /// The expected columns' values in one data line (NaN for an absent column or a gap),
    /// and the character column of its time.
    fn read_row(
        &self,
        lno: usize,
        line: &str,
        layout: &Layout,
        missing_values: &mut usize,
    ) -> Result<(Vec<f64>, usize), InputError> {
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != layout.names.len() {
            return Err(self.err(
                lno,
                None,
                format!("{} fields on this line, {} in the header", fields.len(), layout.names.len()),
                "every row needs one value per header column; a truncated last line means the log was cut off: delete it".into(),
            ));
        }
        let mut row = Vec::with_capacity(self.columns.len());
        for (&i, name) in layout.index.iter().zip(self.columns) {
            if i == usize::MAX {
                row.push(f64::NAN);
                continue;
            }
            let raw = unquote(fields[i]).trim();
            if self.gaps
                && i != layout.index[0]
                && (raw.is_empty() || raw.eq_ignore_ascii_case("nan"))
            {
                *missing_values += 1;
                row.push(f64::NAN);
                continue;
            }
            row.push(self.read_value(lno, column_of(&fields, i), raw, name)?);
        }
        Ok((row, column_of(&fields, layout.index[0])))
    }

    /// One value: a finite number, or an error that says how to fix the row.
    fn read_value(&self, lno: usize, col: usize, raw: &str, name: &str) -> Result<f64, InputError> {
        let v: f64 = raw.parse().map_err(|_| {
            let fix = if raw.contains(';') || raw.matches('.').count() == 0 && raw.contains(',') {
                "use a point as the decimal separator and commas between columns".to_string()
            } else {
                format!("`{name}` must be a number; fix or delete this row")
            };
            self.err(
                lno,
                Some(col),
                format!("`{}` in column `{name}` is not a number", clip(raw, 40)),
                fix,
            )
        })?;
        if !v.is_finite() {
            return Err(self.err(
                lno,
                Some(col),
                format!("`{raw}` in column `{name}` is not a finite number"),
                "a sensor dropout should be a missing row, not NaN or inf: delete this row".into(),
            ));
        }
        if name != self.columns[0] && v.abs() > PLAUSIBLE {
            return Err(self.err(
                lno,
                Some(col),
                format!("`{raw}` in column `{name}` is beyond any value this log can hold (|x| > {PLAUSIBLE:e})"),
                "the value is damaged (a cut-off or merged number): fix or delete this row".into(),
            ));
        }
        Ok(v)
    }

    /// Appends a row (time first, at character column `t_col`); time may not go backwards.
    fn push_row(
        &self,
        log: &mut Log,
        lno: usize,
        (row, t_col): (Vec<f64>, usize),
    ) -> Result<(), InputError> {
        let t = row[0];
        if let Some(&prev) = log.t.last()
            && t < prev
        {
            return Err(self.err(
                lno,
                Some(t_col),
                format!("time goes backwards: t = {t} after t = {prev}"),
                "the log must be in time order; two recordings appended into one file must be split into two runs".into(),
            ));
        }
        log.t.push(t);
        for (c, v) in log.cols.iter_mut().zip(&row[1..]) {
            c.push(*v);
        }
        Ok(())
    }

    /// Notes the gaps and checks that enough rows were read.
    fn finish(&self, mut log: Log, hline: usize, missing_values: usize) -> Result<Log, InputError> {
        let (path, what, min_rows) = (self.path, self.what, self.min_rows);
        if missing_values > 0 {
            log.notes.push(format!(
                "{path}: {missing_values} values missing (empty or nan), left out of their channel"
            ));
        }
        if log.len() < min_rows {
            return Err(InputError::file(
                path,
                format!(
                    "the {what} has {} data rows; at least {min_rows} are needed",
                    log.len()
                ),
                "check that the recording was not cut off".to_string(),
            )
            .at(hline, None));
        }
        Ok(log)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const COLS: [&str; 3] = ["t", "x_m", "y_m"];

    fn p(text: &str) -> Result<Log, InputError> {
        parse("cases/pool/r/sonar.csv", text, &COLS, "sonar log", 2)
    }

    #[test]
    fn reads_columns_in_any_order_and_keeps_the_last_repeat() {
        let log = p("y_m,t,x_m,extra\n2,0.0,1,9\n3,0.2,1.5,9\n4,0.2,1.6,9\n").unwrap();
        assert_eq!(log.t, vec![0.0, 0.2]);
        assert_eq!(log.cols, vec![vec![1.0, 1.6], vec![2.0, 4.0]]);
        assert_eq!(log.notes.len(), 2);
    }

    #[test]
    fn each_bad_input_is_located() {
        let cases: [(&str, &str); 7] = [
            ("", "empty"),
            ("t;x_m;y_m\n0;1;2\n", "separated by ';'"),
            ("t,x_m,ym\n0,1,2\n", "no `y_m` column (`ym` is close"),
            ("t,x_m,y_m\n0,1,2\n0.2,1\n", ":3: 2 fields"),
            (
                "t,x_m,y_m\n0,1,2\n0.2,abc,2\n",
                ":3:5: `abc` in column `x_m`",
            ),
            ("t,x_m,y_m\n0,1,2\n0.2,nan,2\n", "not a finite number"),
            ("t,x_m,y_m\n0.4,1,2\n0.2,1,2\n", "time goes backwards"),
        ];
        for (text, want) in cases {
            let e = p(text).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
            assert!(e.contains("help:"), "{e}");
        }
        let e = p("t,x_m,y_m\n0,1,2\n").unwrap_err().to_string();
        assert!(e.contains("1 data rows"), "{e}");
        for (text, want) in [
            (
                "t,x_m,X_M\n0,1,2\n1,1,2\n",
                ":1:7: column `X_M` appears twice",
            ),
            (
                "t,x_m,y_m\n0,1,2\n1,1e300,2\n",
                ":3:3: `1e300` in column `x_m` is beyond",
            ),
        ] {
            let e = p(text).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
        }
        let long = format!("t,x_m,y_m,{}\n0,1,2,3\n", "z".repeat(1_000_000));
        let e = p(&long).unwrap_err().to_string();
        assert!(e.len() < 2_000, "{} bytes", e.len());
    }

    #[test]
    fn a_byte_order_mark_is_read_and_a_torn_last_row_left_out() {
        let log = p("\u{feff}t,x_m,y_m\n0,1,2\n0.1,1,2\n0.2,4.49034339e-1,1.1").unwrap();
        assert_eq!(log.t, vec![0.0, 0.1]);
        assert!(
            log.notes
                .iter()
                .any(|n| n.contains(":4: the last line has no newline")),
            "{:?}",
            log.notes
        );
    }
}
