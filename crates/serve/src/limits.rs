//! Bounds on what one client may send.

use std::time::Instant;

/// The largest message a client may send, bytes (a command is a few dozen).
pub const MAX_MESSAGE_BYTES: usize = 4096;
/// Commands per second a session takes on average.
pub const COMMANDS_PER_SECOND: f64 = 20.0;
/// Commands a session takes at once before the rate applies.
pub const BURST: f64 = 20.0;
/// Refused commands in a row after which the client is disconnected.
pub const REFUSALS_BEFORE_DISCONNECT: u32 = 200;

/// What to do with a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Take it.
    Allow,
    /// Refuse it (the client is told).
    Refuse,
    /// The client keeps flooding: end its session.
    Disconnect,
}

/// A token bucket: [`BURST`] tokens, refilled at [`COMMANDS_PER_SECOND`].
#[derive(Debug, Clone)]
pub struct RateLimit {
    tokens: f64,
    at: Instant,
    refused: u32,
}

impl RateLimit {
    /// A full bucket at `now`.
    pub fn new(now: Instant) -> Self {
        Self { tokens: BURST, at: now, refused: 0 }
    }

    /// The verdict on a command arriving at `now`.
    pub fn take(&mut self, now: Instant) -> Verdict {
        let dt = now.saturating_duration_since(self.at).as_secs_f64();
        self.tokens = (self.tokens + dt * COMMANDS_PER_SECOND).min(BURST);
        self.at = now;
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            self.refused = 0;
            Verdict::Allow
        } else {
            self.refused += 1;
            if self.refused >= REFUSALS_BEFORE_DISCONNECT {
                Verdict::Disconnect
            } else {
                Verdict::Refuse
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn a_burst_then_the_rate_then_disconnection() {
        let t0 = Instant::now();
        let mut r = RateLimit::new(t0);
        assert!((0..20).all(|_| r.take(t0) == Verdict::Allow));
        assert_eq!(r.take(t0), Verdict::Refuse);
        // 50 ms later one token has come back.
        let t1 = t0 + Duration::from_millis(50);
        assert_eq!(r.take(t1), Verdict::Allow);
        assert_eq!(r.take(t1), Verdict::Refuse);
        let verdicts: Vec<Verdict> = (0..REFUSALS_BEFORE_DISCONNECT).map(|_| r.take(t1)).collect();
        assert_eq!(verdicts.last(), Some(&Verdict::Disconnect));
        // A client that keeps to the rate is never refused.
        let mut r = RateLimit::new(t0);
        assert!((1..2000).all(|i| r.take(t0 + Duration::from_millis(50 * i)) == Verdict::Allow));
    }
}
