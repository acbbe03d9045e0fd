//! Whole-file integrity, in its own test process because [`table::defer_commits`] is
//! process-wide: a flipped bit anywhere in an artifact's data never reads back as other
//! numbers, and deferred outputs are replaced together.

use reprise_artifact::table::{self, Columns, Kind, Table};
use reprise_artifact::{ArtifactError, Provenance};

const KIND: Kind = Kind { name: "test", version: 1 };

fn write(path: &std::path::Path, seed: f64) {
    let values: Vec<f64> = (0..200).map(|i| f64::from(i) * seed).collect();
    let names: Vec<String> = (0..200).map(|i| format!("clip{}", i % 7)).collect();
    let columns = Columns::new().f64("v", values).i64("frame", (0..200).collect()).str("clip", &names);
    table::write(path, KIND, columns, &Provenance::new("t", "0", serde_json::json!({})), &[]).unwrap();
}

fn content(t: &Table) -> (Vec<f64>, Vec<i64>, Vec<String>) {
    (t.f64("v").unwrap().to_vec(), t.i64("frame").unwrap().to_vec(), t.strings("clip").unwrap())
}

/// A single-bit flip in the data pages (every other byte, a varying bit) either fails to read or reads back the same
/// content; at least some are caught by the content checksum alone.
#[test]
fn a_flipped_bit_never_reads_as_other_data() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.parquet");
    write(&path, 0.37);
    let original = std::fs::read(&path).unwrap();
    let expected = content(&Table::read(&path, KIND).unwrap());
    let footer = u32::from_le_bytes(original[original.len() - 8..original.len() - 4].try_into().unwrap()) as usize;
    let data_end = original.len() - 8 - footer;
    let (mut corrupt, mut other) = (0, 0);
    for byte in (4..data_end).step_by(2) {
        let bit = byte % 8;
        let mut bytes = original.clone();
        bytes[byte] ^= 1 << bit;
        std::fs::write(&path, &bytes).unwrap();
        match Table::read(&path, KIND) {
            Ok(t) => assert_eq!(content(&t), expected, "byte {byte} bit {bit} read back different data"),
            Err(ArtifactError::Corrupt { .. }) => corrupt += 1,
            Err(_) => other += 1,
        }
    }
    assert!(corrupt > 0, "no flip reached the checksum ({other} failed otherwise)");
    let message = {
        let mut bytes = original.clone();
        let mut found = None;
        for byte in 4..data_end {
            bytes[byte] ^= 1;
            std::fs::write(&path, &bytes).unwrap();
            if let Err(e @ ArtifactError::Corrupt { .. }) = Table::read(&path, KIND) {
                found = Some(e.to_string());
                break;
            }
            bytes[byte] ^= 1;
        }
        found.unwrap()
    };
    assert!(message.contains("t.parquet: its data does not match the checksum reprise wrote"), "{message}");
}

/// After `defer_commits`, outputs appear only at `commit_pending`, all together; reads
/// in the process see the pending content; `discard_pending` leaves the old files.
#[test]
fn deferred_outputs_are_replaced_together() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.parquet"), dir.path().join("b.parquet"));
    write(&a, 1.0);
    write(&b, 1.0);
    let (old_a, old_b) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    table::defer_commits();
    write(&a, 2.0);
    write(&b, 2.0);
    assert_eq!(std::fs::read(&a).unwrap(), old_a, "not replaced before the commit");
    assert_eq!(Table::read(&a, KIND).unwrap().f64("v").unwrap()[1], 2.0, "the process reads what it wrote");
    table::discard_pending();
    assert_eq!((std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap()), (old_a.clone(), old_b));
    write(&a, 3.0);
    write(&b, 3.0);
    table::commit_pending().unwrap();
    assert_eq!(Table::read(&b, KIND).unwrap().f64("v").unwrap()[1], 3.0);
    assert_ne!(std::fs::read(&a).unwrap(), old_a);
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 2, "no temporary file is left: {names:?}");
}

/// A footer whose column chunk starts before the file (a negative offset: the
/// `parquet` crate asserts on it) or ends past it is an error naming the file and the
/// column, not a panic; found by the ingest stage's generative tests.
#[test]
fn a_column_chunk_outside_the_file_is_an_error() {
    use parquet::file::metadata::{ParquetMetaDataReader, ParquetMetaDataWriter};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.parquet");
    write(&path, 0.5);
    let original = std::fs::read(&path).unwrap();
    let metadata = ParquetMetaDataReader::new().parse_and_finish(&std::fs::File::open(&path).unwrap()).unwrap();
    let footer = u32::from_le_bytes(original[original.len() - 8..original.len() - 4].try_into().unwrap()) as usize;
    let data_end = original.len() - 8 - footer;
    for (offset, size) in [(-40_i64, None), (4, Some(1_000_000_i64))] {
        let mut builder = metadata.clone().into_builder();
        let groups = builder.take_row_groups();
        let groups = groups
            .into_iter()
            .map(|g| {
                let mut columns: Vec<_> = g.columns().to_vec();
                let mut first =
                    columns[0].clone().into_builder().set_data_page_offset(offset).set_dictionary_page_offset(None);
                if let Some(size) = size {
                    first = first.set_total_compressed_size(size);
                }
                columns[0] = first.build().unwrap();
                g.into_builder().set_column_metadata(columns).build().unwrap()
            })
            .collect();
        let damaged_meta = builder.set_row_groups(groups).build();
        let mut bytes = original[..data_end].to_vec();
        ParquetMetaDataWriter::new(&mut bytes, &damaged_meta).finish().unwrap();
        std::fs::write(&path, &bytes).unwrap();
        let e = Table::read_any(&path).unwrap_err().to_string();
        assert!(e.contains("t.parquet") && e.contains("column 0 (`v`)") && e.contains("outside"), "{e}");
    }
}
