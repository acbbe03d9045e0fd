//! How artifacts are encoded on disk (a test process of its own: `integrity` turns on
//! deferred commits, which are process-wide).

use reprise_artifact::table::{self, Columns, Kind, Table};
use reprise_artifact::Provenance;

const KIND: Kind = Kind { name: "test", version: 1 };

/// Floating-point columns are written byte-stream split (smaller for smooth curves), the
/// others as before, and every value reads back.
#[test]
fn float_columns_are_byte_stream_split() {
    use parquet::basic::Encoding;
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.parquet");
    let names: Vec<String> = (0..200).map(|i| format!("clip{}", i % 7)).collect();
    let columns = Columns::new()
        .f64("v", (0..200).map(|i| f64::from(i) * 0.25).collect())
        .i64("frame", (0..200).collect())
        .str("clip", &names);
    table::write(&path, KIND, columns, &Provenance::new("t", "0", serde_json::json!({})), &[]).unwrap();
    let reader = SerializedFileReader::new(std::fs::File::open(&path).unwrap()).unwrap();
    let group = reader.metadata().row_group(0);
    let encodings = |name: &str| {
        let column = group.columns().iter().find(|c| c.column_path().string() == name).unwrap();
        column.encodings().collect::<Vec<_>>()
    };
    assert!(encodings("v").contains(&Encoding::BYTE_STREAM_SPLIT), "{:?}", encodings("v"));
    assert!(
        !encodings("frame").contains(&Encoding::BYTE_STREAM_SPLIT)
            && !encodings("clip").contains(&Encoding::BYTE_STREAM_SPLIT)
    );
    let t = Table::read(&path, KIND).unwrap();
    assert_eq!(t.f64("v").unwrap(), (0..200).map(|i| f64::from(i) * 0.25).collect::<Vec<_>>());
}
