//! Generative tests of the BVH parser and resampler: mutated valid files and token soup
//! parse to a `Bvh` or a `BvhError` — never a panic, a stack overflow, an allocation
//! sized by a typo, or a hang — and whatever parses resamples to curves or an error.
//! The nasty cases found are kept below as ordinary tests.

use reprise_bvh::{parse, resample, BvhError, MAX_DEPTH};
use reprise_fuzzkit::proptest::prelude::*;
use reprise_fuzzkit::{config, mutated_text, token_soup, within, LIMIT};

/// A valid two-joint file with an end site and two frames.
const GOOD: &str = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation \
Xrotation Yrotation\n  JOINT Arm\n  {\n    OFFSET 1 0 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      \
OFFSET 0 1 0\n    }\n  }\n}\nMOTION\nFrames: 2\nFrame Time: 0.1\n0 0 0 0 0 0 0 0 0\n1 0 0 30 45 -90 10 20 30\n";

/// The format's own words.
const TOKENS: &[&str] = &[
    "HIERARCHY",
    "ROOT",
    "JOINT",
    "End",
    "Site",
    "End Site",
    "OFFSET",
    "CHANNELS",
    "MOTION",
    "Frames:",
    "Frame Time:",
    "Xposition",
    "Yposition",
    "Zposition",
    "Xrotation",
    "Yrotation",
    "Zrotation",
    "{",
    "}",
    "\nJOINT a\n{\n",
    "CHANNELS 3 Xrotation Xrotation Xrotation",
    "OFFSET 1e308 1e308 1e308",
    "Frames: 18446744073709551615",
    "Frame Time: 1e300",
    "Frame Time: 1e-320",
];

/// Parses and, when that succeeds, resamples at 30 fps; the error's message must name the file.
fn parse_and_resample(text: String) {
    let result = within(LIMIT, move || parse("f.bvh", &text).and_then(|b| resample(&b, "f", 30.0).map(|_| ())));
    if let Err(e) = result {
        assert!(e.to_string().starts_with("f.bvh: "), "{e}");
    }
}

proptest! {
    #![proptest_config(config(400))]

    #[test]
    fn mutated_files_parse_or_fail_cleanly(text in mutated_text(GOOD, TOKENS)) {
        parse_and_resample(text);
    }

    #[test]
    fn token_soup_parses_or_fails_cleanly(body in token_soup(TOKENS)) {
        parse_and_resample(format!("HIERARCHY\nROOT r\n{{\n{body}"));
        parse_and_resample(body);
    }
}

fn err(text: &str) -> String {
    let text = text.to_string();
    within(LIMIT, move || parse("f.bvh", &text).and_then(|b| resample(&b, "f", 30.0).map(|_| ())))
        .expect_err("a bad file")
        .to_string()
}

/// Found: 100 000 nested `JOINT`s overflowed the parser's stack (a crash, not an error).
#[test]
fn absurd_nesting_is_refused_not_a_stack_overflow() {
    let mut text = String::from("HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\n");
    text.push_str(&"JOINT j\n{\nOFFSET 0 0 0\n".repeat(100_000));
    let msg = err(&text);
    assert!(msg.contains(&format!("nest more than {MAX_DEPTH} deep")), "{msg}");
    assert!(msg.starts_with(&format!("f.bvh: line {}: ", 5 + 3 * (MAX_DEPTH - 1))), "{msg}");
}

/// Found: `Frame Time: 1e9` (for `1e-9`?) asked the resampler for 3·10¹⁰ frames and aborted
/// on allocation.
#[test]
fn frame_time_typo_is_bounded_before_allocating() {
    let msg = err(&GOOD.replace("Frame Time: 0.1", "Frame Time: 1e9"));
    assert!(msg.contains("more than the limit of 1000000") && msg.contains("Frame Time"), "{msg}");
    assert!(msg.starts_with("f.bvh: line 17: cannot resample: "), "{msg}");
}

/// A declared frame count far beyond the lines present reserves nothing for it and says
/// how many lines there are.
#[test]
fn huge_declared_frame_count_is_a_count_error() {
    let msg = err(&GOOD.replace("Frames: 2", "Frames: 18446744073709551615"));
    assert!(msg.contains("declares 18446744073709551615 frames but the file ends after 2 motion lines"), "{msg}");
}

/// A typed error, not a panic, for every line of the file cut off.
#[test]
fn every_truncation_fails_cleanly() {
    for cut in 0..GOOD.len() {
        if let Err(e) = parse("f.bvh", &GOOD[..cut]) {
            assert!(
                matches!(
                    e,
                    BvhError::Syntax { .. }
                        | BvhError::FrameCount { .. }
                        | BvhError::Frames { .. }
                        | BvhError::FrameTime { .. }
                        | BvhError::Offset { .. }
                        | BvhError::ChannelCount { .. }
                        | BvhError::UnknownChannel { .. }
                        | BvhError::Node { .. }
                        | BvhError::ValueCount { .. }
                        | BvhError::Number { .. }
                ),
                "{e}"
            );
        }
    }
}
