//! Generative tests of the curve-table reader: mutated valid CSV (wide and long, with
//! timecodes) and Parquet tables, and token soup, become frames or an error naming the
//! file — never a panic, an allocation sized by a typo, or a hang. Every case is read
//! from a file as `ingest` does, with a smaller `--max-frames` so bounded work stays
//! fast.

use reprise_artifact::{table, Columns, Kind, Provenance};
use reprise_fuzzkit::proptest::prelude::*;
use reprise_fuzzkit::{config, mutated, mutated_text, token_soup, within, LIMIT};

use super::args;
use crate::from_table;

const WIDE: &str = "clip,frame,jaw,brow_L,eye_R\nwalk,0,0.5,1,-2\nwalk,1,0.25,1.5,-2.5e-1\nwalk,2,0,2,-3\n\
run,0,1,1,1\nrun,3,2,\"2\",2\n";
const LONG: &str =
    "clip,time,control,value\na,0,jaw,1\na,0,brow,2\na,0.05,jaw,1.5\na,0.05,brow,2.5\nb,1.5,jaw,0\nb,1.5,brow,0\n";
const TIMECODE: &str =
    "Timecode,BlendShapeCount,JawOpen,EyeBlinkLeft\n01:02:03:04.5,2,0.1,0.2\n01:02:03:05.5,2,0.2,0.3\n";

const TOKENS: &[&str] = &[
    "clip",
    "frame",
    "time",
    "control",
    "value",
    "label",
    "segment_id",
    "jaw",
    ",",
    ";",
    "\t",
    "\"",
    "\n",
    "\r\n",
    "1e9",
    "1000000000",
    "-1",
    "NaN",
    "inf",
    "0,5",
    "99:99:99:99",
    "00:00:00:1e300",
    "4294967295:00:00:00",
];

/// Reads `bytes` as `name` with ingest's options, at most 20 000 frames.
fn check(name: &'static str, bytes: Vec<u8>, timecode: bool) {
    within(LIMIT, move || {
        let dir = tempfile::tempdir().unwrap();
        let mut a = args(dir.path(), name, "");
        std::fs::write(a.io.curves.as_ref().unwrap(), bytes).unwrap();
        a.max_frames = 20_000;
        a.max_values = 2_000_000;
        if timecode {
            a.time_column = Some("Timecode".into());
            a.source_fps = Some(60.0);
            a.ignore_columns = vec!["BlendShapeCount".into()];
        }
        let path = a.io.curves.clone().unwrap();
        if let Err(e) = from_table(&a, &path) {
            assert!(e.to_string().contains(name), "{e}");
        }
    });
}

/// A valid Parquet wide table.
fn parquet_seed() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.parquet");
    let cols = Columns::new()
        .str("clip", &["a", "a", "a", "b"])
        .i64("frame", vec![0, 1, 2, 0])
        .f64("jaw", vec![0.0, 0.5, 1.0, 2.0])
        .f64("brow", vec![1.0, 1.0, 1.0, 3.0]);
    let prov = Provenance::new("user", "0", serde_json::json!({}));
    table::write(&path, Kind { name: "user", version: 1 }, cols, &prov, &[]).unwrap();
    std::fs::read(path).unwrap()
}

proptest! {
    #![proptest_config(config(250))]

    #[test]
    fn mutated_wide_csv(text in mutated_text(WIDE, TOKENS)) {
        check("w.csv", text.into_bytes(), false);
    }

    #[test]
    fn mutated_long_csv(text in mutated_text(LONG, TOKENS)) {
        check("l.csv", text.into_bytes(), false);
    }

    #[test]
    fn mutated_timecode_csv(text in mutated_text(TIMECODE, TOKENS)) {
        check("t.csv", text.into_bytes(), true);
    }

    #[test]
    fn token_soup_csv(text in token_soup(TOKENS)) {
        check("s.csv", format!("clip,frame,jaw\n{text}").into_bytes(), false);
    }

    #[test]
    fn mutated_parquet(bytes in mutated(parquet_seed(), TOKENS)) {
        check("p.parquet", bytes, false);
    }
}

/// The seeds read.
#[test]
fn the_seed_tables_read() {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes, tc) in [
        ("w.csv", WIDE.as_bytes().to_vec(), false),
        ("l.csv", LONG.as_bytes().to_vec(), false),
        ("t.csv", TIMECODE.as_bytes().to_vec(), true),
        ("p.parquet", parquet_seed(), false),
    ] {
        let mut a = args(dir.path(), name, "");
        std::fs::write(a.io.curves.as_ref().unwrap(), bytes).unwrap();
        if tc {
            a.time_column = Some("Timecode".into());
            a.source_fps = Some(60.0);
            a.ignore_columns = vec!["BlendShapeCount".into()];
        }
        let path = a.io.curves.clone().unwrap();
        from_table(&a, &path).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

/// Found: two rows a long time apart in a table of many controls passed the frame limit
/// but would allocate frames × controls values without bound; now `--max-values` refuses it.
#[test]
fn many_controls_over_a_long_span_are_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let header: Vec<String> = (0..2000).map(|c| format!("c{c}")).collect();
    let row = |f: i64| format!("{f},{}", vec!["0"; 2000].join(","));
    let text = format!("frame,{}\n{}\n{}\n", header.join(","), row(0), row(999_999));
    let mut a = args(dir.path(), "many.csv", &text);
    a.max_values = 200_000_000;
    let path = a.io.curves.clone().unwrap();
    let e = from_table(&a, &path).unwrap_err().to_string();
    assert!(e.contains("many.csv: line 3, column `frame`") && e.contains("--max-values 200000000"), "{e}");
}

/// Found: `-0` beside `0` in a long table's time column panicked ("time is among the
/// distinct times"); they are one time.
#[test]
fn minus_zero_is_zero() {
    let dir = tempfile::tempdir().unwrap();
    let a =
        args(dir.path(), "z.csv", "clip,time,control,value\na,-0,jaw,1\na,0,brow,2\na,0.05,jaw,1.5\na,0.05,brow,2.5\n");
    let path = a.io.curves.clone().unwrap();
    let (frames, _, _) = from_table(&a, &path).unwrap();
    assert_eq!(frames.row(0), &[1.0, 2.0]);
    let dup = args(dir.path(), "d.csv", "clip,time,control,value\na,-0,jaw,1\na,0,jaw,2\n");
    let e = from_table(&dup, dup.io.curves.as_ref().unwrap()).unwrap_err().to_string();
    assert!(e.contains("d.csv: line 3") && e.contains("repeats line 2"), "{e}");
}
