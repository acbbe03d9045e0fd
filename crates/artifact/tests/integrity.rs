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
    assert!(message.contains("t.parquet: the file is corrupt"), "{message}");
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
