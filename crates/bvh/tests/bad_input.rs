//! Malformed files: each error names the file and the line, and says what was expected.

use reprise_bvh::{parse, BvhError, BvhRig};

/// A valid file; tests replace one numbered line (1-based) to break it.
const GOOD: [&str; 20] = [
    "HIERARCHY",                                                                // 1
    "ROOT Hips",                                                                // 2
    "{",                                                                        // 3
    "  OFFSET 0 0 0",                                                           // 4
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation", // 5
    "  JOINT Arm",                                                              // 6
    "  {",                                                                      // 7
    "    OFFSET 1 0 0",                                                         // 8
    "    CHANNELS 3 Zrotation Xrotation Yrotation",                             // 9
    "    End Site",                                                             // 10
    "    {",                                                                    // 11
    "      OFFSET 0 1 0",                                                       // 12
    "    }",                                                                    // 13
    "  }",                                                                      // 14
    "}",                                                                        // 15
    "MOTION",                                                                   // 16
    "Frames: 2",                                                                // 17
    "Frame Time: 0.1",                                                          // 18
    "0 0 0 0 0 0 0 0 0",                                                        // 19
    "1 0 0 0 0 0 0 0 0",                                                        // 20
];

fn with_line(line: usize, text: &str) -> String {
    let mut lines = GOOD.to_vec();
    lines[line - 1] = text;
    lines.join("\n") + "\n"
}

fn error_for(text: &str) -> BvhError {
    parse("bad.bvh", text).expect_err("the file is malformed")
}

fn assert_names_line(err: &BvhError, line: usize) {
    let message = err.to_string();
    assert!(message.starts_with(&format!("bad.bvh: line {line}: ")), "{message}");
}

#[test]
fn the_good_file_parses() {
    let bvh = parse("good.bvh", &(GOOD.join("\n") + "\n")).unwrap();
    assert_eq!(bvh.nodes.len(), 3);
    assert_eq!(bvh.channel_count, 9);
    assert_eq!(bvh.frames, 2);
}

#[test]
fn missing_closing_brace() {
    let err = error_for(&with_line(15, ""));
    assert!(matches!(err, BvhError::Syntax { line: 16, .. }), "{err:?}");
    assert_names_line(&err, 16);
    let message = err.to_string();
    assert!(message.contains("`}` closing `ROOT Hips` (line 2)") && message.ends_with("found `MOTION`"), "{message}");
}

#[test]
fn missing_opening_brace() {
    let err = error_for(&with_line(7, ""));
    assert!(matches!(err, BvhError::Syntax { line: 8, .. }), "{err:?}");
    assert_eq!(err.to_string(), "bad.bvh: line 8: expected `{` after `JOINT Arm` (line 6), found `OFFSET`");
}

#[test]
fn offset_without_three_numbers() {
    let err = error_for(&with_line(8, "    OFFSET 1 0"));
    assert!(matches!(err, BvhError::Offset { line: 8, .. }), "{err:?}");
    assert_eq!(err.to_string(), "bad.bvh: line 8: OFFSET needs 3 numbers on its line, found 2 values (`1` `0`)");
    let err = error_for(&with_line(12, "      OFFSET 0 one 0"));
    assert!(matches!(err, BvhError::Offset { line: 12, .. }), "{err:?}");
}

#[test]
fn channels_count_mismatch() {
    let err = error_for(&with_line(9, "    CHANNELS 3 Zrotation Xrotation"));
    assert!(matches!(err, BvhError::ChannelCount { line: 9, named: 2, .. }), "{err:?}");
    assert_eq!(err.to_string(), "bad.bvh: line 9: CHANNELS declares 3 channels but names 2 (Zrotation Xrotation)");
}

#[test]
fn unknown_channel_name() {
    let err = error_for(&with_line(9, "    CHANNELS 3 Zrotation Xrotation Wrotation"));
    assert!(matches!(&err, BvhError::UnknownChannel { line: 9, name, .. } if name == "Wrotation"), "{err:?}");
    assert_names_line(&err, 9);
    assert!(err.to_string().contains("unknown channel name `Wrotation`"));
}

#[test]
fn end_site_may_only_hold_an_offset() {
    let err = error_for(&with_line(12, "      CHANNELS 1 Xrotation"));
    assert!(matches!(err, BvhError::Node { line: 12, .. }), "{err:?}");
    assert!(err.to_string().contains("`End Site` (line 10) must hold exactly one OFFSET, found `CHANNELS`"), "{err}");
    let err = error_for(&with_line(10, "    End"));
    assert!(matches!(err, BvhError::Syntax { line: 11, .. }), "{err:?}");
}

#[test]
fn motion_line_with_wrong_number_of_values() {
    let err = error_for(&with_line(20, "1 0 0 0 0 0 0 0"));
    assert!(matches!(err, BvhError::ValueCount { line: 20, found: 8, expected: 9, .. }), "{err:?}");
    assert_eq!(
        err.to_string(),
        "bad.bvh: line 20: motion line has 8 values, expected 9 (the channels declared in the hierarchy)"
    );
}

#[test]
fn fewer_motion_lines_than_frames() {
    let err = error_for(&with_line(20, ""));
    assert!(matches!(err, BvhError::FrameCount { line: 20, frames_line: 17, declared: 2, .. }), "{err:?}");
    assert_eq!(
        err.to_string(),
        "bad.bvh: line 20: `Frames:` (line 17) declares 2 frames but the file ends after 1 motion line"
    );
}

#[test]
fn more_motion_lines_than_frames() {
    let text = GOOD.join("\n") + "\n2 0 0 0 0 0 0 0 0\n";
    let err = error_for(&text);
    assert!(matches!(err, BvhError::FrameCount { line: 21, .. }), "{err:?}");
    assert_names_line(&err, 21);
}

#[test]
fn non_numeric_motion_value() {
    let err = error_for(&with_line(19, "0 0 0 0 abc 0 0 0 0"));
    assert!(matches!(&err, BvhError::Number { line: 19, column: 5, text, .. } if text == "abc"), "{err:?}");
    assert_eq!(err.to_string(), "bad.bvh: line 19: motion value 5 `abc` is not a finite number");
    let err = error_for(&with_line(19, "0 0 0 0 NaN 0 0 0 0"));
    assert!(matches!(err, BvhError::Number { line: 19, .. }), "{err:?}");
}

#[test]
fn zero_or_bad_frame_time() {
    let err = error_for(&with_line(18, "Frame Time: 0"));
    assert!(matches!(err, BvhError::FrameTime { line: 18, .. }), "{err:?}");
    assert_eq!(
        err.to_string(),
        "bad.bvh: line 18: expected `Frame Time: <seconds>` (a positive number), found `Frame Time: 0`"
    );
    for bad in ["Frame Time: -0.1", "Frame Time:", "FrameTime: 0.1"] {
        assert!(matches!(error_for(&with_line(18, bad)), BvhError::FrameTime { line: 18, .. }), "{bad}");
    }
}

#[test]
fn missing_or_bad_frames_line() {
    for bad in ["Frames: many", "Frames: -2", "Frames 2", "0 0 0"] {
        let err = error_for(&with_line(17, bad));
        assert!(matches!(err, BvhError::Frames { line: 17, .. }), "{bad}: {err:?}");
    }
    let truncated = GOOD[..16].join("\n");
    let err = error_for(&truncated);
    assert!(matches!(err, BvhError::Frames { line: 16, .. }), "{err:?}");
    assert!(err.to_string().ends_with("found the end of the file"));
}

#[test]
fn hierarchy_must_start_and_end_properly() {
    let err = error_for(&with_line(1, "HIERARCHIE"));
    assert!(matches!(err, BvhError::Syntax { line: 1, .. }), "{err:?}");
    let err = error_for(&GOOD[..10].join("\n"));
    assert!(matches!(err, BvhError::Syntax { line: 10, .. }), "{err:?}");
    assert!(err.to_string().ends_with("found the end of the file"), "{err}");
    let err = error_for(&with_line(4, "  CHANNELS 0"));
    assert!(matches!(err, BvhError::Node { .. } | BvhError::Syntax { .. }), "{err:?}");
}

#[test]
fn missing_file_is_an_io_error_naming_it() {
    let err = BvhRig::open(std::path::Path::new("/nonexistent/dir/ghost.bvh")).unwrap_err();
    assert!(matches!(err, BvhError::Io { .. }), "{err:?}");
    assert!(err.to_string().starts_with("ghost.bvh: cannot read the file"), "{err}");
}

#[test]
fn resampling_rejects_bad_rates_and_empty_motion() {
    let bvh = parse("good.bvh", &(GOOD.join("\n") + "\n")).unwrap();
    for fps in [0.0, -24.0, f64::NAN] {
        let err = reprise_bvh::resample(&bvh, "good", fps).unwrap_err();
        assert!(matches!(err, BvhError::Resample { line: 17, .. }), "{err:?}");
    }
    let empty = GOOD[..16].join("\n") + "\nFrames: 0\nFrame Time: 0.1\n";
    let bvh = parse("empty.bvh", &empty).unwrap();
    assert_eq!(BvhRig::from_bvh(&bvh).vertex_count(), 3);
    let err = reprise_bvh::resample(&bvh, "empty", 24.0).unwrap_err();
    assert_eq!(err.to_string(), "empty.bvh: line 17: cannot resample: the file has no frames");
}
