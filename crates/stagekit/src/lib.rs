//! What every reprise stage binary shares: exit codes ([`exit`]), the stage error
//! ([`StageError`]), the `main` wrapper that prints an error once and exits with its
//! code ([`main`]), progress bars or log lines ([`progress()`]) and the parameter record that goes
//! into provenance ([`provenance`]).
#![warn(missing_docs)]

pub mod clips;
pub mod error;
pub mod exit;
pub mod lifetime;
pub mod panic;
pub mod progress;
pub mod rig;
pub mod wiring;

pub use error::{StageError, StageResult};

pub use indicatif::ProgressBar;
use indicatif::ProgressStyle;
pub use reprise_artifact::Provenance;
#[doc(hidden)]
pub use serde;
use serde::Serialize;

/// What precedes a stage binary's code identity in its bytes (see [`code_id!`]).
pub const CODE_ID_MARKER: &str = "reprise-code-id=";

/// The code identity a build script computed (`reprise_codeid::emit`) as the string
/// `reprise-code-id=<64 hex>;`. Given to [`main`], which keeps it in the binary, where the
/// runner finds it without running the binary and keys the stage's cache on it instead of
/// on the binary's bytes. The argument names the compile-time environment variable.
#[macro_export]
macro_rules! code_id {
    ($var:literal) => {
        concat!("reprise-code-id=", env!($var), ";")
    };
}

/// Environment variable: where the runner wants a stage's resource statistics, a JSON
/// object `{"peak_rss_bytes": …}` written when the stage succeeds.
pub const STATS_ENV: &str = "REPRISE_STATS_FILE";

/// Runs a stage body and exits the process (`code_id`: [`code_id!`]): 0 on success, otherwise the error's code
/// after printing `<binary>: error: <message>` once to stderr.
///
/// Around the body: a panic becomes one "internal error" line and exit code
/// [`exit::FAILURE`] ([`mod@panic`]); the stage dies with its runner ([`lifetime`]); and the
/// stage's artifacts are replaced together — each is written to a temporary file as the
/// stage goes, and all are renamed into place only once the body succeeded
/// ([`reprise_artifact::table::defer_commits`]), so a stage that fails or is killed
/// leaves every old output as it was.
pub fn main(binary: &str, code_id: &'static str, body: impl FnOnce() -> StageResult<()>) -> ! {
    // Keeps the identity's bytes in the executable (an unused string would be dropped).
    std::hint::black_box(code_id);
    panic::install(binary);
    lifetime::die_with_runner();
    reprise_artifact::table::defer_commits();
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(body))
        .map(|result| result.and_then(|()| Ok(reprise_artifact::table::commit_pending()?)));
    match result {
        Ok(Ok(())) => {
            if let (Some(path), Some(peak)) = (std::env::var_os(STATS_ENV), peak_rss_bytes()) {
                let _ = std::fs::write(path, format!("{{\"peak_rss_bytes\": {peak}}}"));
            }
            std::process::exit(exit::OK)
        }
        Ok(Err(e)) => {
            reprise_artifact::table::discard_pending();
            say_whole(&format!("{binary}: error: {e}\n"));
            std::process::exit(e.code())
        }
        Err(_) => {
            // The hook has printed the message.
            reprise_artifact::table::discard_pending();
            std::process::exit(exit::FAILURE)
        }
    }
}

/// Writes `text` to stderr in one `write` call. `eprintln!` writes a formatted line piece
/// by piece, and the runner's partitions share one stderr: two stages failing at once
/// interleaved their messages within a line (`reprise-pcareprise-pca: error: : error: …`).
/// One write of at most `PIPE_BUF` (4,096) bytes to a pipe is atomic.
pub fn say_whole(text: &str) {
    use std::io::Write;
    let _ = std::io::stderr().lock().write_all(text.as_bytes());
}

/// This process's peak resident memory (`VmHWM` of `/proc/self/status`), where the OS
/// reports it.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// A provenance record for `stage` at this crate version, with `params` serialised and
/// the pipeline the runner named ([`reprise_artifact::provenance::PIPELINE_ENV`]).
pub fn provenance(stage: &str, version: &str, params: &impl Serialize) -> Provenance {
    let params = serde_json::to_value(params).expect("stage parameters serialise to JSON");
    Provenance {
        pipeline: reprise_artifact::provenance::pipeline_from_env(),
        ..Provenance::new(stage, version, params)
    }
}

/// What one system of a transition benchmark stage did with its requests: how many it
/// answered, of how many, and the median latency (frames) of those answered (the upper
/// median: of an even count, the larger middle value).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AnswerSummary {
    /// The system's id.
    pub system: String,
    /// Requests answered.
    pub answered: usize,
    /// Requests asked.
    pub total: usize,
    /// The median latency of the answered requests, frames (none answered: `None`).
    pub median_latency: Option<i64>,
}

impl AnswerSummary {
    /// The summary of `system`'s `answers`.
    pub fn new<'a>(system: &str, answers: impl IntoIterator<Item = &'a reprise_artifact::transitions::Answer>) -> Self {
        let (mut latencies, mut total) = (Vec::new(), 0);
        for a in answers {
            total += 1;
            latencies.extend(a.latency);
        }
        latencies.sort_unstable();
        let median_latency = latencies.get(latencies.len() / 2).copied();
        Self { system: system.to_string(), answered: latencies.len(), total, median_latency }
    }
}

/// One line: `reprise          answered 1118 / 1120 requests, median latency 9 frames`.
impl std::fmt::Display for AnswerSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let median = self.median_latency.map_or("-".to_string(), |v| v.to_string());
        write!(
            f,
            "{:<16} answered {:>4} / {:<4} requests, median latency {median} frames",
            self.system, self.answered, self.total
        )
    }
}

/// Items mapped in parallel per chunk (see [`par_map_chunked`]).
pub const CHUNK: usize = 64;

/// Maps `items` in parallel, [`CHUNK`] at a time, handing each result to `sink` in item
/// order before the next chunk is mapped: a stage whose results are large (an answer's
/// frames) holds one chunk of them, not all. The first error of `sink` stops it.
pub fn par_map_chunked<T: Sync, R: Send>(
    items: &[T],
    map: impl Fn(&T) -> R + Sync,
    mut sink: impl FnMut(R) -> StageResult<()>,
) -> StageResult<()> {
    use rayon::prelude::*;
    for chunk in items.chunks(CHUNK) {
        let results: Vec<R> = chunk.par_iter().map(&map).collect();
        for r in results {
            sink(r)?;
        }
    }
    Ok(())
}

/// A progress bar on stderr: a bar on a terminal, a plain line every
/// [`progress::LOG_EVERY`] otherwise (see [`progress::draw_target`]).
pub fn progress(len: u64, message: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(len), progress::draw_target());
    bar.set_style(
        ProgressStyle::with_template(progress::TEMPLATE).expect("the template is valid").progress_chars("=> "),
    );
    bar.set_message(message.to_string());
    bar
}

/// Progress bars shown together (one per parallel task), on stderr; as lines when stderr
/// is not a terminal.
pub use indicatif::MultiProgress;

/// A [`MultiProgress`] drawing where [`progress()`] does.
pub fn multi_progress() -> MultiProgress {
    MultiProgress::with_draw_target(progress::draw_target())
}

/// A counter of `unit`s (e.g. "evaluations") for work of unknown length, added to `multi`:
/// its message, how many so far and the time elapsed ([`progress::COUNTER_TEMPLATE`]).
pub fn counter_in(multi: &MultiProgress, message: &str, unit: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(None, progress::draw_target());
    bar.set_style(ProgressStyle::with_template(progress::COUNTER_TEMPLATE).expect("the template is valid"));
    bar.set_message(message.to_string());
    bar.set_prefix(unit.to_string());
    multi.add(bar)
}

/// A bar of [`progress()`]'s style added to `multi`.
pub fn progress_in(multi: &MultiProgress, len: u64, message: &str) -> ProgressBar {
    multi.add(progress(len, message))
}

/// Every stage allocates through mimalloc: glibc's allocator keeps a heap per thread and
/// returns little of it, so a stage whose threads take turns at large buffers (one
/// answer's meshes) held about 1.4 × its live memory.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

#[cfg(test)]
mod tests {
    use reprise_artifact::transitions::Answer;

    use super::AnswerSummary;

    /// Refusals count toward the total only; the median is the upper one of the answered
    /// latencies; with none answered it is shown as "-".
    #[test]
    fn an_answer_summary_counts_and_takes_the_median() {
        let answers = [
            Answer::reached(0, 9),
            Answer::failed("no bridge"),
            Answer::reached(3, 4),
            Answer::reached(1, 12),
            Answer::reached(2, 5),
        ];
        let s = AnswerSummary::new("reprise", &answers);
        assert_eq!((s.answered, s.total, s.median_latency), (4, 5, Some(9)));
        assert_eq!(s.to_string(), "reprise          answered    4 / 5    requests, median latency 9 frames");
        let none = AnswerSummary::new("crossfade", &[Answer::failed("x")]);
        assert_eq!(none.to_string(), "crossfade        answered    0 / 1    requests, median latency - frames");
        assert_eq!(AnswerSummary::new("empty", []).median_latency, None);
    }
}
