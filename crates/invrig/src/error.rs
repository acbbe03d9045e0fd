//! Errors of the inverse rig mapping.

/// Why a mapping cannot be fitted or applied.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InvrigError {
    /// A table's size does not match.
    #[error("{what}: expected {expected} values, got {actual}")]
    Shape {
        /// Which input.
        what: &'static str,
        /// Values expected.
        expected: usize,
        /// Values given.
        actual: usize,
    },
    /// A NaN or infinite value.
    #[error("{what}: row {row}, column {col} is {value} (values must be finite)")]
    NonFinite {
        /// Which input.
        what: &'static str,
        /// Its row.
        row: usize,
        /// Its column.
        col: usize,
        /// The value.
        value: f64,
    },
    /// No rows, or no columns.
    #[error("{0}: empty")]
    Empty(&'static str),
    /// A parameter out of its range.
    #[error("{name} = {value}: {why}")]
    Param {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The range, in words.
        why: &'static str,
    },
    /// The rig evaluator failed or answered the wrong size.
    #[error("the rig: {0}")]
    Rig(String),
}

/// Results of this crate.
pub type Result<T> = std::result::Result<T, InvrigError>;

/// Checks that `values` holds `rows × cols` finite values.
pub(crate) fn check_table(what: &'static str, values: &[f64], rows: usize, cols: usize) -> Result<()> {
    if rows == 0 || cols == 0 {
        return Err(InvrigError::Empty(what));
    }
    if values.len() != rows * cols {
        return Err(InvrigError::Shape { what, expected: rows * cols, actual: values.len() });
    }
    match values.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(InvrigError::NonFinite { what, row: i / cols, col: i % cols, value: values[i] }),
        None => Ok(()),
    }
}

/// Checks that `value` is finite and positive.
pub(crate) fn check_positive(name: &'static str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(InvrigError::Param { name, value, why: "must be finite and positive" })
    }
}
