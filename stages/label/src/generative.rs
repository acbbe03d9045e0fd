//! Generative tests of the labels reader (TOML and CSV) and of applying it: mutated
//! valid files and token soup give a labels file or an error naming the file — never a
//! panic or a hang — and whatever parses is applied to a small frame table with the same
//! outcome: segments, or an error naming the file.

use std::path::Path;

use reprise_artifact::frames::Frames;
use reprise_fuzzkit::proptest::prelude::*;
use reprise_fuzzkit::{config, mutated_text, token_soup, within, LIMIT};

use crate::assign::assign;
use crate::labels_file::LabelsFile;

const TOML: &str = "[[rule]]\npattern = \"walk_*\"\nlabel = \"walk\"\n[[rule]]\npattern = \"run_*\"\nlabel = \"run\"\n\
[[range]]\nclip = \"walk_b\"\nstart = 6\nend = 9\nlabel = \"run\"\n[[exclude]]\nclip = \"walk_a\"\nstart = 3\nend = 4\n\
reason = \"off-screen\"\n[[exclude]]\npattern = \"run_?\"\n";

const CSV: &str = "clip,start,end,label,reason\nwalk_a,0,4,walk,\nwalk_a,5,9,!exclude,cheat\nwalk_b,,,run,\n\
run_a,0,4,run,\"quoted, with comma\"\n";

const TOKENS: &[&str] = &[
    "[[rule]]",
    "[[range]]",
    "[[exclude]]",
    "pattern",
    "label",
    "clip",
    "start",
    "end",
    "reason",
    " = ",
    "\"*\"",
    "\"[\"",
    "\"{a,b}\"",
    "\"**/\"",
    "\"!exclude\"",
    "\"!\"",
    "9223372036854775807",
    "-9223372036854775808",
    "walk_a",
    "run_a",
    ",",
    "\"",
];

/// Clips `walk_a`, `walk_b` (frames 0..=9) and `run_a` (0..=4), one control.
fn frames() -> Frames {
    let mut f =
        Frames { fps: 24.0, controls: vec!["jaw".into()], clip: vec![], frame: vec![], time: vec![], values: vec![] };
    for (clip, n) in [("walk_a", 10), ("walk_b", 10), ("run_a", 5)] {
        for i in 0..n {
            f.clip.push(clip.into());
            f.frame.push(i);
            f.time.push(i as f64 / 24.0);
            f.values.push(i as f64);
        }
    }
    f
}

/// Parses `text` as `labels.EXT` and applies it; every error names the file.
fn check(ext: &'static str, text: String) {
    let result = within(LIMIT, move || {
        let path = Path::new("labels").with_extension(ext);
        let file = LabelsFile::parse(&path, &text)?;
        assign(&frames(), &file, &path, 1).map(|a| a.segments.len())
    });
    if let Err(e) = result {
        assert!(e.to_string().starts_with(&format!("labels.{ext}: ")), "{e}");
    }
}

proptest! {
    #![proptest_config(config(300))]

    #[test]
    fn mutated_toml(text in mutated_text(TOML, TOKENS)) {
        check("toml", text);
    }

    #[test]
    fn mutated_csv(text in mutated_text(CSV, TOKENS)) {
        check("csv", text);
    }

    #[test]
    fn token_soup_labels(text in token_soup(TOKENS)) {
        check("toml", text.clone());
        check("csv", format!("clip,start,end,label\n{text}"));
    }
}

/// The seeds are valid.
#[test]
fn the_seed_files_apply() {
    for (ext, text) in [("toml", TOML), ("csv", CSV)] {
        let path = Path::new("labels").with_extension(ext);
        let file = LabelsFile::parse(&path, text).unwrap();
        assert!(!assign(&frames(), &file, &path, 1).unwrap().segments.is_empty());
    }
}
