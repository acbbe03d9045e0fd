//! Generative tests of the synthesis script parser: mutated copies of the shipped demo
//! scripts and token soup parse to scripts or a message — never a panic or a hang — and
//! every script that parses asks for bounded work (durations and blends within the
//! documented limits), so no typo reaches the engine as a huge allocation.

use reprise_fuzzkit::proptest::prelude::*;
use reprise_fuzzkit::{config, mutated_text, token_soup, within, LIMIT};
use reprise_synth_engine::script::{Command, Script, MAX_BLEND_FRAMES, MAX_SECONDS};

const DEMO: &str = include_str!("../../../datasets/dragon-face/scripts/demo.toml");

const SINGLE: &str = "name = \"r\"\nseed = 1\nstart = { label = \"neutral\", segment = 20, frame = 0 }\n\
[[command]]\ntype = \"idle\"\nduration = 2.0\nradius = 0.3\nposes = [{ segment = 20, frame = 40 }]\nhover = 0.8\n\
[[command]]\ntype = \"move\"\nto = { latent = [0.1, -0.4, 0.9] }\nduration = 1.0\npath = \"graph\"\n\
[[command]]\ntype = \"transition\"\nto = \"roar\"\nblend_frames = 12\n[[command]]\ntype = \"play\"\nsegment = 14\n";

const TOKENS: &[&str] = &[
    "[[script]]",
    "[[command]]",
    "[[script.command]]",
    "type",
    "\"idle\"",
    "\"move\"",
    "\"transition\"",
    "\"play\"",
    "duration",
    "radius",
    "poses",
    "hover",
    "to",
    "path",
    "\"straight\"",
    "blend_frames",
    "segment",
    "clip",
    "frame",
    "latent",
    "start",
    "seed",
    "name",
    "label",
    " = ",
    "nan",
    "inf",
    "1e300",
    "-1",
    "{",
    "}",
    "\"\"\"",
];

/// Parses `text` both ways; whatever parses respects the limits.
fn check(text: String) {
    let scripts = within(LIMIT, move || (Script::parse(&text).ok(), Script::parse_file(&text, "s").ok()));
    for s in scripts.0.into_iter().chain(scripts.1.into_iter().flatten()) {
        for c in &s.commands {
            match c {
                Command::Idle { duration, hover, .. } => {
                    assert!(*duration <= MAX_SECONDS && hover.is_none_or(|h| h <= MAX_SECONDS), "{c:?}")
                }
                Command::Move { duration, .. } => assert!(*duration <= MAX_SECONDS, "{c:?}"),
                Command::Transition { blend_frames, .. } => {
                    assert!(blend_frames.is_none_or(|b| (1..=MAX_BLEND_FRAMES).contains(&b)), "{c:?}")
                }
                Command::Play { .. } => {}
            }
        }
    }
}

proptest! {
    #![proptest_config(config(300))]

    #[test]
    fn mutated_demo_scripts(text in mutated_text(DEMO, TOKENS)) {
        check(text);
    }

    #[test]
    fn mutated_single_script(text in mutated_text(SINGLE, TOKENS)) {
        check(text);
    }

    #[test]
    fn token_soup_scripts(text in token_soup(TOKENS)) {
        check(text);
    }
}

/// Found: `duration = 1e300` passed validation and would have had the engine allocate
/// 10³⁰¹ frames; `blend_frames = 18446744073709551615` likewise.
#[test]
fn absurd_durations_and_blends_are_refused() {
    for (from, to) in [
        ("duration = 2.0", "duration = 1e300"),
        ("hover = 0.8", "hover = 1e9"),
        ("duration = 1.0", "duration = 3600.5"),
        ("blend_frames = 12", "blend_frames = 3600001"),
    ] {
        let err = Script::parse(&SINGLE.replace(from, to)).expect_err(to);
        assert!(err.starts_with("command "), "{to}: {err}");
    }
    assert!(Script::parse(SINGLE).is_ok());
    assert!(Script::parse_file(DEMO, "demo").is_ok());
}
