//! Parquet I/O shared by every artifact kind: atomic writes with provenance, and
//! checked reads that fail naming the file and column.

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow::array::{Array, ArrayRef, BooleanArray, Float64Array, Int64Array, RecordBatch, StringArray};
use arrow::datatypes::{DataType, Field, Schema};

use crate::error::{ArtifactError, Result};
use crate::provenance::{Provenance, KEY_KIND, KEY_SCHEMA_VERSION};

/// An artifact kind: its name (stored under `reprise.schema`) and schema version.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Kind {
    /// Name, e.g. `frames`.
    pub name: &'static str,
    /// Bumped whenever a column is added, removed, renamed or changes meaning.
    pub version: u32,
}

/// Builds the columns of a table to write.
#[derive(Default)]
pub struct Columns {
    fields: Vec<Field>,
    arrays: Vec<ArrayRef>,
    /// Per column: whether its values must be finite (Float64 columns but those of
    /// [`Columns::f64_any`]).
    finite: Vec<bool>,
}

impl Columns {
    /// An empty column list.
    pub fn new() -> Self {
        Self::default()
    }
    /// Appends a non-null Float64 column whose every value must be finite: a NaN or an
    /// infinity is refused when the table is written, naming the column and row, so that
    /// no artifact (and no cache entry) ever holds one.
    pub fn f64(mut self, name: &str, values: Vec<f64>) -> Self {
        self.push(name, DataType::Float64, Arc::new(Float64Array::from(values)), true);
        self
    }
    /// Appends a non-null Float64 column whose values may be infinite or NaN, for columns
    /// whose meaning includes them (read with [`Table::f64_any`]).
    pub fn f64_any(mut self, name: &str, values: Vec<f64>) -> Self {
        self.push(name, DataType::Float64, Arc::new(Float64Array::from(values)), false);
        self
    }
    /// Appends a non-null Int64 column.
    pub fn i64(mut self, name: &str, values: Vec<i64>) -> Self {
        self.push(name, DataType::Int64, Arc::new(Int64Array::from(values)), false);
        self
    }
    /// Appends a non-null Utf8 column.
    pub fn str<S: AsRef<str>>(mut self, name: &str, values: &[S]) -> Self {
        let array = StringArray::from_iter_values(values.iter().map(AsRef::as_ref));
        self.push(name, DataType::Utf8, Arc::new(array), false);
        self
    }
    /// Appends a non-null Boolean column.
    pub fn bool(mut self, name: &str, values: Vec<bool>) -> Self {
        self.push(name, DataType::Boolean, Arc::new(BooleanArray::from(values)), false);
        self
    }
    /// Appends a nullable Float64 column (None = null; the values present must be finite).
    pub fn f64_opt(mut self, name: &str, values: Vec<Option<f64>>) -> Self {
        self.fields.push(Field::new(name, DataType::Float64, true));
        self.arrays.push(Arc::new(Float64Array::from(values)));
        self.finite.push(true);
        self
    }
    fn push(&mut self, name: &str, dtype: DataType, array: ArrayRef, finite: bool) {
        self.fields.push(Field::new(name, dtype, false));
        self.arrays.push(array);
        self.finite.push(finite);
    }
    /// The first value that must be finite and is not, as (column, row, value).
    fn first_non_finite(&self) -> Option<(&str, usize, f64)> {
        self.fields.iter().zip(&self.arrays).zip(&self.finite).filter(|(_, f)| **f).find_map(|((field, array), _)| {
            let a = array.as_any().downcast_ref::<Float64Array>()?;
            let row = (0..a.len()).find(|&i| !a.is_null(i) && !a.value(i).is_finite())?;
            Some((field.name().as_str(), row, a.value(row)))
        })
    }
    /// The columns as one Arrow batch, whose first row is row `first_row` of the table at
    /// `path`: an error naming `path` if their lengths differ, or naming the column and row
    /// of a value that must be finite and is not.
    pub(crate) fn into_batch(self, path: &Path, first_row: usize) -> Result<RecordBatch> {
        if let Some((column, row, value)) = self.first_non_finite() {
            return Err(ArtifactError::NotFinite {
                path: path.into(),
                column: column.into(),
                row: first_row + row,
                value,
            });
        }
        RecordBatch::try_new(Arc::new(Schema::new(self.fields)), self.arrays)
            .map_err(|e| ArtifactError::parquet(path, e))
    }
}

/// Writes `columns` as a Parquet artifact of `kind`, atomically: the data goes to a
/// temporary file beside `path` which is renamed over `path` only once complete, so a
/// crash or error never leaves a half-written artifact and never harms the old one.
/// `extra` adds kind-specific metadata keys (e.g. the rig of a controls table).
pub fn write(
    path: &Path,
    kind: Kind,
    columns: Columns,
    provenance: &Provenance,
    extra: &[(String, String)],
) -> Result<()> {
    crate::stream::TableWriter::create(path, kind, columns, provenance, extra)?.finish()
}

/// Writes `batch` atomically with the key-value `metadata` (kind, schema version,
/// provenance, extra keys) and the batch's content hash (computed here, replacing any
/// [`crate::provenance::KEY_CONTENT`] in `metadata`).
pub(crate) fn write_batch(path: &Path, batch: &RecordBatch, metadata: Vec<(String, String)>) -> Result<()> {
    let mut w = crate::stream::TableWriter::with_metadata(path, batch.schema(), metadata)?;
    w.write_batch(batch)?;
    w.finish()
}

/// Runs `fill` on a temporary file in `path`'s directory, then renames it to `path`.
/// On any error the temporary file is removed and `path` is untouched. After
/// [`defer_commits`] the rename waits for [`commit_pending`].
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut File) -> Result<()>) -> Result<()> {
    let tmp = begin_atomic(path)?;
    let result = (|| {
        let mut file = File::create(&tmp).map_err(|e| ArtifactError::io(&tmp, e))?;
        fill(&mut file)?;
        file.sync_all().map_err(|e| ArtifactError::io(&tmp, e))?;
        commit_atomic(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Creates `path`'s directory and returns the temporary file to fill for it.
pub(crate) fn begin_atomic(path: &Path) -> Result<PathBuf> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| ArtifactError::io(dir, e))?;
    Ok(temp_path(path))
}

/// Renames the complete temporary file `tmp` to `path`, or records it as pending after
/// [`defer_commits`]. On error `tmp` is removed.
pub(crate) fn commit_atomic(tmp: &Path, path: &Path) -> Result<()> {
    let mut pending = PENDING.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let result = match pending.as_mut() {
        Some(list) => {
            list.retain(|(_, p)| p != path);
            list.push((tmp.to_path_buf(), path.to_path_buf()));
            Ok(())
        }
        None => std::fs::rename(tmp, path).map_err(|e| ArtifactError::io(path, e)),
    };
    if result.is_err() {
        let _ = std::fs::remove_file(tmp);
    }
    result
}

/// The temporary name [`write_atomic`] uses for `path` in this process:
/// `.<name>.<pid>.tmp` beside it (the runner removes such files left by a dead stage).
pub fn temp_path(path: &Path) -> PathBuf {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    dir.join(format!(".{name}.{}.tmp", std::process::id()))
}

/// Files written but not yet renamed into place: `(temporary, final)`. `None` until
/// [`defer_commits`].
static PENDING: std::sync::Mutex<Option<Vec<(PathBuf, PathBuf)>>> = std::sync::Mutex::new(None);

/// From now on, [`write_atomic`] leaves each file under its temporary name until
/// [`commit_pending`], so a stage's outputs are replaced together or not at all. Reads
/// of a pending path in this process ([`Table::read_any`], [`crate::provenance::hash_file`])
/// see the pending content.
pub fn defer_commits() {
    let mut pending = PENDING.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    pending.get_or_insert_with(Vec::new);
}

/// Renames every pending file into place, in the order written.
pub fn commit_pending() -> Result<()> {
    let list = PENDING.lock().unwrap_or_else(std::sync::PoisonError::into_inner).as_mut().map(std::mem::take);
    let list = list.unwrap_or_default();
    for (i, (tmp, path)) in list.iter().enumerate() {
        if let Err(e) = std::fs::rename(tmp, path) {
            for (rest, _) in &list[i..] {
                let _ = std::fs::remove_file(rest);
            }
            return Err(ArtifactError::io(path, e));
        }
    }
    Ok(())
}

/// Removes every pending file (the stage failed: its old outputs stay as they were).
pub fn discard_pending() {
    let list = PENDING.lock().unwrap_or_else(std::sync::PoisonError::into_inner).as_mut().map(std::mem::take);
    for (tmp, _) in list.unwrap_or_default() {
        let _ = std::fs::remove_file(tmp);
    }
}

/// Where the current content of `path` is: its pending temporary file, if any.
pub(crate) fn current_location(path: &Path) -> PathBuf {
    let pending = PENDING.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    pending
        .as_ref()
        .and_then(|list| list.iter().find(|(_, p)| p == path).map(|(tmp, _)| tmp.clone()))
        .unwrap_or_else(|| path.to_path_buf())
}

/// The key-value metadata of a Parquet file, read from its footer only.
pub fn metadata_of(path: &Path) -> Result<BTreeMap<String, String>> {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let file = crate::input::open_regular(&current_location(path))?;
    let reader = SerializedFileReader::new(file).map_err(|e| ArtifactError::parquet(path, e))?;
    let kv = reader.metadata().file_metadata().key_value_metadata().cloned().unwrap_or_default();
    Ok(kv.into_iter().map(|e| (e.key, e.value.unwrap_or_default())).collect())
}

/// A Parquet artifact read into memory, with its checked columns.
#[derive(Debug)]
pub struct Table {
    path: PathBuf,
    batch: RecordBatch,
    metadata: BTreeMap<String, String>,
    /// The file row of this table's first row (a chunk of a [`crate::stream::TableStream`]).
    first_row: usize,
}

impl Table {
    /// Reads `path`, checking it is a `kind` artifact of the supported schema version
    /// and that no column name repeats.
    pub fn read(path: &Path, kind: Kind) -> Result<Self> {
        let table = Self::read_any(path)?;
        check_kind(path, &table.metadata, kind)?;
        Ok(table)
    }

    /// Reads any Parquet file (no kind check), e.g. a user's curve table.
    ///
    /// A damaged file is an error naming it, never a panic: the column chunks' byte
    /// ranges are checked against the file before any page is read (the `parquet` crate
    /// asserts on a negative range), and any other panic inside the library is contained.
    pub fn read_any(path: &Path) -> Result<Self> {
        crate::stream::TableStream::open_any(path, 65_536)?.collect()
    }

    pub(crate) fn from_parts(
        path: PathBuf,
        batch: RecordBatch,
        metadata: BTreeMap<String, String>,
        first_row: usize,
    ) -> Self {
        Self { path, batch, metadata, first_row }
    }

    pub(crate) fn into_batch(self) -> RecordBatch {
        self.batch
    }

    /// The whole table as one Arrow batch.
    pub fn batch(&self) -> &RecordBatch {
        &self.batch
    }
    /// The file this table came from.
    pub fn path(&self) -> &Path {
        &self.path
    }
    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.batch.num_rows()
    }
    /// Column names in file order.
    pub fn column_names(&self) -> Vec<String> {
        self.batch.schema().fields().iter().map(|f| f.name().clone()).collect()
    }
    /// The key-value metadata.
    pub fn metadata(&self) -> &BTreeMap<String, String> {
        &self.metadata
    }
    /// A metadata value, or an error naming the missing key.
    pub fn meta(&self, key: &str) -> Result<&str> {
        self.metadata.get(key).map(String::as_str).ok_or_else(|| ArtifactError::Metadata {
            path: self.path.clone(),
            key: key.into(),
            message: "missing".into(),
        })
    }
    /// The provenance record.
    pub fn provenance(&self) -> Result<Provenance> {
        Provenance::from_metadata(&self.path, &self.metadata)
    }
    /// Whether a column exists.
    pub fn has_column(&self, name: &str) -> bool {
        self.batch.schema().index_of(name).is_ok()
    }

    fn column(&self, name: &str) -> Result<&ArrayRef> {
        self.batch
            .column_by_name(name)
            .ok_or_else(|| ArtifactError::MissingColumn { path: self.path.clone(), column: name.into() })
    }

    fn typed<'a, T: 'static>(&'a self, name: &str, expected: &str) -> Result<&'a T> {
        let col = self.column(name)?;
        if let Some(i) = (0..col.len()).find(|&i| col.is_null(i)) {
            return Err(ArtifactError::Null { path: self.path.clone(), column: name.into(), row: self.first_row + i });
        }
        col.as_any().downcast_ref::<T>().ok_or_else(|| ArtifactError::ColumnType {
            path: self.path.clone(),
            column: name.into(),
            expected: expected.into(),
            found: col.data_type().to_string(),
        })
    }

    /// A Float64 column whose every value is finite.
    pub fn f64(&self, name: &str) -> Result<&[f64]> {
        let values = self.typed::<Float64Array>(name, "Float64")?.values();
        if let Some((row, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(ArtifactError::NotFinite {
                path: self.path.clone(),
                column: name.into(),
                row: self.first_row + row,
                value,
            });
        }
        Ok(values)
    }
    /// A Float64 column without nulls whose values may be infinite or NaN (for columns
    /// whose meaning includes them, e.g. a ratio that is `inf` when undefined).
    pub fn f64_any(&self, name: &str) -> Result<&[f64]> {
        Ok(self.typed::<Float64Array>(name, "Float64")?.values())
    }
    /// A nullable Float64 column (nulls as None; non-null values must be finite).
    pub fn f64_opt(&self, name: &str) -> Result<Vec<Option<f64>>> {
        let col = self.column(name)?;
        let array = col.as_any().downcast_ref::<Float64Array>().ok_or_else(|| ArtifactError::ColumnType {
            path: self.path.clone(),
            column: name.into(),
            expected: "Float64".into(),
            found: col.data_type().to_string(),
        })?;
        let values: Vec<Option<f64>> = array.iter().collect();
        if let Some((row, value)) =
            values.iter().enumerate().find_map(|(i, v)| v.filter(|x| !x.is_finite()).map(|x| (i, x)))
        {
            return Err(ArtifactError::NotFinite {
                path: self.path.clone(),
                column: name.into(),
                row: self.first_row + row,
                value,
            });
        }
        Ok(values)
    }
    /// An Int64 column.
    pub fn i64(&self, name: &str) -> Result<&[i64]> {
        Ok(self.typed::<Int64Array>(name, "Int64")?.values())
    }
    /// A Boolean column.
    pub fn bool(&self, name: &str) -> Result<Vec<bool>> {
        Ok(self.typed::<BooleanArray>(name, "Boolean")?.iter().map(|v| v.unwrap_or(false)).collect())
    }
    /// A Utf8 column.
    pub fn str(&self, name: &str) -> Result<Vec<&str>> {
        let array = self.typed::<StringArray>(name, "Utf8")?;
        Ok((0..array.len()).map(|i| array.value(i)).collect())
    }
    /// Any numeric column cast to f64, every value present and finite (for user tables).
    pub fn numbers(&self, name: &str) -> Result<Vec<f64>> {
        let col = self.column(name)?;
        if !col.data_type().is_numeric() {
            return Err(ArtifactError::ColumnType {
                path: self.path.clone(),
                column: name.into(),
                expected: "a number".into(),
                found: col.data_type().to_string(),
            });
        }
        let cast = arrow::compute::cast(col, &DataType::Float64).map_err(|e| ArtifactError::parquet(&self.path, e))?;
        let array = cast.as_any().downcast_ref::<Float64Array>().expect("cast to Float64 gives Float64Array");
        array
            .iter()
            .enumerate()
            .map(|(row, v)| match v {
                None => {
                    Err(ArtifactError::Null { path: self.path.clone(), column: name.into(), row: self.first_row + row })
                }
                Some(value) if !value.is_finite() => Err(ArtifactError::NotFinite {
                    path: self.path.clone(),
                    column: name.into(),
                    row: self.first_row + row,
                    value,
                }),
                Some(value) => Ok(value),
            })
            .collect()
    }
    /// Any string-like column as owned strings, every value present (for user tables).
    pub fn strings(&self, name: &str) -> Result<Vec<String>> {
        let col = self.column(name)?;
        let cast = arrow::compute::cast(col, &DataType::Utf8).map_err(|_| ArtifactError::ColumnType {
            path: self.path.clone(),
            column: name.into(),
            expected: "text".into(),
            found: col.data_type().to_string(),
        })?;
        let array = cast.as_any().downcast_ref::<StringArray>().expect("cast to Utf8 gives StringArray");
        (0..array.len())
            .map(|row| {
                if array.is_null(row) {
                    Err(ArtifactError::Null { path: self.path.clone(), column: name.into(), row: self.first_row + row })
                } else {
                    Ok(array.value(row).to_string())
                }
            })
            .collect()
    }
    /// The arrow type of a column (for error messages and generic readers).
    pub fn column_type(&self, name: &str) -> Result<DataType> {
        Ok(self.column(name)?.data_type().clone())
    }
    /// An error about this table that is not about one column.
    pub fn invalid(&self, message: impl Into<String>) -> ArtifactError {
        ArtifactError::Invalid { path: self.path.clone(), message: message.into() }
    }
}

/// Checks that `metadata` (of `path`) says it is a `kind` artifact of the supported version.
pub(crate) fn check_kind(path: &Path, metadata: &BTreeMap<String, String>, kind: Kind) -> Result<()> {
    let found = metadata.get(KEY_KIND).cloned();
    if found.as_deref() != Some(kind.name) {
        return Err(ArtifactError::WrongKind {
            path: path.into(),
            expected: kind.name.into(),
            found: found.map_or_else(|| "no `reprise.schema` metadata".into(), |k| format!("`{k}`")),
        });
    }
    let version = metadata.get(KEY_SCHEMA_VERSION).cloned().unwrap_or_else(|| "(none)".into());
    if version != kind.version.to_string() {
        return Err(ArtifactError::SchemaVersion {
            path: path.into(),
            kind: kind.name.into(),
            expected: kind.version,
            found: version,
        });
    }
    Ok(())
}

/// Checks that every column chunk's pages lie inside the file (`file_len` bytes): a
/// start and a compressed length that are non-negative and end within the file.
pub fn check_chunk_ranges(
    metadata: &parquet::file::metadata::ParquetMetaData,
    file_len: u64,
) -> std::result::Result<(), String> {
    for (g, group) in metadata.row_groups().iter().enumerate() {
        for (c, chunk) in group.columns().iter().enumerate() {
            let start = chunk.dictionary_page_offset().unwrap_or(chunk.data_page_offset());
            let len = chunk.compressed_size();
            let end = u64::try_from(start).ok().zip(u64::try_from(len).ok()).and_then(|(s, l)| s.checked_add(l));
            if end.is_none_or(|end| end > file_len) {
                return Err(format!(
                    "row group {g}, column {c} (`{}`): pages at byte {start}, length {len}, lie outside the {file_len}-byte file",
                    chunk.column_path().string()
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A NaN or an infinity never reaches an artifact: the write fails naming the column
    /// and row, and leaves nothing at the path; a column declared to hold them
    /// ([`Columns::f64_any`]) and a nullable column's nulls are written.
    #[test]
    fn non_finite_values_are_never_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scales.parquet");
        let kind = Kind { name: "t", version: 1 };
        let pv = Provenance::new("scale", "0", serde_json::json!({}));
        for (column, bad) in [("weight", f64::NAN), ("std", f64::INFINITY)] {
            let cols = Columns::new().str("label", &["a", "b"]).f64(column, vec![1.0, bad]);
            let e = write(&path, kind, cols, &pv, &[]).unwrap_err().to_string();
            assert!(e.contains(&format!("scales.parquet: column `{column}`, row 1: value {bad} is not finite")), "{e}");
            assert!(!path.exists());
        }
        let e = write(&path, kind, Columns::new().f64_opt("m", vec![None, Some(f64::NAN)]), &pv, &[]).unwrap_err();
        assert!(e.to_string().contains("column `m`, row 1"), "{e}");
        let ok = Columns::new().f64_any("ratio", vec![f64::INFINITY, 1.0]).f64_opt("m", vec![None, Some(2.0)]);
        write(&path, kind, ok, &pv, &[]).unwrap();
        assert!(path.exists());
    }
}
