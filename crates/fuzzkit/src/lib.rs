//! What reprise's generative parser tests share (a dev-dependency only).
//!
//! Every parser (curve tables, labels, BVH, glTF, `pipeline.toml`, synthesis scripts) is
//! tested the same way: start from a real, valid input, mutate it the ways real files go
//! wrong, and check the parser returns `Ok` or its typed error — never a panic, an abort
//! on allocation, or a hang. This crate holds the pieces:
//!
//! - [`mutated`] / [`mutated_text`]: strategies producing a valid input with 1–4
//!   [`Mutation`]s applied — bit flips, truncations, deleted or duplicated spans, inserted
//!   tokens (the parser's own keywords and separators, huge numbers, NaN/inf, empty
//!   fields, unicode, control characters), and numbers replaced by nasty ones.
//! - [`within`]: runs a parser on a big-stack thread (like a stage's main thread) and
//!   fails the test if it takes longer than the limit — a hang becomes a failure instead
//!   of a stuck test run; a panic is re-raised so proptest reports and shrinks it.
//! - [`config`]: a proptest configuration with a case count (scaled by the environment
//!   variable `REPRISE_FUZZ_SCALE`, e.g. `10` for a longer local run), no failure files
//!   written (nasty cases are kept as ordinary regression tests next to each parser).
#![warn(missing_docs)]

use std::sync::mpsc;
use std::time::Duration;

use proptest::prelude::*;
use proptest::test_runner::Config;

pub use proptest;

/// The stack a parser gets in [`within`]: a stage's main thread has 8 MiB.
pub const STACK: usize = 8 << 20;

/// Tokens inserted by [`Mutation::Insert`] in every format, besides the format's own.
pub const NASTY: &[&str] = &[
    "NaN",
    "nan",
    "inf",
    "-inf",
    "Infinity",
    "1e308",
    "1e309",
    "-1e308",
    "1e-320",
    "-0",
    "-1",
    "0",
    "4294967296",
    "18446744073709551616",
    "9223372036854775807",
    "-9223372036854775808",
    "1000000000",
    "99999999999999999999999999",
    "0x10",
    "1,5",
    "",
    " ",
    "\t",
    "\n",
    "\r\n",
    "\r",
    "\0",
    ",",
    ";",
    "\"",
    "'",
    "=",
    "[",
    "]",
    "{",
    "}",
    "[[",
    "]]",
    "#",
    "\\",
    "é",
    "日本",
    "😀",
    "\u{feff}",
    "\u{202e}",
    "\u{fffd}",
];

/// Numbers that replace a number of the input in [`Mutation::Number`].
pub const NASTY_NUMBERS: &[&str] = &[
    "NaN",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e999",
    "0",
    "-0",
    "-1",
    "1000000000",
    "4294967296",
    "1e-300",
    "9223372036854775808",
    "",
];

/// One way a valid input goes wrong. Positions are fractions of the input's length, so
/// one mutation means the same place in inputs of any size (and shrinks sensibly).
#[derive(Debug, Clone)]
pub enum Mutation {
    /// Flip bit `bit` of the byte at `at`.
    FlipBit {
        /// Where, as a fraction of the length.
        at: f64,
        /// Which bit (0–7).
        bit: u8,
    },
    /// Overwrite the byte at `at`.
    Byte {
        /// Where.
        at: f64,
        /// The new byte.
        value: u8,
    },
    /// Cut the input at `at`.
    Truncate {
        /// Where.
        at: f64,
    },
    /// Remove `len` bytes from `at`.
    Delete {
        /// Where.
        at: f64,
        /// How many bytes.
        len: usize,
    },
    /// Repeat the `len` bytes at `at` `times` more times.
    Duplicate {
        /// Where.
        at: f64,
        /// How many bytes.
        len: usize,
        /// How many extra copies.
        times: usize,
    },
    /// Insert `token` at `at`.
    Insert {
        /// Where.
        at: f64,
        /// What.
        token: String,
    },
    /// Replace the `nth` number of the input (a run of digits, `.`, `e`, `-`, `+`) by
    /// `with`.
    Number {
        /// Which number (modulo their count).
        nth: usize,
        /// The replacement.
        with: String,
    },
}

fn index(at: f64, len: usize) -> usize {
    ((at * len as f64) as usize).min(len)
}

impl Mutation {
    /// Applies the mutation to `data`.
    pub fn apply(&self, data: &mut Vec<u8>) {
        let len = data.len();
        match self {
            Self::FlipBit { at, bit } if len > 0 => {
                let i = index(*at, len - 1);
                data[i] ^= 1 << (bit % 8);
            }
            Self::Byte { at, value } if len > 0 => {
                let i = index(*at, len - 1);
                data[i] = *value;
            }
            Self::Truncate { at } => data.truncate(index(*at, len)),
            Self::Delete { at, len: n } => {
                let i = index(*at, len);
                data.drain(i..(i + n).min(len));
            }
            Self::Duplicate { at, len: n, times } => {
                let i = index(*at, len);
                let span = data[i..(i + n).min(len)].to_vec();
                let copies: Vec<u8> = span.iter().copied().cycle().take(span.len() * times).collect();
                data.splice(i..i, copies);
            }
            Self::Insert { at, token } => {
                let i = index(*at, len);
                data.splice(i..i, token.bytes());
            }
            Self::Number { nth, with } => {
                let numbers = number_spans(data);
                if !numbers.is_empty() {
                    let (s, e) = numbers[nth % numbers.len()];
                    data.splice(s..e, with.bytes());
                }
            }
            Self::FlipBit { .. } | Self::Byte { .. } => {}
        }
    }
}

/// Byte ranges of the numbers in `data`: maximal runs of `0-9 . e E + -` holding a digit.
fn number_spans(data: &[u8]) -> Vec<(usize, usize)> {
    let is_part = |b: u8| b.is_ascii_digit() || matches!(b, b'.' | b'e' | b'E' | b'+' | b'-');
    let mut out = Vec::new();
    let mut i = 0;
    while i < data.len() {
        if data[i].is_ascii_digit() {
            let mut s = i;
            while s > 0 && is_part(data[s - 1]) && !data[s - 1].is_ascii_alphabetic() {
                s -= 1;
            }
            let mut e = i;
            while e < data.len() && is_part(data[e]) {
                e += 1;
            }
            out.push((s, e));
            i = e;
        } else {
            i += 1;
        }
    }
    out
}

/// One [`Mutation`], inserting [`NASTY`] tokens and the format's own `tokens`.
pub fn mutation(tokens: &'static [&'static str]) -> impl Strategy<Value = Mutation> {
    let at = 0.0..1.0f64;
    let token = prop_oneof![
        proptest::sample::select(NASTY).prop_map(String::from),
        proptest::sample::select(if tokens.is_empty() { NASTY } else { tokens }).prop_map(String::from),
        "\\PC{0,8}",
    ];
    prop_oneof![
        (at.clone(), 0u8..8).prop_map(|(at, bit)| Mutation::FlipBit { at, bit }),
        (at.clone(), any::<u8>()).prop_map(|(at, value)| Mutation::Byte { at, value }),
        at.clone().prop_map(|at| Mutation::Truncate { at }),
        (at.clone(), 1usize..64).prop_map(|(at, len)| Mutation::Delete { at, len }),
        (at.clone(), 1usize..64, 1usize..8).prop_map(|(at, len, times)| Mutation::Duplicate { at, len, times }),
        (at, token).prop_map(|(at, token)| Mutation::Insert { at, token }),
        (any::<usize>(), proptest::sample::select(NASTY_NUMBERS))
            .prop_map(|(nth, with)| Mutation::Number { nth, with: with.into() }),
    ]
}

/// `seed` with 1–4 mutations applied (and, one time in 16, `seed` itself).
pub fn mutated(seed: Vec<u8>, tokens: &'static [&'static str]) -> impl Strategy<Value = Vec<u8>> {
    proptest::collection::vec(mutation(tokens), 0..=4).prop_map(move |ms| {
        let mut data = seed.clone();
        for m in &ms {
            m.apply(&mut data);
        }
        data
    })
}

/// [`mutated`] for text formats: the bytes decoded lossily (as a reader of the file would
/// see them after its UTF-8 check).
pub fn mutated_text(seed: &str, tokens: &'static [&'static str]) -> impl Strategy<Value = String> {
    mutated(seed.as_bytes().to_vec(), tokens).prop_map(|b| String::from_utf8_lossy(&b).into_owned())
}

/// Random text built from the format's tokens, [`NASTY`] ones and arbitrary characters,
/// separated by spaces or line ends — inputs unlike any valid file.
pub fn token_soup(tokens: &'static [&'static str]) -> impl Strategy<Value = String> {
    let piece = prop_oneof![
        proptest::sample::select(NASTY).prop_map(String::from),
        proptest::sample::select(if tokens.is_empty() { NASTY } else { tokens }).prop_map(String::from),
        "\\PC{0,6}",
        "[0-9.e-]{1,6}",
    ];
    let sep = proptest::sample::select(&[" ", "\n", "", "\t", " = ", ","][..]);
    proptest::collection::vec((piece, sep), 0..64).prop_map(|v| v.into_iter().map(|(p, s)| p + s).collect())
}

/// A proptest configuration running `cases` cases (times `REPRISE_FUZZ_SCALE` when set),
/// writing no failure-persistence files, from a fixed seed ([`seed`]) so that a run —
/// CI's above all — is deterministic: a change is never stopped by a failure it did not
/// cause. `REPRISE_FUZZ_SEED=random` (or another number) and a larger scale explore further
/// in a longer local run; a failure found so becomes a named regression test.
pub fn config(cases: u32) -> Config {
    let scale = std::env::var("REPRISE_FUZZ_SCALE").ok().and_then(|s| s.parse::<f64>().ok()).unwrap_or(1.0);
    Config {
        cases: ((f64::from(cases) * scale).round() as u32).max(1),
        failure_persistence: None,
        max_shrink_iters: 512,
        rng_seed: seed(std::env::var("REPRISE_FUZZ_SEED").ok().as_deref()),
        ..Config::default()
    }
}

/// The generative tests' seed: fixed (0) unless `setting` (the `REPRISE_FUZZ_SEED`
/// variable) is `random` or another number.
pub fn seed(setting: Option<&str>) -> proptest::test_runner::RngSeed {
    use proptest::test_runner::RngSeed;
    match setting.map(str::trim) {
        Some("random") => RngSeed::Random,
        Some(n) => n.parse().map_or(RngSeed::Fixed(0), RngSeed::Fixed),
        None => RngSeed::Fixed(0),
    }
}

/// Runs `f` on a thread with a stage's stack ([`STACK`]) and returns its result; panics
/// (failing the test) if `f` runs longer than `limit`, and re-raises `f`'s own panic.
pub fn within<T: Send + 'static>(limit: Duration, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    let handle = std::thread::Builder::new()
        .stack_size(STACK)
        .spawn(move || {
            let _ = tx.send(f());
        })
        .expect("spawn a parser thread");
    match rx.recv_timeout(limit) {
        Ok(v) => {
            let _ = handle.join();
            v
        }
        Err(mpsc::RecvTimeoutError::Disconnected) => match handle.join() {
            Err(panic) => std::panic::resume_unwind(panic),
            Ok(()) => unreachable!("the thread sends before it ends"),
        },
        // The thread is left running: the test fails, and the process ends with it.
        Err(mpsc::RecvTimeoutError::Timeout) => panic!("the parser ran longer than {limit:?}: a hang"),
    }
}

/// The time limit of one parse in the generative tests: generous for a 2-core machine
/// under load, tiny against a hang.
pub const LIMIT: Duration = Duration::from_secs(10);

#[cfg(test)]
mod tests {
    use super::*;

    /// The seed is fixed unless asked otherwise; a number picks that seed.
    #[test]
    fn the_seed_is_fixed_by_default() {
        use proptest::test_runner::RngSeed;
        assert_eq!(seed(None), RngSeed::Fixed(0));
        assert_eq!(seed(Some("17")), RngSeed::Fixed(17));
        assert_eq!(seed(Some("random")), RngSeed::Random);
        assert_eq!(config(10).rng_seed, seed(std::env::var("REPRISE_FUZZ_SEED").ok().as_deref()));
    }

    /// Mutations stay within the input and do what they say.
    #[test]
    fn mutations_apply() {
        let mut d = b"a,1.5\nb,2\n".to_vec();
        Mutation::Number { nth: 0, with: "NaN".into() }.apply(&mut d);
        assert_eq!(d, b"a,NaN\nb,2\n");
        Mutation::Truncate { at: 0.5 }.apply(&mut d);
        assert_eq!(d.len(), 5);
        Mutation::Duplicate { at: 0.0, len: 2, times: 2 }.apply(&mut d);
        assert_eq!(&d[..6], b"a,a,a,");
        let mut e = Vec::new();
        Mutation::FlipBit { at: 0.9, bit: 3 }.apply(&mut e);
        Mutation::Delete { at: 0.9, len: 3 }.apply(&mut e);
        assert!(e.is_empty());
    }

    /// A panic inside `within` reaches the caller; a slow function is a failure.
    #[test]
    fn within_reraises_and_times_out() {
        assert_eq!(within(LIMIT, || 7), 7);
        assert!(std::panic::catch_unwind(|| within(LIMIT, || panic!("boom"))).is_err());
        let slow = std::panic::catch_unwind(|| within(Duration::from_millis(10), || std::thread::sleep(LIMIT)));
        assert!(slow.is_err());
    }
}
