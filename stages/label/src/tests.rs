//! Stage-level tests: a small frame table in a tempdir, a labels file, `run`.

use std::path::Path;

use reprise_artifact::frames::{Frames, LabeledFrames};
use reprise_artifact::segments;
use reprise_artifact::Provenance;

use crate::{run, Args};

/// Clips `walk_a` (frames 0..=9), `walk_b` (0..=9), `run_a` (0..=4); two controls.
fn write_frames(dir: &Path) -> std::path::PathBuf {
    let mut f = Frames {
        fps: 24.0,
        controls: vec!["jaw".into(), "eye_L".into()],
        clip: vec![],
        frame: vec![],
        time: vec![],
        values: vec![],
    };
    for (clip, n) in [("walk_a", 10), ("walk_b", 10), ("run_a", 5)] {
        for i in 0..n {
            f.clip.push(clip.into());
            f.frame.push(i);
            f.time.push(i as f64 / 24.0);
            f.values.extend([i as f64, -(i as f64)]);
        }
    }
    let path = dir.join("frames.parquet");
    f.write(&path, &Provenance::new("test", "0", serde_json::json!({}))).unwrap();
    path
}

fn args(dir: &Path, labels: &str, ext: &str) -> Args {
    let labels_path = dir.join(format!("labels.{ext}"));
    std::fs::write(&labels_path, labels).unwrap();
    Args {
        io: crate::Io {
            frames: write_frames(dir),
            controls: None,
            labels: labels_path,
            segments: dir.join("segments.parquet"),
            labeled_frames: dir.join("labeled.parquet"),
            check: false,
        },
        mask: vec![],
        mask_group: vec![],
        min_segment_length: 1,
    }
}

const RULES: &str = r#"
[[rule]]
pattern = "walk_*"
label = "walk"
[[rule]]
pattern = "run_*"
label = "run"
[[range]]
clip = "walk_b"
start = 6
end = 9
label = "run"
[[exclude]]
clip = "walk_a"
start = 3
end = 4
reason = "off-screen"
"#;

#[test]
fn rules_ranges_and_exclusions_make_segments() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = args(dir.path(), RULES, "toml");
    a.mask = vec!["eye_*".into()];
    let summary = run(&a).unwrap().unwrap();
    let segs = segments::read(&a.io.segments).unwrap();
    let got: Vec<(String, String, i64, i64)> =
        segs.iter().map(|s| (s.label.clone(), s.clip.clone(), s.start, s.end)).collect();
    let want = [
        ("walk", "walk_a", 0, 2),
        ("walk", "walk_a", 5, 9),
        ("walk", "walk_b", 0, 5),
        ("run", "walk_b", 6, 9),
        ("run", "run_a", 0, 4),
    ];
    assert_eq!(got, want.map(|(l, c, s, e)| (l.into(), c.into(), s, e)).to_vec());
    assert_eq!(summary.excluded_frames, 2);
    assert_eq!(summary.labels[0].frames, 14);
    let labeled = LabeledFrames::read(&a.io.labeled_frames).unwrap();
    assert_eq!(labeled.frames.controls, vec!["jaw".to_string()]);
    assert_eq!(labeled.masked_controls, vec!["eye_L".to_string()]);
    assert_eq!(labeled.frames.rows(), 23);
    // segment 3 (run on walk_b 6..=9): its first labeled row carries jaw = 6.
    let first = labeled.segment_id.iter().position(|&s| s == 3).unwrap();
    assert_eq!((labeled.frames.frame[first], labeled.frames.values[first]), (6, 6.0));
    // Running twice in one process gives the same outputs.
    run(&a).unwrap();
    assert_eq!(segments::read(&a.io.segments).unwrap(), segs);
}

#[test]
fn min_segment_length_drops_short_runs() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = args(dir.path(), RULES, "toml");
    a.min_segment_length = 4;
    let summary = run(&a).unwrap().unwrap();
    assert_eq!((summary.dropped_segments, summary.dropped_frames), (1, 3));
}

#[test]
fn csv_labels_file() {
    let dir = tempfile::tempdir().unwrap();
    let a = args(dir.path(), "clip,start,end,label\nwalk_a,,,walk\nrun_a,0,4,run\nwalk_a,0,1,!exclude\n", "csv");
    let summary = run(&a).unwrap().unwrap();
    assert_eq!(summary.labels.iter().map(|l| l.frames).collect::<Vec<_>>(), vec![8, 5]);
    assert_eq!(summary.unlabeled_frames, 10);
}

/// One test per bad labels file: the error names the file, the entry and the problem,
/// and no output is written.
macro_rules! bad_labels {
    ($($name:ident: $ext:literal, $text:expr, $($needle:literal),+;)*) => {$(
        #[test]
        fn $name() {
            let dir = tempfile::tempdir().unwrap();
            let a = args(dir.path(), $text, $ext);
            let err = run(&a).unwrap_err();
            let msg = err.to_string();
            assert!(msg.contains(&format!("labels.{}", $ext)), "{msg}");
            $(assert!(msg.contains($needle), "expected `{}` in: {msg}", $needle);)+
            assert_eq!(err.code(), reprise_stagekit::exit::INPUT);
            assert!(!a.io.segments.exists() && !a.io.labeled_frames.exists());
        }
    )*};
}

bad_labels! {
    unknown_clip: "toml", "[[range]]\nclip = \"walk_c\"\nstart = 0\nend = 1\nlabel = \"walk\"\n", "range 1", "clip `walk_c` matches no clip";
    unknown_clip_csv: "csv", "clip,start,end,label\nwalk_a,0,1,walk\nwalkk,0,1,walk\n", "line 3", "`walkk`";
    pattern_matching_nothing: "toml", "[[rule]]\npattern = \"jog_*\"\nlabel = \"jog\"\n", "rule 1", "matches no clip";
    overlapping_ranges: "toml", "[[range]]\nclip = \"walk_a\"\nstart = 0\nend = 5\nlabel = \"walk\"\n[[range]]\nclip = \"walk_a\"\nstart = 5\nend = 9\nlabel = \"run\"\n", "range 2 overlaps range 1", "frame 5";
    past_clip_end: "csv", "clip,start,end,label\nrun_a,0,7,run\n", "line 2", "run past clip `run_a`", "0..=4";
    label_without_frames: "toml", "[[rule]]\npattern = \"*\"\nlabel = \"all\"\n[[range]]\nclip = \"run_a\"\nstart = 0\nend = 4\nlabel = \"run\"\n[[exclude]]\nclip = \"run_a\"\n", "label `run` has no frames";
    unknown_key: "toml", "[[rule]]\npattern = \"*\"\nlable = \"x\"\n", "unknown field `lable`";
    reversed_range: "toml", "[[range]]\nclip = \"walk_a\"\nstart = 5\nend = 2\nlabel = \"walk\"\n", "range 1", "5..=2";
    unknown_csv_column: "csv", "clip,begin,end,label\n", "unknown column `begin`";
    empty_label: "toml", "[[rule]]\npattern = \"*\"\nlabel = \"\"\n", "rule 1", "label `` is empty";
    blank_label_csv: "csv", "clip,start,end,label\nwalk_a,0,1,\"  \"\n", "line 2";
    spaced_label: "toml", "[[range]]\nclip = \"walk_a\"\nstart = 0\nend = 1\nlabel = \" walk\"\n", "range 1", "spaces around it";
    reserved_label: "csv", "clip,start,end,label\nwalk_a,0,1,!skip\n", "line 2", "`!skip` starts with `!`";
}

/// `!exclude` means the same in TOML as in CSV.
#[test]
fn exclude_label_in_toml_excludes_like_csv() {
    let dir = tempfile::tempdir().unwrap();
    let csv = args(dir.path(), "clip,start,end,label\nwalk_a,,,walk\nrun_a,0,4,run\nwalk_a,0,1,!exclude\n", "csv");
    let from_csv = run(&csv).unwrap().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let toml = "[[rule]]\npattern = \"walk_a\"\nlabel = \"walk\"\n[[range]]\nclip = \"run_a\"\nstart = 0\nend = 4\nlabel = \"run\"\n\
                [[range]]\nclip = \"walk_a\"\nstart = 0\nend = 1\nlabel = \"!exclude\"\n";
    let from_toml = run(&args(dir.path(), toml, "toml")).unwrap().unwrap();
    assert_eq!(from_toml.labels.iter().map(|l| l.frames).collect::<Vec<_>>(), vec![8, 5]);
    assert_eq!(from_toml.excluded_frames, from_csv.excluded_frames);
    assert!(from_toml.labels.iter().all(|l| l.label != "!exclude"));
}

#[test]
fn mask_matching_nothing_is_a_config_error() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = args(dir.path(), RULES, "toml");
    a.mask = vec!["tongue_*".into()];
    let err = run(&a).unwrap_err();
    assert!(err.to_string().contains("`tongue_*` matches no control"), "{err}");
    assert_eq!(err.code(), reprise_stagekit::exit::CONFIG);
}

#[test]
fn check_validates_without_reading() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = args(dir.path(), RULES, "toml");
    a.io.frames = dir.path().join("not-yet-written.parquet");
    a.io.check = true;
    assert!(run(&a).unwrap().is_none());
    a.mask_group = vec!["eyes".into()];
    assert!(run(&a).unwrap_err().to_string().contains("--mask-group needs --controls"));
}
