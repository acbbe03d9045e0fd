//! `reprise inspect FILE`: a summary of any Parquet artifact — size, rows, row groups, the
//! Arrow schema, the key-value metadata where stages record provenance (`reprise.stage`,
//! `reprise.params`, `reprise.inputs`, …; JSON values pretty-printed), and the first rows.

use std::fmt::Write as _;
use std::fs::File;
use std::path::Path;

use arrow::record_batch::RecordBatch;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::ProjectionMask;

use crate::cli::InspectArgs;
use crate::error::{Error, Result};

/// Above this many columns the schema lists only [`SCHEMA_HEAD`] of them.
const WIDE: usize = 40;
/// How many columns a wide schema lists.
const SCHEMA_HEAD: usize = 20;
/// How many columns the rows show when `--columns` is not given.
const ROW_COLUMNS: usize = 8;
/// The Arrow schema parquet writers embed in the metadata (base64): not worth printing.
const ARROW_SCHEMA_KEY: &str = "ARROW:schema";

/// Renders the summary of `args.file`.
pub fn inspect(args: &InspectArgs) -> Result<String> {
    let path = args.file.as_path();
    let file = File::open(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    let size = file.metadata().map_err(|source| Error::Io { path: path.to_path_buf(), source })?.len();
    if size == 0 || file.metadata().is_ok_and(|m| m.is_dir()) {
        return Err(Error::NotParquet { path: path.to_path_buf(), message: "empty file or a directory".into() });
    }
    let builder = ParquetRecordBatchReaderBuilder::try_new(file)
        .map_err(|e| Error::NotParquet { path: path.to_path_buf(), message: e.to_string() })?;
    reprise_artifact::table::check_chunk_ranges(builder.metadata(), size)
        .map_err(|message| Error::NotParquet { path: path.to_path_buf(), message })?;
    let schema = builder.schema().clone();
    let meta = builder.metadata().clone();
    let names: Vec<&str> = schema.fields().iter().map(|f| f.name().as_str()).collect();

    let chosen: Vec<usize> = if args.columns.is_empty() {
        Vec::new()
    } else {
        args.columns
            .iter()
            .map(|c| {
                names.iter().position(|n| n == c).ok_or_else(|| Error::InspectColumn {
                    path: path.to_path_buf(),
                    column: c.clone(),
                    available: preview_list(&names),
                })
            })
            .collect::<Result<_>>()?
    };

    let mut out = String::new();
    let _ = writeln!(out, "file:       {}", path.display());
    let _ = writeln!(out, "size:       {} ({size} bytes)", human_size(size));
    let _ = writeln!(out, "rows:       {}", meta.file_metadata().num_rows());
    let _ = writeln!(out, "row groups: {}", meta.num_row_groups());
    let _ = writeln!(out, "columns:    {}", names.len());

    let listed: Vec<usize> = if !chosen.is_empty() {
        chosen.clone()
    } else if names.len() > WIDE {
        (0..SCHEMA_HEAD).collect()
    } else {
        (0..names.len()).collect()
    };
    let width = listed.iter().map(|&i| names[i].len()).max().unwrap_or(0);
    let _ = writeln!(out, "schema:");
    for &i in &listed {
        let field = schema.field(i);
        let nullable = if field.is_nullable() { "" } else { " (not null)" };
        let _ = writeln!(out, "  {:<width$}  {}{nullable}", field.name(), field.data_type());
    }
    if listed.len() < names.len() {
        let _ = writeln!(out, "  … and {} more columns (choose with --columns a,b,c)", names.len() - listed.len());
    }

    let _ = writeln!(out, "metadata:");
    match meta.file_metadata().key_value_metadata().filter(|kv| !kv.is_empty()) {
        None => {
            let _ = writeln!(out, "  (none)");
        }
        Some(pairs) => {
            for kv in pairs {
                let value = kv.value.as_deref().unwrap_or("");
                if kv.key == ARROW_SCHEMA_KEY {
                    let _ = writeln!(out, "  {}: ({} bytes: the embedded Arrow schema)", kv.key, value.len());
                } else {
                    let _ = writeln!(out, "  {}: {}", kv.key, pretty_value(value));
                }
            }
        }
    }

    if args.head > 0 {
        let shown: Vec<usize> =
            if chosen.is_empty() { (0..names.len().min(ROW_COLUMNS)).collect() } else { chosen.clone() };
        let batches = head(path, builder, &shown, args.head)?;
        let rows: usize = batches.iter().map(RecordBatch::num_rows).sum();
        let more = if shown.len() < names.len() {
            format!(", {} of {} columns", shown.len(), names.len())
        } else {
            String::new()
        };
        let _ = writeln!(out, "first {rows} rows{more}:");
        let table = arrow::util::pretty::pretty_format_batches(&batches)
            .map_err(|e| Error::InspectRows { path: path.to_path_buf(), message: e.to_string() })?;
        let _ = writeln!(out, "{table}");
    }
    Ok(out)
}

/// Reads the first `n` rows of the columns `shown` (in that order).
fn head(
    path: &Path,
    builder: ParquetRecordBatchReaderBuilder<File>,
    shown: &[usize],
    n: usize,
) -> Result<Vec<RecordBatch>> {
    let fail = |message: String| Error::InspectRows { path: path.to_path_buf(), message };
    let mask = ProjectionMask::roots(builder.parquet_schema(), shown.iter().copied());
    let reader = builder
        .with_projection(mask)
        .with_limit(n)
        .with_batch_size(n.min(8192))
        .build()
        .map_err(|e| fail(e.to_string()))?;
    // The projection yields columns in file order; put them in the order asked for.
    let mut sorted = shown.to_vec();
    sorted.sort_unstable();
    let order: Vec<usize> = shown.iter().map(|c| sorted.iter().position(|s| s == c).unwrap_or(0)).collect();
    reader
        .map(|batch| {
            batch.map_err(|e| fail(e.to_string())).and_then(|b| b.project(&order).map_err(|e| fail(e.to_string())))
        })
        .collect()
}

/// A JSON object or array pretty-printed (indented under its key); anything else as is.
fn pretty_value(value: &str) -> String {
    match serde_json::from_str::<serde_json::Value>(value) {
        Ok(json @ (serde_json::Value::Object(_) | serde_json::Value::Array(_))) => {
            serde_json::to_string_pretty(&json).unwrap_or_else(|_| value.into()).replace('\n', "\n  ")
        }
        _ => value.into(),
    }
}

fn human_size(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    #[allow(clippy::cast_precision_loss, reason = "a display approximation")]
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit < UNITS.len() - 1 {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else {
        format!("{value:.1} {}", UNITS[unit])
    }
}

fn preview_list(names: &[&str]) -> String {
    let shown: Vec<String> = names.iter().take(SCHEMA_HEAD).map(|n| format!("`{n}`")).collect();
    if names.len() > SCHEMA_HEAD {
        format!("{}, … {} more", shown.join(", "), names.len() - SCHEMA_HEAD)
    } else {
        shown.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;
    use std::sync::Arc;

    use arrow::array::{ArrayRef, Float64Array, Int64Array, StringArray};
    use arrow::datatypes::{DataType, Field, Schema};
    use parquet::arrow::ArrowWriter;
    use parquet::file::metadata::KeyValue;
    use parquet::file::properties::WriterProperties;

    use super::*;

    fn write(path: &Path, columns: usize, rows: usize, metadata: Vec<KeyValue>) {
        let mut fields = vec![Field::new("clip", DataType::Utf8, false), Field::new("frame", DataType::Int64, false)];
        let mut arrays: Vec<ArrayRef> = vec![
            Arc::new(StringArray::from_iter_values((0..rows).map(|r| format!("take{}", r / 3)))),
            Arc::new(Int64Array::from_iter_values((0..rows).map(|r| i64::try_from(r).unwrap()))),
        ];
        for c in 2..columns {
            fields.push(Field::new(format!("ctrl_{c:03}"), DataType::Float64, true));
            #[allow(clippy::cast_precision_loss)]
            arrays.push(Arc::new(Float64Array::from_iter_values((0..rows).map(|r| r as f64 + c as f64 / 1000.0))));
        }
        let schema = Arc::new(Schema::new_with_metadata(fields, HashMap::new()));
        let batch = RecordBatch::try_new(schema.clone(), arrays).unwrap();
        let props = WriterProperties::builder().set_key_value_metadata(Some(metadata)).build();
        let mut writer = ArrowWriter::try_new(File::create(path).unwrap(), schema, Some(props)).unwrap();
        writer.write(&batch).unwrap();
        writer.close().unwrap();
    }

    fn args(file: &Path, head: usize, columns: &[&str]) -> InspectArgs {
        InspectArgs { file: file.to_path_buf(), head, columns: columns.iter().map(ToString::to_string).collect() }
    }

    #[test]
    fn summarises_a_narrow_table_with_provenance() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frames.parquet");
        let kv = |k: &str, v: &str| KeyValue { key: k.into(), value: Some(v.into()) };
        write(
            &path,
            4,
            10,
            vec![kv("reprise.stage", "ingest"), kv("reprise.params", r#"{"seed":7,"source":"dragon-face"}"#)],
        );
        let text = inspect(&args(&path, 3, &[])).unwrap();
        assert!(text.contains("rows:       10\n"), "{text}");
        assert!(text.contains("row groups: 1\n"), "{text}");
        assert!(
            text.contains("  clip      Utf8 (not null)\n  frame     Int64 (not null)\n  ctrl_002  Float64\n"),
            "{text}"
        );
        assert!(text.contains("  reprise.stage: ingest\n"), "{text}");
        assert!(
            text.contains("  reprise.params: {\n    \"seed\": 7,\n    \"source\": \"dragon-face\"\n  }\n"),
            "{text}"
        );
        assert!(text.contains("first 3 rows:\n"), "{text}");
        assert!(text.contains("| take0 | 2     |"), "{text}");
        assert!(!text.contains("| take1"), "only three rows: {text}");
    }

    #[test]
    fn wide_tables_are_abbreviated_and_columns_can_be_chosen() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("wide.parquet");
        write(&path, 50, 4, Vec::new());
        let text = inspect(&args(&path, 2, &[])).unwrap();
        assert!(text.contains("ctrl_019") && !text.contains("ctrl_020"), "{text}");
        assert!(text.contains("… and 30 more columns (choose with --columns a,b,c)"), "{text}");
        assert!(text.contains("first 2 rows, 8 of 50 columns:"), "{text}");
        let text = inspect(&args(&path, 1, &["ctrl_042", "clip"])).unwrap();
        assert!(text.contains("schema:\n  ctrl_042  Float64\n  clip      Utf8 (not null)\n  … and 48 more"), "{text}");
        let header = text.lines().find(|l| l.contains("ctrl_042") && l.starts_with('|')).unwrap();
        assert!(header.find("ctrl_042").unwrap() < header.find("clip").unwrap(), "asked order: {header}");
        let err = inspect(&args(&path, 1, &["nope"])).unwrap_err();
        assert!(err.to_string().contains("has no column `nope`"), "{err}");
    }

    #[test]
    fn non_parquet_and_missing_files() {
        let dir = tempfile::tempdir().unwrap();
        let text_file = dir.path().join("labels.toml");
        std::fs::write(&text_file, "not parquet at all").unwrap();
        let err = inspect(&args(&text_file, 5, &[])).unwrap_err();
        assert!(err.to_string().starts_with(&format!("`{}` is not a Parquet file", text_file.display())), "{err}");
        assert_eq!(err.code(), reprise_stagekit::exit::INPUT);
        let missing = dir.path().join("nope.parquet");
        let err = inspect(&args(&missing, 5, &[])).unwrap_err();
        assert!(err.to_string().contains("nope.parquet"), "{err}");
        assert_eq!(err.code(), reprise_stagekit::exit::INPUT);
    }
}
