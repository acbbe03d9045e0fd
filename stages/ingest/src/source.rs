//! A user's curve table (CSV or Parquet) read into columns, with errors that name the
//! file, the column and the line (CSV, counting the header as line 1) or row (Parquet).

use std::path::{Path, PathBuf};

use reprise_artifact::Table;
use reprise_stagekit::{StageError, StageResult};

/// A table of named columns whose cells are parsed on demand.
pub(crate) enum RawTable {
    /// CSV: the header and every record as text.
    Csv { path: PathBuf, headers: Vec<String>, records: Vec<csv::StringRecord>, lines: Vec<u64> },
    /// Parquet: typed columns.
    Parquet { table: Table },
}

/// The largest curve CSV read (see [`RawTable::read`]): 8 GiB; its values are bounded by
/// `--max-values` as well.
const MAX_CSV_BYTES: u64 = 8 << 30;

/// The largest magnitude of a number in a curve table (times, frames and controls):
/// 10¹⁵. Sums of squares of a billion such values still stay finite.
pub(crate) const MAX_MAGNITUDE: f64 = 1e15;

impl RawTable {
    /// Reads a `.csv` or `.parquet` file (by extension).
    pub(crate) fn read(path: &Path) -> StageResult<Self> {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("csv") => Self::read_csv(path),
            Some("parquet" | "pq") => {
                let table = Table::read_any(path)?;
                Ok(Self::Parquet { table })
            }
            _ => Err(StageError::Input(format!(
                "{}: unknown curve table format; expected a .csv or .parquet file",
                path.display()
            ))),
        }
    }

    fn read_csv(path: &Path) -> StageResult<Self> {
        let io = |e: &dyn std::fmt::Display| StageError::Input(format!("{}: {e}", path.display()));
        let len =
            reprise_artifact::input::check_file(path, MAX_CSV_BYTES).map_err(|e| StageError::Input(e.to_string()))?;
        if len == 0 {
            return Err(StageError::Input(format!(
                "{}: the file is empty; a curve table starts with a header line (`clip,frame,<control>,…`)",
                path.display()
            )));
        }
        let mut reader = csv::ReaderBuilder::new().trim(csv::Trim::All).from_path(path).map_err(|e| io(&e))?;
        let headers: Vec<String> = reader.headers().map_err(|e| io(&e))?.iter().map(String::from).collect();
        // Refused from the header, before a row is read (key columns aside).
        if headers.len() > crate::curves::MAX_CONTROLS + 8 {
            crate::curves::check_controls(path, &headers)?;
        }
        if let [only] = headers.as_slice() {
            if let Some(sep) = [';', '\t', '|'].into_iter().find(|c| only.contains(*c)) {
                let shown = if sep == '\t' { "a tab".to_string() } else { format!("`{sep}`") };
                return Err(StageError::Input(format!(
                    "{}: line 1: the columns are separated by {shown}, not by commas; reprise reads comma-separated \
                     CSV with `.` as the decimal point (re-export it, or convert it to Parquet)",
                    path.display()
                )));
            }
        }
        for (i, h) in headers.iter().enumerate() {
            if h.is_empty() {
                return Err(StageError::Input(format!(
                    "{}: line 1, column {}: empty column name",
                    path.display(),
                    i + 1
                )));
            }
            if let Some(j) = headers[..i].iter().position(|g| g == h) {
                return Err(StageError::Input(format!(
                    "{}: line 1: duplicated column `{h}` (columns {} and {})",
                    path.display(),
                    j + 1,
                    i + 1
                )));
            }
        }
        let mut records = Vec::new();
        let mut lines = Vec::new();
        for record in reader.records() {
            let record = record.map_err(|e| match e.kind() {
                csv::ErrorKind::UnequalLengths { pos, expected_len, len } => StageError::Input(format!(
                    "{}: line {}: {len} fields where the header has {expected_len}; a decimal comma (`0,5` for \
                     `0.5`) or an unquoted comma inside a name splits a field in two",
                    path.display(),
                    pos.as_ref().map_or(0, csv::Position::line)
                )),
                _ => io(&e),
            })?;
            lines.push(record.position().map_or(0, csv::Position::line));
            records.push(record);
        }
        Ok(Self::Csv { path: path.into(), headers, records, lines })
    }

    pub(crate) fn path(&self) -> &Path {
        match self {
            Self::Csv { path, .. } => path,
            Self::Parquet { table } => table.path(),
        }
    }

    pub(crate) fn column_names(&self) -> Vec<String> {
        match self {
            Self::Csv { headers, .. } => headers.clone(),
            Self::Parquet { table } => table.column_names(),
        }
    }

    pub(crate) fn rows(&self) -> usize {
        match self {
            Self::Csv { records, .. } => records.len(),
            Self::Parquet { table } => table.rows(),
        }
    }

    /// Where a row is, for messages: `line 12` (CSV) or `row 10` (Parquet, from 0).
    pub(crate) fn at(&self, row: usize) -> String {
        match self {
            Self::Csv { lines, .. } => format!("line {}", lines[row]),
            Self::Parquet { .. } => format!("row {row}"),
        }
    }

    /// `file: line N, column `c`: message`.
    pub(crate) fn error(&self, row: usize, column: &str, message: &str) -> StageError {
        StageError::Input(format!("{}: {}, column `{column}`: {message}", self.path().display(), self.at(row)))
    }

    fn index(&self, column: &str) -> usize {
        match self {
            Self::Csv { headers, .. } => {
                headers.iter().position(|h| h == column).expect("caller checked the column exists")
            }
            Self::Parquet { .. } => 0,
        }
    }

    /// A column of finite numbers.
    pub(crate) fn numbers(&self, column: &str) -> StageResult<Vec<f64>> {
        let values = self.finite_numbers(column)?;
        match values.iter().position(|v| v.abs() > MAX_MAGNITUDE) {
            Some(row) => Err(self.error(
                row,
                column,
                &format!(
                    "value {:e} is beyond ±{MAX_MAGNITUDE:e}: no rig control is that large, and its square overflows \
                     the statistics of every later stage (a typo, or a unit far too small?)",
                    values[row]
                ),
            )),
            None => Ok(values),
        }
    }

    /// A column of finite numbers, as read.
    fn finite_numbers(&self, column: &str) -> StageResult<Vec<f64>> {
        match self {
            Self::Parquet { table } => Ok(table.numbers(column)?),
            Self::Csv { records, .. } => {
                let c = self.index(column);
                records
                    .iter()
                    .enumerate()
                    .map(|(row, r)| {
                        let cell = r.get(c).unwrap_or("");
                        match cell.parse::<f64>() {
                            Ok(v) if v.is_finite() => Ok(v),
                            Ok(v) => Err(self.error(row, column, &format!("value {v} is not finite"))),
                            Err(_) if cell.is_empty() => Err(self.error(row, column, "missing value")),
                            Err(_) if cell.replacen(',', ".", 1).parse::<f64>().is_ok() => Err(self.error(
                                row,
                                column,
                                &format!(
                                    "`{cell}` has a decimal comma; reprise reads numbers with a decimal point (`.`)"
                                ),
                            )),
                            Err(_) => Err(self.error(row, column, &format!("`{cell}` is not a number"))),
                        }
                    })
                    .collect()
            }
        }
    }

    /// A column of whole numbers (frame numbers).
    pub(crate) fn integers(&self, column: &str) -> StageResult<Vec<i64>> {
        let values = self.numbers(column)?;
        values
            .iter()
            .enumerate()
            .map(|(row, &v)| {
                if v.fract() == 0.0 && v.abs() < 9.0e15 {
                    Ok(v as i64)
                } else {
                    Err(self.error(row, column, &format!("{v} is not a whole frame number")))
                }
            })
            .collect()
    }

    /// A column of text.
    pub(crate) fn strings(&self, column: &str) -> StageResult<Vec<String>> {
        match self {
            Self::Parquet { table } => Ok(table.strings(column)?),
            Self::Csv { records, .. } => {
                let c = self.index(column);
                records
                    .iter()
                    .enumerate()
                    .map(|(row, r)| match r.get(c) {
                        Some(cell) if !cell.is_empty() => Ok(cell.to_string()),
                        _ => Err(self.error(row, column, "missing value")),
                    })
                    .collect()
            }
        }
    }
}
