//! Label partitions of an artifact: the blake3 of each label's rows, so the runner can say
//! *which* labels of a changed input changed (the first step of partitioned stages; the
//! docs/pipeline.md, "Partitioned stages").
//!
//! A Parquet artifact with a Utf8 column `label` has one partition per label. A partition's
//! digest hashes its shape (the name and type of every column but `label` that has a value
//! in one of the label's rows) and, in file order, each of the label's rows over those
//! columns in arrow's row format. A `segment_id` column is hashed as the
//! segment's ordinal within the label (0 for its first segment, …): ids are numbered across
//! labels, so another label gaining a segment renumbers this one's without changing its data.

use std::collections::BTreeMap;
use std::fs::File;
use std::path::Path;

use arrow::array::{Array, Int64Array, StringArray};
use arrow::datatypes::DataType;
use arrow::record_batch::{RecordBatch, RecordBatchReader};
use arrow::row::{RowConverter, SortField};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

/// The column that names a row's partition.
pub const PARTITION_COLUMN: &str = reprise_artifact::partition::LABEL;

/// The column hashed by ordinal within its partition.
pub const SEGMENT_COLUMN: &str = reprise_artifact::partition::SEGMENT;

/// Each label's digest (hex blake3), or `None` when `path` is not a Parquet file with a
/// Utf8 `label` column or cannot be read (the file's own content hash still decides
/// freshness; partitions only explain it).
#[must_use]
pub fn label_digests(path: &Path) -> Option<BTreeMap<String, String>> {
    let file = File::open(path).ok()?;
    let file_len = file.metadata().ok()?.len();
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).ok()?;
    reprise_artifact::table::check_chunk_ranges(builder.metadata(), file_len).ok()?;
    let reader = builder.build().ok()?;
    let schema = reader.schema();
    let label_at = schema.index_of(PARTITION_COLUMN).ok()?;
    if schema.field(label_at).data_type() != &DataType::Utf8 {
        return None;
    }
    let segment_at = schema.index_of(SEGMENT_COLUMN).ok().filter(|&i| schema.field(i).data_type() == &DataType::Int64);
    let others: Vec<usize> = (0..schema.fields().len()).filter(|&i| i != label_at && Some(i) != segment_at).collect();
    let batches: Vec<RecordBatch> = reader.collect::<Result<_, _>>().ok()?;
    let label_of = |batch: &RecordBatch| batch.column(label_at).as_any().downcast_ref::<StringArray>().cloned();

    // Pass 1: each label's columns, those with a value in any of its rows. A ragged table
    // (another label with more components adds a `y<k>` column, null in this label's rows)
    // then leaves this label's digest alone.
    let mut columns: BTreeMap<String, Vec<bool>> = BTreeMap::new();
    for batch in &batches {
        let labels = label_of(batch)?;
        for r in 0..batch.num_rows() {
            if labels.is_null(r) {
                return None;
            }
            let used = columns.entry(labels.value(r).to_string()).or_insert_with(|| vec![false; others.len()]);
            for (k, &c) in others.iter().enumerate() {
                used[k] |= !batch.column(c).is_null(r);
            }
        }
    }
    // Pass 2: each label's shape (its columns' names and types), then, in file order, its
    // segment ordinals and rows over its columns in arrow's row format.
    let mut converters: BTreeMap<Vec<usize>, RowConverter> = BTreeMap::new();
    let mut hashers: BTreeMap<String, (Vec<usize>, blake3::Hasher)> = BTreeMap::new();
    for (label, used) in &columns {
        let own: Vec<usize> = others.iter().zip(used).filter(|(_, &u)| u).map(|(&c, _)| c).collect();
        let mut shape = blake3::Hasher::new();
        for &c in &own {
            shape.update(format!("{}:{:?};", schema.field(c).name(), schema.field(c).data_type()).as_bytes());
        }
        if !converters.contains_key(&own) {
            let fields = own.iter().map(|&c| SortField::new(schema.field(c).data_type().clone())).collect();
            converters.insert(own.clone(), RowConverter::new(fields).ok()?);
        }
        hashers.insert(label.clone(), (own, shape));
    }
    let mut ordinals: BTreeMap<String, Vec<i64>> = BTreeMap::new();
    for batch in &batches {
        let labels = label_of(batch)?;
        let segments = match segment_at {
            Some(i) => Some(batch.column(i).as_any().downcast_ref::<Int64Array>()?.clone()),
            None => None,
        };
        let mut rows_by_columns = BTreeMap::new();
        for r in 0..batch.num_rows() {
            let label = labels.value(r);
            let (own, hasher) = hashers.get_mut(label)?;
            if let Some(segments) = &segments {
                let seen = ordinals.entry(label.to_string()).or_default();
                let ordinal = reprise_artifact::partition::segment_ordinal(seen, segments.value(r));
                hasher.update(&(ordinal as u64).to_le_bytes());
            }
            if !rows_by_columns.contains_key(own) {
                let arrays: Vec<_> = own.iter().map(|&c| batch.column(c).clone()).collect();
                rows_by_columns.insert(own.clone(), converters.get(own)?.convert_columns(&arrays).ok()?);
            }
            let row = rows_by_columns.get(own)?.row(r);
            hasher.update(&(row.as_ref().len() as u64).to_le_bytes());
            hasher.update(row.as_ref());
        }
    }
    Some(hashers.into_iter().map(|(label, (_, h))| (label, h.finalize().to_hex().to_string())).collect())
}

/// How the partitions of an input differ between two runs.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Delta {
    /// Labels whose rows changed.
    pub changed: Vec<String>,
    /// Labels that are new.
    pub added: Vec<String>,
    /// Labels that are gone.
    pub removed: Vec<String>,
    /// How many labels are unchanged.
    pub unchanged: usize,
}

impl Delta {
    /// The difference from `old` to `new`.
    #[must_use]
    pub fn between(old: &BTreeMap<String, String>, new: &BTreeMap<String, String>) -> Self {
        let mut delta = Self::default();
        for (label, digest) in new {
            match old.get(label) {
                None => delta.added.push(label.clone()),
                Some(before) if before != digest => delta.changed.push(label.clone()),
                Some(_) => delta.unchanged += 1,
            }
        }
        delta.removed = old.keys().filter(|l| !new.contains_key(*l)).cloned().collect();
        delta
    }
}

impl std::fmt::Display for Delta {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let list = |labels: &[String]| labels.iter().map(|l| format!("`{l}`")).collect::<Vec<_>>().join(", ");
        let mut parts = Vec::new();
        for (labels, what) in [(&self.changed, "changed"), (&self.added, "added"), (&self.removed, "removed")] {
            if !labels.is_empty() {
                parts.push(format!("label {} {what}", list(labels)));
            }
        }
        if parts.is_empty() {
            parts.push("no label's rows changed".into());
        }
        write!(f, "{}; {} label(s) unchanged", parts.join(", "), self.unchanged)
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use arrow::array::{ArrayRef, Float64Array};
    use arrow::datatypes::{Field, Schema};
    use arrow::record_batch::RecordBatch;
    use parquet::arrow::ArrowWriter;

    use super::*;

    /// Writes rows `(segment_id, label, value)`.
    fn write(path: &Path, rows: &[(i64, &str, f64)]) {
        let schema = Arc::new(Schema::new(vec![
            Field::new("segment_id", DataType::Int64, false),
            Field::new("label", DataType::Utf8, false),
            Field::new("value", DataType::Float64, false),
        ]));
        let columns: Vec<ArrayRef> = vec![
            Arc::new(Int64Array::from(rows.iter().map(|r| r.0).collect::<Vec<_>>())),
            Arc::new(StringArray::from(rows.iter().map(|r| r.1).collect::<Vec<_>>())),
            Arc::new(Float64Array::from(rows.iter().map(|r| r.2).collect::<Vec<_>>())),
        ];
        let batch = RecordBatch::try_new(schema.clone(), columns).unwrap();
        let mut writer = ArrowWriter::try_new(File::create(path).unwrap(), schema, None).unwrap();
        writer.write(&batch).unwrap();
        writer.close().unwrap();
    }

    /// Changing one label's rows changes its digest only; another label gaining a segment
    /// renumbers the later labels' segment ids without changing their digests.
    #[test]
    fn one_labels_rows_change_only_its_digest() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.parquet"), dir.path().join("b.parquet"));
        write(&a, &[(0, "idle", 1.0), (0, "idle", 2.0), (1, "wave", 3.0), (2, "nod", 4.0), (2, "nod", 5.0)]);
        write(&b, &[(0, "idle", 1.0), (1, "idle", 2.5), (2, "wave", 3.0), (3, "nod", 4.0), (3, "nod", 5.0)]);
        let (old, new) = (label_digests(&a).unwrap(), label_digests(&b).unwrap());
        assert_eq!(old.len(), 3);
        let delta = Delta::between(&old, &new);
        assert_eq!(delta, Delta { changed: vec!["idle".into()], added: vec![], removed: vec![], unchanged: 2 });
        assert_eq!(delta.to_string(), "label `idle` changed; 2 label(s) unchanged");

        write(&b, &[(0, "idle", 1.0), (0, "idle", 2.0), (1, "wave", 3.0), (2, "wave", 3.0), (3, "run", 1.0)]);
        let delta = Delta::between(&old, &label_digests(&b).unwrap());
        assert_eq!(
            delta.to_string(),
            "label `wave` changed, label `run` added, label `nod` removed; 1 label(s) unchanged"
        );
    }

    /// A ragged table (`y<k>` columns null where a label has fewer): the widest label
    /// losing its last column changes its own digest only.
    #[test]
    fn a_ragged_column_belongs_to_the_labels_that_fill_it() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, y1: Option<Vec<Option<f64>>>| {
            let path = dir.path().join(name);
            let mut fields =
                vec![Field::new("label", DataType::Utf8, false), Field::new("y0", DataType::Float64, true)];
            let mut columns: Vec<ArrayRef> =
                vec![Arc::new(StringArray::from(vec!["wide", "narrow"])), Arc::new(Float64Array::from(vec![1.0, 2.0]))];
            if let Some(y1) = y1 {
                fields.push(Field::new("y1", DataType::Float64, true));
                columns.push(Arc::new(Float64Array::from(y1)));
            }
            let schema = Arc::new(Schema::new(fields));
            let batch = RecordBatch::try_new(schema.clone(), columns).unwrap();
            let mut writer = ArrowWriter::try_new(File::create(&path).unwrap(), schema, None).unwrap();
            writer.write(&batch).unwrap();
            writer.close().unwrap();
            label_digests(&path).unwrap()
        };
        let (before, after) = (write("a.parquet", Some(vec![Some(3.0), None])), write("b.parquet", None));
        assert_eq!(before["narrow"], after["narrow"]);
        assert_ne!(before["wide"], after["wide"]);
    }

    #[test]
    fn files_without_labels_have_no_partitions() {
        let dir = tempfile::tempdir().unwrap();
        let text = dir.path().join("labels.toml");
        std::fs::write(&text, "[[rule]]\n").unwrap();
        assert_eq!(label_digests(&text), None);
        assert_eq!(label_digests(&dir.path().join("missing.parquet")), None);
    }
}
