//! The content hash every artifact carries under [`KEY_CONTENT`]: blake3 of its decoded
//! columns, computed batch by batch so that a table written or read in pieces hashes the
//! same as in one piece.
//!
//! Parquet pages carry no checksum as parquet-rs writes them, so a flipped bit in a data
//! page would otherwise decode into silently different numbers. The hash is
//!
//! $$h = \mathrm{blake3}\big(\,\Vert_{c}\; |n_c| \,\Vert\, n_c \,\Vert\, t_c \,\Vert\, \mathrm{blake3}(v_c)\big)$$
//!
//! over the columns $c$ in file order, with $n_c$ the column's name, $t_c$ its Arrow type
//! and $v_c$ its values row after row (a null as byte 0; a value as byte 1 and its
//! little-endian bits; a string with its length first). Only the columns' own streams
//! depend on the rows, so how rows are split into batches or row groups does not matter.
//!
//! [`KEY_CONTENT`]: crate::provenance::KEY_CONTENT

use arrow::array::{Array, BooleanArray, Float64Array, Int64Array, RecordBatch, StringArray};
use arrow::datatypes::Schema;

/// A content hash being computed over a table's batches ([`ContentHash::update`] each
/// batch in row order, then [`ContentHash::finish`]).
pub(crate) struct ContentHash {
    /// (name, type) per column.
    fields: Vec<(String, String)>,
    /// The value stream's hasher per column.
    columns: Vec<blake3::Hasher>,
    /// `false` once a column of a type reprise does not write is seen: no hash.
    supported: bool,
    buf: Vec<u8>,
}

impl ContentHash {
    /// A hash over tables of `schema`.
    pub(crate) fn new(schema: &Schema) -> Self {
        let fields: Vec<(String, String)> =
            schema.fields().iter().map(|f| (f.name().clone(), f.data_type().to_string())).collect();
        let columns = fields.iter().map(|_| blake3::Hasher::new()).collect();
        Self { fields, columns, supported: true, buf: Vec::new() }
    }

    /// Adds the next rows (the batch must have the schema given to [`ContentHash::new`]).
    pub(crate) fn update(&mut self, batch: &RecordBatch) {
        for (column, hasher) in batch.columns().iter().zip(&mut self.columns) {
            let any = column.as_any();
            let (f64s, i64s) = (any.downcast_ref::<Float64Array>(), any.downcast_ref::<Int64Array>());
            let (bools, strs) = (any.downcast_ref::<BooleanArray>(), any.downcast_ref::<StringArray>());
            if f64s.is_none() && i64s.is_none() && bools.is_none() && strs.is_none() {
                self.supported = false;
                return;
            }
            let buf = &mut self.buf;
            buf.clear();
            for row in 0..column.len() {
                if column.is_null(row) {
                    buf.push(0);
                    continue;
                }
                buf.push(1);
                if let Some(a) = f64s {
                    buf.extend_from_slice(&a.value(row).to_bits().to_le_bytes());
                } else if let Some(a) = i64s {
                    buf.extend_from_slice(&a.value(row).to_le_bytes());
                } else if let Some(a) = bools {
                    buf.push(u8::from(a.value(row)));
                } else if let Some(a) = strs {
                    buf.extend_from_slice(&(a.value(row).len() as u64).to_le_bytes());
                    buf.extend_from_slice(a.value(row).as_bytes());
                }
            }
            hasher.update(buf);
        }
    }

    /// The hash, hex; `None` if a column has a type reprise does not write.
    pub(crate) fn finish(&self) -> Option<String> {
        if !self.supported {
            return None;
        }
        let mut h = blake3::Hasher::new();
        for ((name, dtype), column) in self.fields.iter().zip(&self.columns) {
            h.update(&(name.len() as u64).to_le_bytes());
            h.update(name.as_bytes());
            h.update(dtype.as_bytes());
            h.update(column.finalize().as_bytes());
        }
        Some(h.finalize().to_hex().to_string())
    }

    /// The hash of one whole batch.
    #[cfg(test)]
    pub(crate) fn of(batch: &RecordBatch) -> Option<String> {
        let mut h = Self::new(&batch.schema());
        h.update(batch);
        h.finish()
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use arrow::array::ArrayRef;
    use arrow::datatypes::{DataType, Field};

    use super::*;

    fn batch(f: Vec<Option<f64>>, s: Vec<&str>) -> RecordBatch {
        let schema = Arc::new(Schema::new(vec![
            Field::new("f", DataType::Float64, true),
            Field::new("s", DataType::Utf8, false),
        ]));
        let columns: Vec<ArrayRef> = vec![Arc::new(Float64Array::from(f)), Arc::new(StringArray::from(s))];
        RecordBatch::try_new(schema, columns).unwrap()
    }

    /// The same rows hash the same in one batch or split anywhere into several; another
    /// value, a null for a value, or a string moved across a boundary changes the hash.
    #[test]
    fn the_hash_does_not_depend_on_batching() {
        let whole = batch(vec![Some(1.0), None, Some(3.0)], vec!["ab", "c", ""]);
        let one = ContentHash::of(&whole).unwrap();
        for cut in 0..=3 {
            let mut h = ContentHash::new(&whole.schema());
            h.update(&whole.slice(0, cut));
            h.update(&whole.slice(cut, 3 - cut));
            assert_eq!(h.finish().unwrap(), one, "split at {cut}");
        }
        let other = [
            batch(vec![Some(1.0), None, Some(3.5)], vec!["ab", "c", ""]),
            batch(vec![Some(1.0), Some(0.0), Some(3.0)], vec!["ab", "c", ""]),
            batch(vec![Some(1.0), None, Some(3.0)], vec!["a", "bc", ""]),
        ];
        for b in other {
            assert_ne!(ContentHash::of(&b).unwrap(), one);
        }
    }
}
