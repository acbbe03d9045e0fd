//! What the server measures of itself, for `GET /stats` and the load benchmark: how long
//! a frame takes to make, how late each frame tick fires, and how long a command waits for
//! the first frame it changes.
//!
//! Each measure keeps its last [`KEEP`] samples (a ring: memory is bounded however long the
//! server runs) and reports their count, median, 99th percentile and maximum in
//! milliseconds.

use std::sync::Mutex;
use std::time::Duration;

use serde::Serialize;

/// Samples kept per measure.
pub const KEEP: usize = 1 << 16;

/// The last [`KEEP`] samples of one measure, in milliseconds.
#[derive(Debug, Default)]
struct Ring {
    samples: Vec<f64>,
    next: usize,
    total: u64,
}

impl Ring {
    fn push(&mut self, ms: f64) {
        if self.samples.len() < KEEP {
            self.samples.push(ms);
        } else {
            self.samples[self.next] = ms;
        }
        self.next = (self.next + 1) % KEEP;
        self.total += 1;
    }

    fn summary(&self) -> Summary {
        let mut s = self.samples.clone();
        s.sort_unstable_by(f64::total_cmp);
        // The nearest-rank percentile: the smallest sample with at least p of them ≤ it.
        let rank = |p: f64| s.get(((p * s.len() as f64).ceil() as usize).max(1) - 1).copied();
        Summary { count: self.total, kept: s.len(), p50_ms: rank(0.5), p99_ms: rank(0.99), max_ms: s.last().copied() }
    }
}

/// One measure's summary over its kept samples (`None` before the first).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Summary {
    /// Samples ever taken.
    pub count: u64,
    /// Samples the figures are over (the last [`KEEP`]).
    pub kept: usize,
    /// Median, ms.
    pub p50_ms: Option<f64>,
    /// 99th percentile (nearest rank), ms.
    pub p99_ms: Option<f64>,
    /// Maximum, ms.
    pub max_ms: Option<f64>,
}

/// Every measure's summary.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Report {
    /// Making one frame of a session: every system's step, the rig, the encoding.
    pub frame_make: Summary,
    /// How late a frame tick fired against its schedule (a busy server falls behind).
    pub tick_late: Summary,
    /// From a command's arrival to the sending of the first frame made after it (the
    /// frame it is stamped with).
    pub command_to_frame: Summary,
    /// Sessions open when asked.
    pub sessions: usize,
}

/// The server's measures.
#[derive(Debug, Default)]
pub struct Stats {
    inner: Mutex<[Ring; 3]>,
}

/// Which measure a sample is of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Measure {
    /// [`Report::frame_make`].
    FrameMake = 0,
    /// [`Report::tick_late`].
    TickLate = 1,
    /// [`Report::command_to_frame`].
    CommandToFrame = 2,
}

impl Stats {
    /// Records a sample.
    pub fn record(&self, m: Measure, d: Duration) {
        // A poisoned lock only means another thread panicked mid-push; the ring is intact.
        let mut rings = self.inner.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        rings[m as usize].push(d.as_secs_f64() * 1e3);
    }

    /// Every measure's summary, with `sessions` open.
    pub fn report(&self, sessions: usize) -> Report {
        let rings = self.inner.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        Report {
            frame_make: rings[0].summary(),
            tick_late: rings[1].summary(),
            command_to_frame: rings[2].summary(),
            sessions,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_are_nearest_rank_over_the_kept_samples() {
        let s = Stats::default();
        assert_eq!(s.report(0).frame_make.p50_ms, None);
        for ms in 1..=100 {
            s.record(Measure::FrameMake, Duration::from_millis(ms));
        }
        let r = s.report(3).frame_make;
        assert_eq!((r.count, r.kept, r.p50_ms, r.p99_ms, r.max_ms), (100, 100, Some(50.0), Some(99.0), Some(100.0)));
        assert_eq!(s.report(3).tick_late.count, 0);
        assert_eq!(s.report(3).sessions, 3);
    }

    #[test]
    fn the_ring_keeps_only_the_last_samples() {
        let mut r = Ring::default();
        for _ in 0..KEEP {
            r.push(1000.0);
        }
        for _ in 0..KEEP {
            r.push(1.0);
        }
        let s = r.summary();
        assert_eq!((s.count, s.kept, s.max_ms), (2 * KEEP as u64, KEEP, Some(1.0)));
    }
}
