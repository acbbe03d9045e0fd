//! Label partitions of an artifact: the rows of one label (or of one ordered pair of
//! labels), written by one partition run of a stage, and their merge into the artifact
//! later stages read.
//!
//! A partitioned stage (declared in its `Wiring`, run by the runner with `--partition`)
//! writes, for each label, a table holding only that label's rows. [`merge`] concatenates
//! those tables in the labels' order into one file that is, row for row, what the stage
//! would have written for all labels at once:
//!
//! - every part must be a reprise artifact of one kind, schema version, stage, stage
//!   version, parameters and extra metadata (anything else is refused, naming the part);
//! - its `label` column must hold only the part's label (for a pair, its `from` label in
//!   `label_from`, or in `label` when the kind has no pair columns);
//! - `segment_id`s are renumbered: ids are numbered across labels, so a part written
//!   before another label gained a segment carries stale ids. A part's k-th distinct
//!   segment of a label becomes that label's k-th segment in the current labeled frames;
//! - the provenance's inputs are the current input files (a cached part recorded the files
//!   it was run on, whose other labels may since have changed), and the content hash is
//!   recomputed.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use arrow::array::{ArrayRef, Int64Array};
use arrow::datatypes::{FieldRef, Schema};
use arrow::record_batch::RecordBatch;

use crate::error::{ArtifactError, Result};
use crate::provenance::{InputRef, KEY_CONTENT, KEY_INPUTS};
use crate::table::{self, Table};

/// The column naming a row's label.
pub const LABEL: &str = "label";
/// The column numbering segments across labels.
pub const SEGMENT: &str = "segment_id";

/// The ordinal of segment `id` among the segments `seen` so far (in order of first
/// appearance), adding it if new: how a label's segments are numbered within the label,
/// since `segment_id`s are numbered across labels.
pub fn segment_ordinal(seen: &mut Vec<i64>, id: i64) -> usize {
    seen.iter().position(|&s| s == id).unwrap_or_else(|| {
        seen.push(id);
        seen.len() - 1
    })
}

/// One label of a table: its segment ids in order of first appearance, and its rows.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LabelRows {
    /// The label.
    pub label: String,
    /// Its `segment_id`s, in the order they first appear (empty without the column).
    pub segments: Vec<i64>,
    /// How many rows it has.
    pub rows: usize,
}

/// Each label of `path` (a table with a Utf8 `label` column and, optionally, an Int64
/// `segment_id`), in the order the labels first appear.
pub fn labels_in_order(path: &Path) -> Result<Vec<LabelRows>> {
    let table = Table::read_any(path)?;
    let labels = table.strings(LABEL)?;
    let segments = if table.column_names().iter().any(|c| c == SEGMENT) { Some(table.i64(SEGMENT)?) } else { None };
    let mut order: Vec<LabelRows> = Vec::new();
    let mut at: BTreeMap<&str, usize> = BTreeMap::new();
    for (r, label) in labels.iter().enumerate() {
        let i = *at.entry(label).or_insert_with(|| {
            order.push(LabelRows { label: label.clone(), segments: Vec::new(), rows: 0 });
            order.len() - 1
        });
        order[i].rows += 1;
        if let Some(segments) = &segments {
            segment_ordinal(&mut order[i].segments, segments[r]);
        }
    }
    Ok(order)
}

/// One part to merge: the file a partition run wrote and the labels its rows must carry.
#[derive(Debug, Clone)]
pub struct Part<'a> {
    /// The partition's file.
    pub path: &'a Path,
    /// The label every row's `label` column must hold, or for a pair its `from` column.
    pub label: &'a str,
    /// For a pair's part, the label every row's `to` column must hold.
    pub to: Option<&'a str>,
}

/// The columns naming a pair's two labels.
pub const PAIR: [&str; 2] = ["from", "to"];

/// Concatenates `parts` (in that order) into `out`, atomically. `inputs` is the
/// provenance's input record of the merged file; `segments` each label's current segment
/// ids ([`labels_in_order`]), used when the parts carry a `segment_id` column.
pub fn merge(
    parts: &[Part<'_>],
    out: &Path,
    inputs: &BTreeMap<String, InputRef>,
    segments: &BTreeMap<String, Vec<i64>>,
) -> Result<()> {
    let Some(first) = parts.first() else {
        return Err(ArtifactError::Invalid { path: out.into(), message: "no partitions to merge".into() });
    };
    let tables = parts.iter().map(|p| Table::read_any(p.path)).collect::<Result<Vec<_>>>()?;
    let shared = shared_metadata(tables[0].metadata());
    for table in &tables[1..] {
        let own = shared_metadata(table.metadata());
        let differs = |k: &&String| own.get(*k) != shared.get(*k);
        if let Some(key) = own.keys().chain(shared.keys()).find(differs) {
            return Err(table.invalid(format!(
                "its metadata `{key}` differs from the partition `{}`'s; the partitions come from different runs",
                first.path.display()
            )));
        }
    }
    let schema = Arc::new(Schema::new(union_fields(&tables)?));
    let mut batches = Vec::with_capacity(tables.len());
    for (table, part) in tables.iter().zip(parts) {
        let columns = match part.to {
            None => renumber(table, part.label, segments)?,
            Some(to) => pair_rows(table, part.label, to)?,
        };
        let columns = widen(table, columns, &schema)?;
        batches.push(RecordBatch::try_new(schema.clone(), columns).map_err(|e| ArtifactError::parquet(out, e))?);
    }
    let batch = arrow::compute::concat_batches(&schema, &batches).map_err(|e| ArtifactError::parquet(out, e))?;
    let mut metadata: Vec<(String, String)> = shared.into_iter().collect();
    metadata.push((KEY_INPUTS.into(), serde_json::to_string(inputs).expect("string map serialises")));
    table::write_batch(out, &batch, metadata)
}

/// The columns of the merged table: every part's, in the order first seen. A ragged kind
/// (a label with fewer components writes fewer `y<k>` columns) has nullable extra columns.
fn union_fields(tables: &[Table]) -> Result<Vec<FieldRef>> {
    let mut fields: Vec<FieldRef> = Vec::new();
    for table in tables {
        for field in table.batch().schema().fields() {
            match fields.iter().find(|f| f.name() == field.name()) {
                Some(f) if f.data_type() != field.data_type() => {
                    return Err(table.invalid(format!(
                        "column `{}` is {}, another partition's is {}",
                        field.name(),
                        field.data_type(),
                        f.data_type()
                    )));
                }
                Some(_) => {}
                None => fields.push(field.clone()),
            }
        }
    }
    Ok(fields)
}

/// `columns` (of `table`) laid out as `schema`: a column the part lacks is all null, if
/// the schema allows nulls there.
fn widen(table: &Table, columns: Vec<ArrayRef>, schema: &Schema) -> Result<Vec<ArrayRef>> {
    let own = table.batch().schema();
    schema
        .fields()
        .iter()
        .map(|field| match own.index_of(field.name()) {
            Ok(i) => Ok(columns[i].clone()),
            Err(_) if field.is_nullable() => Ok(arrow::array::new_null_array(field.data_type(), table.rows())),
            Err(_) => Err(table.invalid(format!("no column `{}`, which another partition has", field.name()))),
        })
        .collect()
}

/// `table`'s columns after checking every row is of the pair `from → to`.
fn pair_rows(table: &Table, from: &str, to: &str) -> Result<Vec<ArrayRef>> {
    for (column, label) in PAIR.iter().zip([from, to]) {
        if let Some(row) = table.strings(column)?.iter().position(|l| l != label) {
            return Err(table.invalid(format!("row {row}: `{column}` is not `{label}`, the partition's")));
        }
    }
    Ok(table.batch().columns().to_vec())
}

/// The metadata every part of one run shares: all but the content hash, the inputs and
/// the Arrow schema the Parquet writer embeds (the columns are compared as such).
fn shared_metadata(meta: &BTreeMap<String, String>) -> BTreeMap<String, String> {
    const ARROW_SCHEMA: &str = "ARROW:schema";
    meta.iter()
        .filter(|(k, _)| ![KEY_CONTENT, KEY_INPUTS, ARROW_SCHEMA].contains(&k.as_str()))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect()
}

/// `table`'s batch after checking every row is of `label`, with its segment ids mapped to
/// the label's current ones by ordinal.
fn renumber(table: &Table, label: &str, segments: &BTreeMap<String, Vec<i64>>) -> Result<Vec<ArrayRef>> {
    let batch = table.batch();
    if let Some(row) = table.strings(LABEL)?.iter().position(|l| l != label) {
        return Err(table.invalid(format!("row {row}: label is not `{label}`, the partition's")));
    }
    let Ok(at) = batch.schema().index_of(SEGMENT) else { return Ok(batch.columns().to_vec()) };
    let current = segments.get(label).map_or(&[][..], Vec::as_slice);
    let old = table.i64(SEGMENT)?;
    let mut seen: Vec<i64> = Vec::new();
    let mut ids = Vec::with_capacity(old.len());
    for (row, &id) in old.iter().enumerate() {
        let ordinal = segment_ordinal(&mut seen, id);
        let Some(&now) = current.get(ordinal) else {
            return Err(table.invalid(format!(
                "row {row}: label `{label}` has {} segment(s) in the current labeled frames, this partition more; \
                 rerun the stage with --force",
                current.len()
            )));
        };
        ids.push(now);
    }
    if seen.len() != current.len() {
        return Err(table.invalid(format!(
            "label `{label}` has {} segment(s) in the current labeled frames, this partition {}: a part must hold \
             every segment of its label, in order; rerun the stage with --force",
            current.len(),
            seen.len()
        )));
    }
    let mut columns: Vec<ArrayRef> = batch.columns().to_vec();
    columns[at] = Arc::new(Int64Array::from(ids));
    Ok(columns)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::provenance::Provenance;
    use crate::table::{Columns, Kind};

    const KIND: Kind = Kind { name: "part-test", version: 1 };

    fn write(path: &Path, label: &str, segments: &[i64], values: &[f64], params: serde_json::Value) {
        let cols = Columns::new()
            .str("label", &vec![label.to_string(); segments.len()])
            .i64("segment_id", segments.to_vec())
            .f64("v", values.to_vec());
        table::write(path, KIND, cols, &Provenance::new("s", "1", params), &[]).unwrap();
    }

    fn inputs() -> BTreeMap<String, InputRef> {
        BTreeMap::from([("x".into(), InputRef { path: "x.parquet".into(), blake3: "abc".into() })])
    }

    /// Two parts merge in the given order, their segment ids mapped by ordinal to the
    /// current ones; the merged file reads back with the given inputs as provenance.
    #[test]
    fn parts_concatenate_with_current_segment_ids() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b, out) = (dir.path().join("a.parquet"), dir.path().join("b.parquet"), dir.path().join("m.parquet"));
        write(&a, "walk", &[0, 0, 1], &[1.0, 2.0, 3.0], serde_json::json!({"q": 3}));
        write(&b, "run", &[7, 9, 9], &[4.0, 5.0, 6.0], serde_json::json!({"q": 3}));
        let segments = BTreeMap::from([("walk".to_string(), vec![4, 5]), ("run".to_string(), vec![0, 2])]);
        let parts = [Part { path: &b, label: "run", to: None }, Part { path: &a, label: "walk", to: None }];
        merge(&parts, &out, &inputs(), &segments).unwrap();
        let t = Table::read(&out, KIND).unwrap();
        assert_eq!(t.strings("label").unwrap(), ["run", "run", "run", "walk", "walk", "walk"]);
        assert_eq!(t.i64("segment_id").unwrap(), [0, 2, 2, 4, 4, 5]);
        assert_eq!(t.f64("v").unwrap(), [4.0, 5.0, 6.0, 1.0, 2.0, 3.0]);
        let prov = t.provenance().unwrap();
        assert_eq!(prov.inputs, inputs());
        assert_eq!(prov.params, serde_json::json!({"q": 3}));
    }

    /// Parts of different runs (parameters), a row of another label, and a part with more
    /// segments than the label now has are refused naming the part.
    #[test]
    fn parts_that_do_not_belong_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b, out) = (dir.path().join("a.parquet"), dir.path().join("b.parquet"), dir.path().join("m.parquet"));
        let segments = BTreeMap::from([("walk".to_string(), vec![0]), ("run".to_string(), vec![1])]);
        write(&a, "walk", &[0], &[1.0], serde_json::json!({"q": 3}));
        write(&b, "run", &[1], &[1.0], serde_json::json!({"q": 4}));
        let e = merge(
            &[Part { path: &a, label: "walk", to: None }, Part { path: &b, label: "run", to: None }],
            &out,
            &inputs(),
            &segments,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("b.parquet") && e.contains("reprise.params"), "{e}");
        // A metadata key only one part has, whichever part comes first.
        let cols = Columns::new().str("label", &["run"]).i64("segment_id", vec![1]).f64("v", vec![1.0]);
        let extra = [("reprise.extra".to_string(), "1".to_string())];
        table::write(&b, KIND, cols, &Provenance::new("s", "1", serde_json::json!({"q": 3})), &extra).unwrap();
        for parts in [[("a", &a, "walk"), ("b", &b, "run")], [("b", &b, "run"), ("a", &a, "walk")]] {
            let parts: Vec<Part<'_>> = parts.iter().map(|(_, p, l)| Part { path: p, label: l, to: None }).collect();
            let e = merge(&parts, &out, &inputs(), &segments).unwrap_err().to_string();
            assert!(e.contains("`reprise.extra` differs"), "{e}");
        }
        let e =
            merge(&[Part { path: &a, label: "run", to: None }], &out, &inputs(), &segments).unwrap_err().to_string();
        assert!(e.contains("a.parquet: row 0: label is not `run`"), "{e}");
        write(&a, "walk", &[0, 3], &[1.0, 2.0], serde_json::json!({"q": 3}));
        let e =
            merge(&[Part { path: &a, label: "walk", to: None }], &out, &inputs(), &segments).unwrap_err().to_string();
        assert!(e.contains("row 1: label `walk` has 1 segment(s)"), "{e}");
        assert!(!out.exists(), "nothing written");
    }

    /// A part with fewer (nullable) columns is widened with nulls, as one writer of the
    /// ragged table would have; a column of another type is refused.
    #[test]
    fn ragged_parts_are_widened() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b, out) = (dir.path().join("a.parquet"), dir.path().join("b.parquet"), dir.path().join("m.parquet"));
        let prov = Provenance::new("s", "1", serde_json::json!({}));
        let cols = |label: &str, width: usize| {
            (0..width).fold(Columns::new().str("label", &[label]), |c, k| c.f64_opt(&format!("y{k}"), vec![Some(1.0)]))
        };
        table::write(&a, KIND, cols("a", 1), &prov, &[]).unwrap();
        table::write(&b, KIND, cols("b", 2), &prov, &[]).unwrap();
        let segments = BTreeMap::new();
        merge(
            &[Part { path: &a, label: "a", to: None }, Part { path: &b, label: "b", to: None }],
            &out,
            &inputs(),
            &segments,
        )
        .unwrap();
        let t = Table::read(&out, KIND).unwrap();
        assert_eq!(t.column_names(), ["label", "y0", "y1"]);
        assert_eq!(t.f64_opt("y1").unwrap(), [None, Some(1.0)]);
        table::write(&b, KIND, Columns::new().str("label", &["b"]).str("y0", &["x"]), &prov, &[]).unwrap();
        let e = merge(
            &[Part { path: &a, label: "a", to: None }, Part { path: &b, label: "b", to: None }],
            &out,
            &inputs(),
            &segments,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("b.parquet: column `y0` is Utf8, another partition's is Float64"), "{e}");
    }

    /// A pair's part must hold only that pair's rows; an empty part (no bridge) merges.
    #[test]
    fn pair_parts_hold_their_pair() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b, out) = (dir.path().join("a.parquet"), dir.path().join("b.parquet"), dir.path().join("m.parquet"));
        let prov = Provenance::new("s", "1", serde_json::json!({}));
        let pair = |from: &[&str], to: &[&str]| Columns::new().str("from", from).str("to", to);
        table::write(&a, KIND, pair(&["x", "x"], &["y", "y"]), &prov, &[]).unwrap();
        table::write(&b, KIND, pair(&[], &[]), &prov, &[]).unwrap();
        let parts = [Part { path: &a, label: "x", to: Some("y") }, Part { path: &b, label: "y", to: Some("x") }];
        merge(&parts, &out, &inputs(), &BTreeMap::new()).unwrap();
        assert_eq!(Table::read(&out, KIND).unwrap().strings("to").unwrap(), ["y", "y"]);
        let e = merge(&[Part { path: &a, label: "x", to: Some("z") }], &out, &inputs(), &BTreeMap::new())
            .unwrap_err()
            .to_string();
        assert!(e.contains("a.parquet: row 0: `to` is not `z`"), "{e}");
    }

    /// Labels and their segments in order of first appearance.
    #[test]
    fn labels_in_first_appearance_order() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("l.parquet");
        let cols = Columns::new().str("label", &["b", "a", "b", "a"]).i64("segment_id", vec![3, 1, 4, 1]);
        table::write(&path, KIND, cols, &Provenance::new("s", "1", serde_json::json!({})), &[]).unwrap();
        let rows = |label: &str, segments: Vec<i64>, rows| LabelRows { label: label.into(), segments, rows };
        assert_eq!(labels_in_order(&path).unwrap(), vec![rows("b", vec![3, 4], 2), rows("a", vec![1], 2)]);
    }
}
