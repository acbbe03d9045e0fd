//! Tables written and read in pieces, so a stage never holds a large artifact whole: a
//! [`TableWriter`] appends batches to a row-group-bounded Parquet file and renames it into
//! place once complete; a [`TableStream`] yields a file's rows in bounded chunks. Both keep
//! the content hash ([`crate::content`]) as they go, so a streamed table carries and is
//! checked against the same hash as one written or read whole.

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};

use arrow::datatypes::{DataType, Schema, SchemaRef};
use arrow::record_batch::RecordBatch;
use parquet::arrow::arrow_reader::{ParquetRecordBatchReader, ParquetRecordBatchReaderBuilder};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, Encoding, ZstdLevel};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::schema::types::ColumnPath;

use crate::content::ContentHash;
use crate::error::{ArtifactError, Result};
use crate::provenance::{Provenance, KEY_CONTENT, KEY_KIND, KEY_SCHEMA_VERSION};
use crate::table::{self, Columns, Kind, Table};

/// Rows per row group of a streamed table: with a few hundred Float64 columns a row group
/// is a few tens of MB while it is encoded or decoded.
pub const ROW_GROUP_ROWS: usize = 4096;

/// An artifact being written batch by batch. Nothing appears at its path until
/// [`TableWriter::finish`]; dropped unfinished (an error on the way), its temporary file is
/// removed and the old artifact stays.
pub struct TableWriter {
    path: PathBuf,
    tmp: PathBuf,
    schema: SchemaRef,
    writer: Option<ArrowWriter<File>>,
    hash: ContentHash,
    /// Rows written so far.
    rows: usize,
}

impl TableWriter {
    /// Starts a `kind` artifact at `path` whose first rows (and schema) are `first`;
    /// `extra` adds kind-specific metadata keys.
    pub fn create(
        path: &Path,
        kind: Kind,
        first: Columns,
        provenance: &Provenance,
        extra: &[(String, String)],
    ) -> Result<Self> {
        let batch = first.into_batch(path, 0)?;
        let kv = [(KEY_KIND.to_string(), kind.name.to_string()), (KEY_SCHEMA_VERSION.into(), kind.version.to_string())]
            .into_iter()
            .chain(provenance.to_metadata())
            .chain(extra.iter().cloned());
        let mut w = Self::with_metadata(path, batch.schema(), kv.collect())?;
        w.write_batch(&batch)?;
        Ok(w)
    }

    /// Starts a table of `schema` at `path` with the key-value `metadata` (any
    /// [`KEY_CONTENT`] in it is replaced by the hash of the rows written).
    pub(crate) fn with_metadata(path: &Path, schema: SchemaRef, metadata: Vec<(String, String)>) -> Result<Self> {
        let kv: Vec<KeyValue> =
            metadata.into_iter().filter(|(k, _)| k != KEY_CONTENT).map(|(k, v)| KeyValue::new(k, v)).collect();
        let mut props = WriterProperties::builder()
            .set_compression(Compression::ZSTD(ZstdLevel::try_new(1).expect("level 1 is valid")))
            .set_max_row_group_row_count(Some(ROW_GROUP_ROWS))
            .set_key_value_metadata(Some(kv));
        // Floating-point columns byte-stream split: the bytes of like significance side by
        // side, which zstd compresses far better for smooth curves (the same values).
        for field in schema.fields().iter().filter(|f| matches!(f.data_type(), DataType::Float64 | DataType::Float32)) {
            let column = ColumnPath::from(field.name().as_str());
            props = props
                .set_column_dictionary_enabled(column.clone(), false)
                .set_column_encoding(column, Encoding::BYTE_STREAM_SPLIT);
        }
        let props = props.build();
        let tmp = table::begin_atomic(path)?;
        let file = File::create(&tmp).map_err(|e| ArtifactError::io(&tmp, e))?;
        let hash = ContentHash::new(&schema);
        let mut w = Self { path: path.into(), tmp, schema: schema.clone(), writer: None, hash, rows: 0 };
        w.writer = Some(ArrowWriter::try_new(file, schema, Some(props)).map_err(|e| ArtifactError::parquet(path, e))?);
        Ok(w)
    }

    /// Appends rows; their columns must be the first rows' (names, types, order).
    pub fn write(&mut self, rows: Columns) -> Result<()> {
        let batch = rows.into_batch(&self.path, self.rows)?;
        self.write_batch(&batch)
    }

    pub(crate) fn write_batch(&mut self, batch: &RecordBatch) -> Result<()> {
        if batch.schema().fields() != self.schema.fields() {
            return Err(ArtifactError::Invalid {
                path: self.path.clone(),
                message: "rows appended with other columns than the table's first rows (internal error)".into(),
            });
        }
        self.hash.update(batch);
        self.rows += batch.num_rows();
        let writer = self.writer.as_mut().expect("a writer is open until finish");
        writer.write(batch).map_err(|e| ArtifactError::parquet(&self.path, e))
    }

    /// Writes the footer with the content hash and renames the file into place (or leaves
    /// it pending, see [`table::defer_commits`]).
    pub fn finish(mut self) -> Result<()> {
        let mut writer = self.writer.take().expect("a writer is open until finish");
        if let Some(hash) = self.hash.finish() {
            writer.append_key_value_metadata(KeyValue::new(KEY_CONTENT.into(), hash));
        }
        let file = writer.into_inner().map_err(|e| ArtifactError::parquet(&self.path, e))?;
        file.sync_all().map_err(|e| ArtifactError::io(&self.tmp, e))?;
        table::commit_atomic(&self.tmp, &self.path)
    }
}

impl Drop for TableWriter {
    fn drop(&mut self) {
        if self.writer.is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// An artifact read in chunks of at most `rows` rows, each a [`Table`] (its errors name
/// rows of the whole file). The content hash is checked once the last chunk is read: a
/// consumer must not commit anything it derived before the stream ends without error.
pub struct TableStream {
    path: PathBuf,
    metadata: BTreeMap<String, String>,
    schema: SchemaRef,
    reader: ParquetRecordBatchReader,
    hash: ContentHash,
    next_row: usize,
    done: bool,
}

impl TableStream {
    /// Opens `path`, checking that it is a `kind` artifact of the supported schema
    /// version, that no column name repeats and that its pages lie inside the file.
    pub fn open(path: &Path, kind: Kind, rows: usize) -> Result<Self> {
        let stream = Self::open_any(path, rows)?;
        table::check_kind(path, &stream.metadata, kind)?;
        Ok(stream)
    }

    /// Opens any Parquet file (no kind check).
    pub fn open_any(path: &Path, rows: usize) -> Result<Self> {
        contained(path, || Self::open_unguarded(path, rows))
    }

    fn open_unguarded(path: &Path, rows: usize) -> Result<Self> {
        let file = crate::input::open_regular(&table::current_location(path))?;
        let file_len = file.metadata().map_err(|e| ArtifactError::io(path, e))?.len();
        let builder = ParquetRecordBatchReaderBuilder::try_new(file).map_err(|e| ArtifactError::parquet(path, e))?;
        table::check_chunk_ranges(builder.metadata(), file_len)
            .map_err(|message| ArtifactError::Parquet { path: path.into(), message })?;
        let metadata: BTreeMap<String, String> = builder
            .metadata()
            .file_metadata()
            .key_value_metadata()
            .map(|kv| kv.iter().map(|e| (e.key.clone(), e.value.clone().unwrap_or_default())).collect())
            .unwrap_or_default();
        let schema = builder.schema().clone();
        let mut seen = std::collections::HashSet::new();
        for field in schema.fields() {
            if !seen.insert(field.name()) {
                return Err(ArtifactError::DuplicateColumn { path: path.into(), column: field.name().clone() });
            }
        }
        let reader = builder.with_batch_size(rows.max(1)).build().map_err(|e| ArtifactError::parquet(path, e))?;
        let hash = ContentHash::new(&schema);
        Ok(Self { path: path.into(), metadata, schema, reader, hash, next_row: 0, done: false })
    }

    /// The key-value metadata.
    pub fn metadata(&self) -> &BTreeMap<String, String> {
        &self.metadata
    }

    /// The table's schema.
    pub fn schema(&self) -> &Schema {
        &self.schema
    }

    /// The next chunk of rows, or `None` after the last (the content hash then checked).
    pub fn next_chunk(&mut self) -> Result<Option<Table>> {
        if self.done {
            return Ok(None);
        }
        let path = self.path.clone();
        let next = contained(&path, || self.reader.next().transpose().map_err(|e| ArtifactError::parquet(&path, e)))?;
        let Some(batch) = next else {
            self.done = true;
            if let Some(expected) = self.metadata.get(KEY_CONTENT) {
                if self.hash.finish().as_ref() != Some(expected) {
                    return Err(ArtifactError::Corrupt { path: self.path.clone() });
                }
            }
            return Ok(None);
        };
        self.hash.update(&batch);
        let first_row = self.next_row;
        self.next_row += batch.num_rows();
        Ok(Some(Table::from_parts(self.path.clone(), batch, self.metadata.clone(), first_row)))
    }

    /// Every remaining row as one table (the hash checked).
    pub fn collect(mut self) -> Result<Table> {
        let mut batches = Vec::new();
        while let Some(t) = self.next_chunk()? {
            batches.push(t.into_batch());
        }
        let batch = arrow::compute::concat_batches(&self.schema, &batches)
            .map_err(|e| ArtifactError::parquet(&self.path, e))?;
        Ok(Table::from_parts(self.path, batch, self.metadata, 0))
    }
}

/// Runs a Parquet read; a panic inside the library becomes an error naming the file.
fn contained<T>(path: &Path, f: impl FnOnce() -> Result<T>) -> Result<T> {
    crate::contain::contain(f).unwrap_or_else(|message| {
        Err(ArtifactError::Parquet { path: path.into(), message: format!("damaged file ({message})") })
    })
}
