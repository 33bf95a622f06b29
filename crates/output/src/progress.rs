//! A minimal progress bar on stderr for long runs.
//!
//! On a terminal it redraws one line (`label [#####-----] 512/1000 51.2% 830 steps/s ETA 0:01`)
//! at most every 100 ms; otherwise (logs, CI) it prints nothing until the final summary line.
//! Calling [`Progress::inc`] every step is cheap: one clock read and a comparison.
//!
//! ```
//! use simkit_output::progress::Progress;
//! let mut bar = Progress::new("relax", 1000);
//! for _ in 0..1000 {
//!     // ... one step ...
//!     bar.inc(1);
//! }
//! bar.finish(); // "relax: 1000/1000 steps in 0.0 s (... steps/s)"
//! ```

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

const REDRAW: Duration = Duration::from_millis(100);
const BAR_WIDTH: usize = 24;

/// Progress of a run with a known number of steps; see the [module docs](self).
#[derive(Debug)]
pub struct Progress {
    label: String,
    total: u64,
    done: u64,
    start: Instant,
    last_draw: Instant,
    terminal: bool,
    quiet: bool,
    finished: bool,
}

impl Progress {
    /// A progress bar for `total` steps, drawn when stderr is a terminal.
    pub fn new(label: impl Into<String>, total: u64) -> Self {
        let now = Instant::now();
        Self {
            label: label.into(),
            total,
            done: 0,
            start: now,
            last_draw: now,
            terminal: std::io::stderr().is_terminal(),
            quiet: false,
            finished: false,
        }
    }

    /// A progress tracker that never prints (the counts and rates still work).
    pub fn hidden(label: impl Into<String>, total: u64) -> Self {
        let mut p = Self::new(label, total);
        p.quiet = true;
        p
    }

    /// Steps done so far.
    pub fn done(&self) -> u64 {
        self.done
    }

    /// Total steps.
    pub fn total(&self) -> u64 {
        self.total
    }

    /// Steps per second since the start.
    pub fn rate(&self) -> f64 {
        let secs = self.start.elapsed().as_secs_f64();
        if secs > 0.0 {
            self.done as f64 / secs
        } else {
            0.0
        }
    }

    /// Estimated time to completion at the average rate so far, if known (and within the
    /// range of a [`Duration`]).
    pub fn eta(&self) -> Option<Duration> {
        let rate = self.rate();
        if rate > 0.0 && self.done <= self.total {
            Duration::try_from_secs_f64((self.total - self.done) as f64 / rate).ok()
        } else {
            None
        }
    }

    /// Adds `n` steps; redraws if due.
    #[inline]
    pub fn inc(&mut self, n: u64) {
        self.done = self.done.saturating_add(n);
        self.tick();
    }

    /// Sets the number of steps done; redraws if due.
    #[inline]
    pub fn set(&mut self, done: u64) {
        self.done = done;
        self.tick();
    }

    #[inline]
    fn tick(&mut self) {
        if self.terminal && !self.quiet {
            let now = Instant::now();
            if now.duration_since(self.last_draw) >= REDRAW {
                self.last_draw = now;
                self.draw();
            }
        }
    }

    /// The current status line (what the bar shows).
    pub fn line(&self) -> String {
        let frac = if self.total > 0 {
            (self.done as f64 / self.total as f64).min(1.0)
        } else {
            1.0
        };
        let filled = (frac * BAR_WIDTH as f64).round() as usize;
        let eta = self.eta().map(fmt_duration).unwrap_or_else(|| "?".into());
        format!(
            "{} [{}{}] {}/{} {:.1}% {} steps/s ETA {}",
            self.label,
            "#".repeat(filled),
            "-".repeat(BAR_WIDTH - filled),
            self.done,
            self.total,
            100.0 * frac,
            crate::numfmt::short(self.rate()),
            eta
        )
    }

    fn draw(&self) {
        let mut err = std::io::stderr().lock();
        let _ = write!(err, "\r{}\x1b[K", self.line());
        let _ = err.flush();
    }

    /// The final summary line.
    pub fn summary(&self) -> String {
        let secs = self.start.elapsed().as_secs_f64();
        format!(
            "{}: {}/{} steps in {:.1} s ({} steps/s)",
            self.label,
            self.done,
            self.total,
            secs,
            crate::numfmt::short(self.rate())
        )
    }

    /// Prints the summary line (always, unless hidden) and stops drawing. Called by `Drop`
    /// if not called explicitly.
    pub fn finish(&mut self) {
        if self.finished {
            return;
        }
        self.finished = true;
        if self.quiet {
            return;
        }
        let mut err = std::io::stderr().lock();
        if self.terminal {
            let _ = write!(err, "\r\x1b[K");
        }
        let _ = writeln!(err, "{}", self.summary());
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}

fn fmt_duration(d: Duration) -> String {
    let s = d.as_secs();
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, (s / 60) % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_lines() {
        let mut p = Progress::hidden("run", 10);
        for _ in 0..5 {
            p.inc(1);
        }
        assert_eq!(p.done(), 5);
        let line = p.line();
        assert!(line.contains("5/10") && line.contains("50.0%"), "{line}");
        assert!(p.summary().starts_with("run: 5/10 steps"));
        assert_eq!(fmt_duration(Duration::from_secs(3725)), "1:02:05");
        let mut z = Progress::hidden("zero", 0);
        z.inc(3);
        assert!(z.line().contains("100.0%"));
    }
}
