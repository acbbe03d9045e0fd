//! Progress where a user reads it: bars on a terminal, and — when stderr is a log file or
//! a pipe (a runner's log, a cluster job's output) — one plain line per bar every
//! [`LOG_EVERY`], so a long stage is never silent for minutes.

use std::io::{self, IsTerminal, Write};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use indicatif::{ProgressDrawTarget, TermLike};

/// The bar's template: message, bar, position of length, elapsed, and the estimate of
/// what remains.
pub const TEMPLATE: &str = "{msg:>12} [{bar:30}] {pos}/{len} {elapsed} (ETA {eta})";

/// The template of work with no known length (an optimiser that stops when it converges):
/// message, count and elapsed time — no bar, no total, no estimate.
pub const COUNTER_TEMPLATE: &str = "{msg} · {pos} {prefix} · {elapsed}";

/// How often a bar prints its line when stderr is not a terminal.
pub const LOG_EVERY: Duration = Duration::from_secs(5);

/// Set (to anything) in a stage's environment, it prints plain lines even on a terminal:
/// the runner sets it when several stages share one terminal (a partitioned stage).
pub const PLAIN_ENV: &str = "REPRISE_PROGRESS_PLAIN";

/// Where a stage's bars draw: stderr as a terminal (unless [`PLAIN_ENV`] is set), else
/// [`LogLines`] on stderr.
pub fn draw_target() -> ProgressDrawTarget {
    if io::stderr().is_terminal() && std::env::var_os(PLAIN_ENV).is_none() {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::term_like_with_hz(Box::new(LogLines::stderr(LOG_EVERY)), 1)
    }
}

/// Whether a line is due: never printed yet, or `every` has passed since `last`.
pub fn due(last: Option<Instant>, now: Instant, every: Duration) -> bool {
    last.is_none_or(|l| now.duration_since(l) >= every)
}

type Sink = Arc<Mutex<dyn Write + Send>>;

/// A "terminal" that turns each draw into plain lines, at most one draw per interval:
/// the lines of a draw (one per bar) are collected and, at the draw's end (`flush`),
/// written with a time stamp if a line is due, else dropped. Cursor moves are ignored.
pub struct LogLines {
    sink: Sink,
    every: Duration,
    start: Instant,
    state: Mutex<(Vec<String>, Option<Instant>)>,
}

impl std::fmt::Debug for LogLines {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LogLines").field("every", &self.every).finish_non_exhaustive()
    }
}

impl LogLines {
    /// Lines on stderr.
    pub fn stderr(every: Duration) -> Self {
        Self::new(Arc::new(Mutex::new(io::stderr())), every)
    }

    /// Lines into `sink`.
    pub fn new(sink: Sink, every: Duration) -> Self {
        Self { sink, every, start: Instant::now(), state: Mutex::new((Vec::new(), None)) }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, (Vec<String>, Option<Instant>)> {
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

impl TermLike for LogLines {
    fn width(&self) -> u16 {
        100
    }

    fn move_cursor_up(&self, _: usize) -> io::Result<()> {
        Ok(())
    }

    fn move_cursor_down(&self, _: usize) -> io::Result<()> {
        Ok(())
    }

    fn move_cursor_right(&self, _: usize) -> io::Result<()> {
        Ok(())
    }

    fn move_cursor_left(&self, _: usize) -> io::Result<()> {
        Ok(())
    }

    fn write_line(&self, s: &str) -> io::Result<()> {
        let line = s.trim_end();
        if !line.trim().is_empty() {
            self.lock().0.push(line.trim_start().to_string());
        }
        Ok(())
    }

    fn write_str(&self, s: &str) -> io::Result<()> {
        self.write_line(s)
    }

    fn clear_line(&self) -> io::Result<()> {
        Ok(())
    }

    fn flush(&self) -> io::Result<()> {
        let mut state = self.lock();
        let now = Instant::now();
        let lines = std::mem::take(&mut state.0);
        if lines.is_empty() || !due(state.1, now, self.every) {
            return Ok(());
        }
        state.1 = Some(now);
        let at = now.duration_since(self.start).as_secs();
        let mut sink = self.sink.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        for l in lines {
            writeln!(sink, "[{:02}:{:02}] {l}", at / 60, at % 60)?;
        }
        sink.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_is_due_once_per_interval() {
        let t0 = Instant::now();
        let every = Duration::from_secs(5);
        assert!(due(None, t0, every), "the first line is always due");
        assert!(!due(Some(t0), t0 + Duration::from_secs(4), every));
        assert!(due(Some(t0), t0 + Duration::from_secs(5), every));
    }

    /// A bar drawn into log lines prints its message, position, length and estimate on
    /// one plain line, without terminal control codes.
    #[test]
    fn a_bar_becomes_a_plain_line() {
        let sink = Arc::new(Mutex::new(Vec::<u8>::new()));
        let target = ProgressDrawTarget::term_like(Box::new(LogLines::new(sink.clone(), Duration::ZERO)));
        let bar = indicatif::ProgressBar::with_draw_target(Some(40), target);
        bar.set_style(indicatif::ProgressStyle::with_template(TEMPLATE).unwrap());
        bar.set_message("neutral");
        bar.set_position(10);
        bar.finish();
        let text = String::from_utf8(sink.lock().unwrap().clone()).unwrap();
        assert!(text.lines().all(|l| l.starts_with("[00:00] neutral [") && l.contains("(ETA ")), "{text:?}");
        assert!(text.lines().any(|l| l.contains(" 10/40 ")), "the position drawn: {text:?}");
        assert!(text.lines().last().is_some_and(|l| l.contains(" 40/40 ")) && !text.contains('\u{1b}'), "{text:?}");
    }

    /// Draws within the interval are dropped, not queued.
    #[test]
    fn draws_within_the_interval_are_dropped() {
        let sink = Arc::new(Mutex::new(Vec::<u8>::new()));
        let log = LogLines::new(sink.clone(), Duration::from_secs(3600));
        for i in 0..3 {
            log.write_line(&format!("  step {i}  ")).unwrap();
            log.flush().unwrap();
        }
        let text = String::from_utf8(sink.lock().unwrap().clone()).unwrap();
        assert_eq!(text.lines().collect::<Vec<_>>(), ["[00:00] step 0"]);
    }
}
