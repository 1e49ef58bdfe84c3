//! Progress bars on stderr, drawn only on a terminal (quiet when piped or in CI).

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::time::Duration;

pub struct Progress {
    multi: MultiProgress,
}

impl Progress {
    pub fn new() -> Progress {
        // indicatif hides a stderr target that is not a terminal.
        Progress {
            multi: MultiProgress::with_draw_target(ProgressDrawTarget::stderr()),
        }
    }

    pub fn hidden() -> Progress {
        Progress {
            multi: MultiProgress::with_draw_target(ProgressDrawTarget::hidden()),
        }
    }

    pub fn bar(&self, len: u64, what: &str) -> ProgressBar {
        let b = self.multi.add(ProgressBar::new(len));
        b.set_style(
            ProgressStyle::with_template("{prefix} [{elapsed}] {wide_bar} {pos}/{len}")
                .expect("valid template"),
        );
        b.set_prefix(what.to_string());
        b
    }

    /// A spinner for one running stage instance; stages may set a message or a length on it.
    pub fn spinner(&self, id: &str) -> ProgressBar {
        let s = self.multi.add(ProgressBar::new_spinner());
        s.set_style(
            ProgressStyle::with_template("  {spinner} {prefix} {msg}").expect("valid template"),
        );
        s.set_prefix(id.to_string());
        s.enable_steady_tick(Duration::from_millis(120));
        s
    }

    /// Prints a line above the bars (or plainly, to stderr, when they are hidden).
    pub fn println(&self, line: impl AsRef<str>) {
        if self.multi.is_hidden() {
            eprintln!("{}", line.as_ref());
        } else {
            let _ = self.multi.println(line.as_ref());
        }
    }
}

impl Default for Progress {
    fn default() -> Self {
        Progress::new()
    }
}
