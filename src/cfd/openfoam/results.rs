//! Parsers of what an OpenFOAM run leaves behind: the solver log (`Time = t` then the
//! sixDoFRigidBodyMotion report), `sixDoFRigidBodyState.dat` and the `forces` `force.dat`.

/// One time step of the solver log.
#[derive(Debug, Clone, PartialEq)]
pub struct LogStep {
    pub t: f64,
    /// The log's line (1-based) of this step's `Time = ` line.
    pub line: usize,
    pub centre: Option<[f64; 3]>,
    pub linear_velocity: Option<[f64; 3]>,
    pub angular_velocity: Option<[f64; 3]>,
}

/// How the log ends.
#[derive(Debug, Clone, PartialEq)]
pub enum LogEnd {
    /// `End` printed: the solver reached its end time.
    Finished,
    /// A `FOAM FATAL ERROR` or a trapped signal (floating point exception, segmentation fault).
    Crashed(String),
    /// The log stops mid-run: the solver was killed, or is still running.
    Truncated,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Log {
    pub steps: Vec<LogStep>,
    pub end: LogEnd,
    /// The last `ExecutionTime = ... s` (CPU seconds of the run).
    pub execution_time_s: Option<f64>,
    pub clock_time_s: Option<f64>,
}

/// `(a b c)` -> three numbers.
pub fn vector(text: &str) -> Option<[f64; 3]> {
    let inner = text.trim().strip_prefix('(')?.strip_suffix(')')?;
    let mut it = inner.split_whitespace().map(|x| x.parse::<f64>());
    let v = [it.next()?.ok()?, it.next()?.ok()?, it.next()?.ok()?];
    it.next().is_none().then_some(v)
}

fn after<'a>(line: &'a str, prefix: &str) -> Option<&'a str> {
    line.trim_start().strip_prefix(prefix).map(str::trim)
}

pub fn parse_log(text: &str) -> Log {
    let mut steps: Vec<LogStep> = Vec::new();
    let mut end = LogEnd::Truncated;
    let (mut exec, mut clock) = (None, None);
    for (i, line) in text.lines().enumerate() {
        if let Some(t) = line
            .strip_prefix("Time = ")
            .and_then(|t| t.trim().parse::<f64>().ok())
        {
            steps.push(LogStep {
                t,
                line: i + 1,
                centre: None,
                linear_velocity: None,
                angular_velocity: None,
            });
        } else if let Some(v) = after(line, "Centre of mass:") {
            // With several outer correctors the body is reported per corrector: the last one wins.
            if let Some(s) = steps.last_mut() {
                s.centre = vector(v);
            }
        } else if let Some(v) = after(line, "Linear velocity:") {
            if let Some(s) = steps.last_mut() {
                s.linear_velocity = vector(v);
            }
        } else if let Some(v) = after(line, "Angular velocity:") {
            if let Some(s) = steps.last_mut() {
                s.angular_velocity = vector(v);
            }
        } else if let Some(rest) = line.strip_prefix("ExecutionTime = ") {
            let mut parts = rest.split_whitespace();
            exec = parts.next().and_then(|x| x.parse().ok());
            clock = rest
                .split("ClockTime = ")
                .nth(1)
                .and_then(|c| c.split_whitespace().next())
                .and_then(|x| x.parse().ok());
        } else if line.trim() == "End" && !matches!(end, LogEnd::Crashed(_)) {
            end = LogEnd::Finished;
        } else if is_crash(line) && !matches!(end, LogEnd::Crashed(_)) {
            end = LogEnd::Crashed(line.trim().trim_start_matches("--> ").to_string());
        }
    }
    // A step whose motion report never came (killed mid-step) carries nothing.
    if !matches!(end, LogEnd::Finished) {
        while steps.last().is_some_and(|s| s.linear_velocity.is_none()) {
            steps.pop();
        }
    }
    Log {
        steps,
        end,
        execution_time_s: exec,
        clock_time_s: clock,
    }
}

/// A line that says the run died. The banner's `trapFpe: Floating point exception trapping
/// enabled` line does not.
fn is_crash(line: &str) -> bool {
    let l = line.trim_start();
    if l.starts_with("trapFpe") {
        return false;
    }
    l.contains("FOAM FATAL")
        || l.contains("sigFpe::sigHandler")
        || l.contains("sigSegv::sigHandler")
        || l.starts_with("Floating point exception")
        || l.starts_with("Segmentation fault")
}

/// The last `n` lines of a log, for error messages.
pub fn tail(text: &str, n: usize) -> String {
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(n)..].join("\n")
}

/// A postProcessing table: time and named vector columns.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VectorTable {
    pub t: Vec<f64>,
    pub columns: Vec<String>,
    pub rows: Vec<Vec<[f64; 3]>>,
    /// The file's line (1-based) of each row.
    pub lines: Vec<usize>,
    pub angle_units: Option<String>,
}

/// The largest magnitude a value of a results table may have: what lies beyond is a damaged
/// file (a diverged run stops with a crash in its log, which is reported first).
pub const MAX_VALUE: f64 = 1e9;

impl VectorTable {
    pub fn column(&self, name: &str) -> Option<Vec<[f64; 3]>> {
        let i = self.columns.iter().position(|c| c == name)?;
        Some(self.rows.iter().map(|r| r[i]).collect())
    }
}

#[derive(Debug, thiserror::Error, PartialEq)]
#[error("line {line}: {msg}")]
pub struct TableError {
    pub line: usize,
    pub msg: String,
}

/// Reads a tab-separated function-object table whose values are `(x y z)` vectors; the
/// column names come from the last `# Time ...` header line. A torn last line (the solver
/// was killed mid-write) is dropped.
pub fn parse_vector_table(text: &str) -> Result<VectorTable, TableError> {
    let mut table = VectorTable::default();
    let lines: Vec<&str> = text.lines().collect();
    let mut line_of: Vec<usize> = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        if let Some(h) = line.strip_prefix('#') {
            let h = h.trim();
            if let Some(u) = h
                .strip_prefix("Angle Units")
                .map(|u| u.trim_start_matches([' ', ':']).trim())
            {
                table.angle_units = Some(u.to_string());
            } else if h.starts_with("Time") {
                table.columns = h
                    .split('\t')
                    .skip(1)
                    .map(|c| c.trim().to_string())
                    .filter(|c| !c.is_empty())
                    .collect();
                if table.columns.len() <= 1 {
                    // Headers written with spaces: names are single words or parenthesised groups.
                    table.columns = split_header(h).into_iter().skip(1).collect();
                }
            }
            continue;
        }
        if line.trim().is_empty() {
            continue;
        }
        let last = i + 1 == lines.len() && !text.ends_with('\n');
        match parse_row(line) {
            Some((t, v)) if v.len() == table.columns.len() || table.columns.is_empty() => {
                check_row(i + 1, line, t, &v)?;
                table.t.push(t);
                table.rows.push(v);
                line_of.push(i + 1);
            }
            _ if last => {}
            _ => {
                return Err(TableError {
                    line: i + 1,
                    msg: format!(
                        "expected a time and {} vectors, found `{}`",
                        table.columns.len(),
                        crate::core::input::clip(line.trim(), 120)
                    ),
                });
            }
        }
    }
    check_lone_times(&table.t, &line_of)?;
    // Restarted runs may repeat times: keep the last row of each, in time order.
    let mut keep: Vec<usize> = Vec::new();
    for k in 0..table.t.len() {
        while keep.last().is_some_and(|&j| table.t[j] >= table.t[k]) {
            keep.pop();
        }
        keep.push(k);
    }
    table.t = keep.iter().map(|&k| table.t[k]).collect();
    table.rows = keep.iter().map(|&k| table.rows[k].clone()).collect();
    table.lines = keep.iter().map(|&k| line_of[k]).collect();
    Ok(table)
}

/// A row's numbers are finite and within [`MAX_VALUE`].
fn check_row(line_no: usize, line: &str, t: f64, v: &[[f64; 3]]) -> Result<(), TableError> {
    let shown = || crate::core::input::clip(line.trim(), 120);
    if !t.is_finite() || v.iter().flatten().any(|x| !x.is_finite()) {
        return Err(TableError {
            line: line_no,
            msg: format!("a value that is not a finite number: `{}`", shown()),
        });
    }
    if let Some(x) = v.iter().flatten().find(|x| x.abs() > MAX_VALUE) {
        return Err(TableError {
            line: line_no,
            msg: format!(
                "the value {x:e} is beyond {MAX_VALUE:e}, which no run of a body writes: the file is damaged (`{}`); rerun the case or restore the file",
                shown()
            ),
        });
    }
    Ok(())
}

/// A time below its predecessor whose successor is above that predecessor again is not a
/// restart (which goes on from the earlier time) but one damaged row; the restart rule would
/// drop every row before it.
fn check_lone_times(t: &[f64], line_of: &[usize]) -> Result<(), TableError> {
    for k in 1..t.len().saturating_sub(1) {
        if t[k] < t[k - 1] && t[k + 1] > t[k - 1] {
            return Err(TableError {
                line: line_of[k],
                msg: format!(
                    "time {} is out of order between {} (line {}) and {} (line {}): the row is damaged, not a restart",
                    t[k],
                    t[k - 1],
                    line_of[k - 1],
                    t[k + 1],
                    line_of[k + 1]
                ),
            });
        }
    }
    // A restart that wrote a single row is far less likely than a damaged last time, and
    // would drop every row after the time it names.
    let n = t.len();
    if n >= 2 && t[n - 1] < t[n - 2] {
        return Err(TableError {
            line: line_of[n - 1],
            msg: format!(
                "the last time, {}, goes back from {} (line {}): a damaged row, or a restart cut off after one row; delete the line if the run was restarted",
                t[n - 1],
                t[n - 2],
                line_of[n - 2]
            ),
        });
    }
    Ok(())
}

fn split_header(h: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut depth = 0;
    for c in h.chars() {
        match c {
            '(' => {
                depth += 1;
                cur.push(c)
            }
            ')' => {
                depth -= 1;
                cur.push(c)
            }
            c if c.is_whitespace() && depth == 0 => {
                if !cur.is_empty() {
                    out.push(std::mem::take(&mut cur));
                }
            }
            c => cur.push(c),
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

fn parse_row(line: &str) -> Option<(f64, Vec<[f64; 3]>)> {
    let open = line.find('(')?;
    let t = line[..open].trim().parse().ok()?;
    let mut v = Vec::new();
    let mut rest = &line[open..];
    while let Some(s) = rest.find('(') {
        let e = rest[s..].find(')')? + s;
        v.push(vector(&rest[s..=e])?);
        rest = &rest[e + 1..];
    }
    rest.trim().is_empty().then_some((t, v))
}

#[cfg(test)]
mod tests;
