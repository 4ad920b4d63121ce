//! Progress of long commands (`train`, `eval`, `record`, `bench`): an `indicatif` bar (known
//! total) or spinner (stages) on stderr **only when stderr is a terminal**. Anywhere else — CI
//! logs, journald, a pipe — nothing is drawn and no progress line is written: what a command
//! prints as its result, and the log lines it writes through [`Progress::println`], are the same
//! either way.
//!
//! ```
//! use mosaicd::progress::Progress;
//! let p = Progress::with_display(false, "frames", Some(3)); // as off a terminal
//! for i in 0..3 {
//!     p.set(i + 1, "kodim01");
//! }
//! p.finish();
//! assert!(!p.is_shown());
//! ```

use std::io::IsTerminal;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};

/// Redraw rate of a spinner (its elapsed time moves even while a stage runs).
const SPINNER_TICK: Duration = Duration::from_millis(200);

/// A progress display: shown, or nothing at all.
#[derive(Debug)]
pub struct Progress {
    bar: Option<ProgressBar>,
}

impl Progress {
    /// A bar over `total` steps (a spinner when `None`), labelled `label`; shown only when stderr
    /// is a terminal.
    pub fn new(label: &str, total: Option<u64>) -> Self {
        Self::with_display(std::io::stderr().is_terminal(), label, total)
    }

    /// As [`Progress::new`], shown only when `display` (tests; callers with their own `--quiet`).
    pub fn with_display(display: bool, label: &str, total: Option<u64>) -> Self {
        if !display {
            return Self { bar: None };
        }
        let bar = match total {
            Some(n) => {
                let b = ProgressBar::new(n);
                b.set_style(
                    ProgressStyle::with_template(
                        "{prefix} [{bar:30}] {pos}/{len} {wide_msg} {elapsed_precise} (eta {eta})",
                    )
                    .expect("a valid template")
                    .progress_chars("=> "),
                );
                b
            }
            None => {
                let b = ProgressBar::new_spinner();
                b.set_style(
                    ProgressStyle::with_template("{spinner} {prefix} {elapsed_precise} {wide_msg}")
                        .expect("a valid template"),
                );
                b.enable_steady_tick(SPINNER_TICK);
                b
            }
        };
        bar.set_prefix(label.to_string());
        Self { bar: Some(bar) }
    }

    /// Whether anything is drawn.
    pub fn is_shown(&self) -> bool {
        self.bar.is_some()
    }

    /// `done` steps finished, working on `what`.
    pub fn set(&self, done: u64, what: &str) {
        if let Some(b) = &self.bar {
            b.set_position(done);
            b.set_message(what.to_string());
        }
    }

    /// The current stage (a spinner's message).
    pub fn message(&self, what: &str) {
        if let Some(b) = &self.bar {
            b.set_message(what.to_string());
        }
    }

    /// A log line on stderr: above the bar when it is shown, plainly otherwise.
    pub fn println(&self, line: &str) {
        match &self.bar {
            Some(b) => b.println(line),
            None => eprintln!("{line}"),
        }
    }

    /// Remove the display (the result lines that follow stand alone).
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nothing_is_drawn_off_a_terminal_and_a_bar_on_one() {
        let off = Progress::with_display(false, "x", Some(10));
        off.set(3, "a");
        off.message("b");
        assert!(!off.is_shown());
        // Tests run with stderr captured or piped: `new` decides from the real stream.
        if !std::io::stderr().is_terminal() {
            assert!(!Progress::new("x", Some(2)).is_shown());
        }
        let on = Progress::with_display(true, "x", Some(10));
        on.set(4, "a");
        assert_eq!(on.bar.as_ref().map(|b| b.position()), Some(4));
        on.finish();
        assert!(on.bar.as_ref().unwrap().is_finished());
    }
}
