//! Stage-level tests on small curve tables written to a tempdir.

use std::path::{Path, PathBuf};

use reprise_artifact::clips;
use reprise_artifact::controls::{Controls, RigRef};
use reprise_artifact::frames::Frames;

use crate::{run, Args, Io, Layout};

mod generative;

pub(super) fn args(dir: &Path, name: &str, text: &str) -> Args {
    let curves = dir.join(name);
    std::fs::write(&curves, text).unwrap();
    Args {
        io: Io {
            curves: Some(curves),
            bvh: vec![],
            gltf: None,
            blendshapes: None,
            frames: dir.join("frames.parquet"),
            controls: dir.join("controls.parquet"),
            clips: dir.join("clips.parquet"),
            check: false,
        },
        generate: None,
        seed: 7,
        corpus_scale: 1.0,
        layout: Layout::Auto,
        fps: 24.0,
        max_frames: 1_000_000,
        max_values: 200_000_000,
        source_fps: None,
        clip: None,
        time_column: None,
        ignore_columns: vec![],
        external_rig: vec![],
    }
}

fn outputs(a: &Args) -> [&PathBuf; 3] {
    [&a.io.frames, &a.io.controls, &a.io.clips]
}

#[test]
fn wide_csv_with_clips() {
    let dir = tempfile::tempdir().unwrap();
    let a = args(dir.path(), "c.csv", "clip,frame,jaw,brow\nx,0,0,1\nx,1,0.5,1\ny,0,2,1\ny,1,3,1\ny,2,4,1\n");
    let s = run(&a).unwrap().unwrap();
    assert_eq!((s.frames, s.controls, s.clips), (5, 2, 2));
    let f = Frames::read(&a.io.frames).unwrap();
    assert_eq!(f.controls, vec!["jaw", "brow"]);
    assert_eq!(f.row(3), &[3.0, 1.0]);
    let c = Controls::read(&a.io.controls).unwrap();
    assert_eq!(c.rig, RigRef::None);
    assert_eq!(c.controls.iter().map(|c| c.animated).collect::<Vec<_>>(), vec![true, false]);
    assert_eq!((c.controls[0].min, c.controls[0].max), (0.0, 4.0));
    let cl = clips::read(&a.io.clips).unwrap();
    assert_eq!(cl.iter().map(|c| c.frames).collect::<Vec<_>>(), vec![2, 3]);
}

/// A long table at 48 fps (by its `time` column) is resampled to 24 fps and gives the
/// same frames as the equivalent wide table.
#[test]
fn long_table_resampled_matches_wide() {
    let dir = tempfile::tempdir().unwrap();
    let mut long = String::from("control,time,value\n");
    let mut wide = String::from("time,a,b\n");
    for i in 0..9 {
        let t = f64::from(i) / 48.0;
        long.push_str(&format!("b,{t},{}\na,{t},{}\n", 2.0 * t, t * t));
        wide.push_str(&format!("{t},{},{}\n", t * t, 2.0 * t));
    }
    let a = args(dir.path(), "long.csv", &long);
    run(&a).unwrap();
    let from_long = Frames::read(&a.io.frames).unwrap();
    assert_eq!(from_long.rows(), 5);
    assert_eq!(from_long.controls, vec!["b", "a"]);
    let sub = dir.path().join("w");
    std::fs::create_dir(&sub).unwrap();
    let w = args(&sub, "long.csv", &wide);
    run(&w).unwrap();
    let from_wide = Frames::read(&w.io.frames).unwrap();
    for r in 0..5 {
        assert_eq!(from_long.row(r)[0], from_wide.row(r)[1]);
        assert!((from_long.row(r)[1] - from_wide.row(r)[0]).abs() < 1e-12);
    }
    assert!((clips::read(&a.io.clips).unwrap()[0].source_fps - 48.0).abs() < 1e-6);
}

#[test]
fn source_fps_converts_frame_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = args(dir.path(), "c.csv", "frame,v\n0,0\n1,1\n2,2\n3,3\n4,4\n");
    a.source_fps = Some(48.0);
    a.clip = Some("take".into());
    run(&a).unwrap();
    let f = Frames::read(&a.io.frames).unwrap();
    assert_eq!(f.column(0), vec![0.0, 2.0, 4.0]);
    assert_eq!(f.clip[0], "take");
}

#[test]
fn dragon_face_generates_the_corpus() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = args(dir.path(), "unused.csv", "");
    a.io.curves = None;
    a.generate = Some(crate::Generator::DragonFace);
    let s = run(&a).unwrap().unwrap();
    assert!((700..=800).contains(&s.controls), "{}", s.controls);
    assert!(s.frames > 3745, "good frames plus bad takes, got {}", s.frames);
    let c = Controls::read(&a.io.controls).unwrap();
    assert!(matches!(c.rig, RigRef::DragonFace { seed: 7, .. }));
    assert!(c.controls.iter().any(|c| !c.animated), "some controls never move");
    assert!(c.controls.iter().any(|c| c.group == "eyes"));
}

/// A real Live Link Face (ARKit) take: 60 fps SMPTE timecodes, 61 curves, a constant
/// `BlendShapeCount` column dropped, resampled to 24 fps.
#[test]
fn live_link_face_csv() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/datasets/livelinkface_csv/MySlate_3_Jason_Millers_iPhone.csv");
    if !path.exists() {
        assert!(std::env::var_os("CI").is_none(), "CI must have ../shared/datasets/livelinkface_csv");
        eprintln!("SKIPPED live_link_face_csv: ../shared/datasets not found");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mut a = args(dir.path(), "unused.csv", "");
    a.io.curves = Some(path);
    a.time_column = Some("Timecode".into());
    a.ignore_columns = vec!["BlendShapeCount".into()];
    a.source_fps = Some(60.0);
    let s = run(&a).unwrap().unwrap();
    assert_eq!(s.controls, 61);
    // 328 frames at 60 fps span 327/60 s; at 24 fps that is floor(130.8) + 1 frames.
    assert_eq!(s.frames, 131);
    let cl = clips::read(&a.io.clips).unwrap();
    assert!((cl[0].source_fps - 60.0).abs() < 0.5, "{}", cl[0].source_fps);
    let f = Frames::read(&a.io.frames).unwrap();
    let jaw = f.controls.iter().position(|c| c == "JawOpen").unwrap();
    assert!(f.column(jaw).iter().all(|v| (0.0..=1.0).contains(v)));
}

#[test]
fn bad_timecode_names_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = args(dir.path(), "tc.csv", "Timecode,jaw\n00:00:00:01,1\n00:00:0x:02,1\n");
    a.time_column = Some("Timecode".into());
    let err = run(&a).unwrap_err().to_string();
    assert!(err.contains("tc.csv: line 3, column `Timecode`") && err.contains("timecode"), "{err}");
}

/// One test per bad input: a clear message naming the file and where, the INPUT exit
/// code, and earlier artifacts left untouched.
macro_rules! bad_input {
    ($($name:ident: $file:literal, $text:expr, $($needle:literal),+;)*) => {$(
        #[test]
        fn $name() {
            let dir = tempfile::tempdir().unwrap();
            let a = args(dir.path(), $file, $text);
            for out in outputs(&a) {
                std::fs::write(out, b"earlier artifact").unwrap();
            }
            let err = run(&a).unwrap_err();
            let msg = err.to_string();
            assert!(msg.contains($file), "{msg}");
            $(assert!(msg.contains($needle), "expected `{}` in: {msg}", $needle);)+
            assert_eq!(err.code(), reprise_stagekit::exit::INPUT);
            for out in outputs(&a) {
                assert_eq!(std::fs::read(out).unwrap(), b"earlier artifact");
            }
        }
    )*};
}

bad_input! {
    duplicated_column: "d.csv", "frame,jaw,brow,jaw\n0,1,2,3\n", "duplicated column `jaw`", "columns 2 and 4";
    unknown_long_column: "l.csv", "frame,control,value,weight\n0,a,1,1\n", "unknown column `weight`";
    non_numeric_control: "n.csv", "frame,jaw\n0,1\n1,open\n", "line 3", "column `jaw`", "`open` is not a number";
    nan_value: "nan.csv", "frame,jaw\n0,1\n1,NaN\n", "line 3", "column `jaw`", "not finite";
    inf_value: "inf.csv", "frame,jaw\n0,1\n1,inf\n", "line 3", "not finite";
    empty_cell: "e.csv", "frame,jaw,brow\n0,1,\n", "line 2", "column `brow`", "missing value";
    duplicated_frame: "dup.csv", "clip,frame,jaw\na,0,1\na,1,1\na,1,2\n", "line 4", "column `frame`", "repeats line 3";
    frames_going_back: "back.csv", "clip,time,jaw\na,0.0,1\na,0.2,1\na,0.1,2\n", "line 4", "column `time`", "goes back";
    fractional_frame: "frac.csv", "frame,jaw\n0.5,1\n", "line 2", "not a whole frame number";
    no_time_column: "nt.csv", "clip,jaw\na,1\n", "no `frame` or `time` column";
    long_missing_control: "lm.csv", "frame,control,value\n0,a,1\n0,b,1\n1,a,2\n", "time 0.041", "control `b` is missing";
    long_duplicate: "ld.csv", "frame,control,value\n0,a,1\n0,a,2\n", "line 3", "repeats line 2";
    reserved_column: "r.csv", "frame,label\n0,1\n", "`label` is reserved";
    not_a_table: "t.txt", "frame,jaw\n0,1\n", "expected a .csv or .parquet";
    frame_number_typo: "typo.csv", "clip,frame,jaw\na,0,1\na,1,1\na,1000000000,2\n", "line 4", "column `frame`", "clip `a` runs from 0 s to 41666666.6", "--max-frames 1000000", "typo";
    semicolons: "semi.csv", "frame;jaw;brow\n0;1;2\n", "line 1", "separated by `;`, not by commas";
    tabs: "tab.csv", "frame\tjaw\n0\t1\n", "separated by a tab";
    decimal_commas: "dc.csv", "frame,jaw\n0,0,5\n", "line 2", "3 fields where the header has 2", "decimal comma";
    quoted_decimal_comma: "qdc.csv", "frame,jaw\n0,\"0,5\"\n", "line 2", "column `jaw`", "`0,5` has a decimal comma";
}

/// A time column at an absurd --fps is refused by the frame limit before allocating.
#[test]
fn huge_fps_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = args(dir.path(), "c.csv", "clip,time,jaw\na,0,1\na,10,2\n");
    a.fps = 1e9;
    assert_eq!(run(&a).unwrap_err().code(), reprise_stagekit::exit::CONFIG, "above the fps ceiling");
    a.fps = 1000.0;
    a.max_frames = 5000;
    let err = run(&a).unwrap_err().to_string();
    assert!(err.contains("line 3, column `time`") && err.contains("10001 frames"), "{err}");
    a.max_frames = 20_000;
    assert_eq!(run(&a).unwrap().unwrap().frames, 10_001);
}

/// `--generate` makes 24 fps; another --fps is refused, not silently ignored.
#[test]
fn generate_refuses_another_fps() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = args(dir.path(), "unused.csv", "");
    a.io.curves = None;
    a.generate = Some(crate::Generator::DragonFace);
    a.fps = 1e6;
    let err = run(&a).unwrap_err();
    assert_eq!(err.code(), reprise_stagekit::exit::CONFIG);
    a.fps = 30.0;
    assert!(run(&a).unwrap_err().to_string().contains("makes a 24 fps corpus; --fps 30 cannot be honoured"));
}

#[test]
fn missing_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = args(dir.path(), "c.csv", "frame,v\n0,1\n");
    a.io.curves = Some(dir.path().join("nowhere.csv"));
    let err = run(&a).unwrap_err().to_string();
    assert!(err.contains("nowhere.csv"), "{err}");
}

#[test]
fn parquet_curves_with_bad_values_name_the_row() {
    use reprise_artifact::{table, Columns, Kind, Provenance};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.parquet");
    // A user's table (reprise itself never writes a non-finite value).
    let cols = Columns::new().i64("frame", vec![0, 1, 2]).f64_any("jaw", vec![0.0, f64::INFINITY, 1.0]);
    table::write(
        &path,
        Kind { name: "user", version: 1 },
        cols,
        &Provenance::new("x", "0", serde_json::json!({})),
        &[],
    )
    .unwrap();
    let mut a = args(dir.path(), "unused.csv", "");
    a.io.curves = Some(path);
    let err = run(&a).unwrap_err().to_string();
    assert!(err.contains("c.parquet") && err.contains("column `jaw`, row 1"), "{err}");
}

#[test]
fn flags_are_validated() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = args(dir.path(), "c.csv", "frame,v\n0,1\n");
    a.generate = Some(crate::Generator::DragonFace);
    assert!(run(&a).unwrap_err().to_string().contains("not several"));
    a.generate = None;
    a.fps = 0.0;
    assert_eq!(run(&a).unwrap_err().code(), reprise_stagekit::exit::CONFIG);
    a.fps = 24.0;
    a.io.check = true;
    a.io.curves = Some(dir.path().join("not-yet.csv"));
    assert!(run(&a).unwrap().is_none());
}

/// A BVH take of one joint: `frames` frames at 10 fps, rotating about Z by `step`
/// degrees a frame; `bone` is the end site's length.
fn take(frames: usize, step: f64, bone: f64) -> String {
    let mut text = format!(
        "HIERARCHY\nROOT J\n{{\n  OFFSET 0 0 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {{\n    \
         OFFSET 0 {bone} 0\n  }}\n}}\nMOTION\nFrames: {frames}\nFrame Time: 0.1\n"
    );
    for f in 0..frames {
        text.push_str(&format!("{} 0 0\n", step * f as f64));
    }
    text
}

/// Several BVH takes of one skeleton are one ingest: a clip per file (named by its stem),
/// controls' ranges over all of them, the first file as the rig, every file in the
/// provenance. Another skeleton or a repeated stem is refused by name.
#[test]
fn several_bvh_takes_are_one_source() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = args(dir.path(), "unused.csv", "a\n1\n");
    a.io.curves = None;
    a.fps = 10.0;
    for (name, frames, step) in [("walk.bvh", 4, 10.0), ("turn.bvh", 6, -5.0)] {
        std::fs::write(dir.path().join(name), take(frames, step, 1.0)).unwrap();
        a.io.bvh.push(dir.path().join(name));
    }
    let s = run(&a).unwrap().unwrap();
    assert_eq!((s.frames, s.clips), (10, 2));
    let cl = clips::read(&a.io.clips).unwrap();
    assert_eq!(cl.iter().map(|c| (c.clip.as_str(), c.frames)).collect::<Vec<_>>(), [("walk", 4), ("turn", 6)]);
    assert!(cl[1].source.ends_with("turn.bvh"), "{}", cl[1].source);
    let c = Controls::read(&a.io.controls).unwrap();
    let rz = c.controls.iter().find(|c| c.name == "J.rz").unwrap();
    assert!((rz.min + 25f64.to_radians()).abs() < 1e-9 && (rz.max - 30f64.to_radians()).abs() < 1e-9, "{rz:?}");
    assert!(matches!(&c.rig, RigRef::Bvh { path, .. } if path.ends_with("walk.bvh")), "{:?}", c.rig);
    assert_eq!(Frames::read(&a.io.frames).unwrap().rows(), 10);
    let meta = reprise_artifact::table::metadata_of(&a.io.frames).unwrap();
    let prov = &meta[reprise_artifact::provenance::KEY_INPUTS];
    assert!(prov.contains("bvh[0]") && prov.contains("bvh[1]"), "{prov}");

    std::fs::write(dir.path().join("other.bvh"), take(3, 1.0, 2.0)).unwrap();
    a.io.bvh.push(dir.path().join("other.bvh"));
    let e = run(&a).unwrap_err().to_string();
    assert!(e.contains("other.bvh: its skeleton differs from") && e.contains("walk.bvh"), "{e}");
    a.io.bvh.pop();
    std::fs::create_dir(dir.path().join("b")).unwrap();
    std::fs::write(dir.path().join("b/walk.bvh"), take(3, 1.0, 1.0)).unwrap();
    a.io.bvh.push(dir.path().join("b/walk.bvh"));
    let e = run(&a).unwrap_err().to_string();
    assert!(e.contains("two takes named `walk`"), "{e}");
}

/// `reprise-ingest --help` names every source it reads.
#[test]
fn the_help_names_every_source() {
    let about = <Args as clap::CommandFactory>::command().get_about().map(ToString::to_string).unwrap_or_default();
    for source in ["dragon-face", "curve table", "glTF", "BVH"] {
        assert!(about.contains(source), "{about}");
    }
}

/// Round three of the fault catalogue (#27): each refused with the file, the place and
/// what to do, and nothing written.
mod faults_round_three {
    use super::*;

    fn refused(name: &str, text: &str) -> String {
        let dir = tempfile::tempdir().unwrap();
        let a = args(dir.path(), name, text);
        let e = run(&a).expect_err("refused").to_string();
        assert!(outputs(&a).iter().all(|p| !p.exists()), "nothing written: {e}");
        e
    }

    /// 100,000 columns of 10 rows took 6.8 GB; now refused from the header line.
    #[test]
    fn a_table_of_a_hundred_thousand_columns_is_refused_from_its_header() {
        let header: Vec<String> =
            std::iter::once("frame".to_string()).chain((0..100_000).map(|i| format!("c{i}"))).collect();
        let row: Vec<String> =
            std::iter::once("0".to_string()).chain((0..100_000).map(|_| "0.5".to_string())).collect();
        let text = format!("{}\n{}\n", header.join(","), row.join(","));
        let start = std::time::Instant::now();
        let e = refused("wide.csv", &text);
        assert!(e.contains("wide.csv: 100001 controls, more than the 10000 reprise reads"), "{e}");
        assert!(start.elapsed() < std::time::Duration::from_secs(20), "refused at once");
    }

    #[test]
    fn controls_differing_only_in_case_are_refused() {
        let e = refused("c.csv", "frame,Jaw,jaw\n0,0,1\n1,0,1\n");
        assert!(e.contains("c.csv: controls `Jaw` and `jaw` differ only in case"), "{e}");
    }

    #[test]
    fn an_empty_file_says_it_is_empty() {
        let e = refused("c.csv", "");
        assert!(e.contains("c.csv: the file is empty; a curve table starts with a header line"), "{e}");
    }

    /// `1e308` is finite, but its square is not: it made `std = inf` in a later stage.
    #[test]
    fn a_value_whose_square_overflows_is_refused_where_it_is() {
        let e = refused("c.csv", "frame,jaw\n0,0\n1,1e308\n");
        assert!(e.contains("c.csv: line 3, column `jaw`: value 1e308"), "{e}");
        assert!(e.contains("beyond ±1e15"), "{e}");
    }

    /// A device or a directory given as the curve table is refused by name, at once.
    #[cfg(unix)]
    #[test]
    fn a_device_is_not_a_curve_table() {
        let dir = tempfile::tempdir().unwrap();
        let mut a = args(dir.path(), "c.csv", "frame,jaw\n0,0\n");
        let dev = dir.path().join("zero.csv");
        std::os::unix::fs::symlink("/dev/zero", &dev).unwrap();
        a.io.curves = Some(dev);
        let e = run(&a).expect_err("refused").to_string();
        assert!(e.contains("zero.csv: a character device, not a regular file"), "{e}");
    }
}
