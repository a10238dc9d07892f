//! Errors of the stiffness model file and of predictions from it.

use crate::error::VjmError;

/// Everything that can go wrong building, saving, loading or using a
/// [`StiffnessModel`](super::StiffnessModel). Messages name the file (as the caller gave it),
/// the row or the field at fault.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ModelError {
    /// The model file (or the measurement file to fingerprint) could not be read.
    #[error("cannot read `{path}`: {source}")]
    Read {
        /// The path as given.
        path: String,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The model file could not be written (nothing was left behind).
    #[error("cannot write model file `{path}`: {source}")]
    Write {
        /// The path as given.
        path: String,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not a stiffness model file (not JSON, a field missing or of the wrong type,
    /// inconsistent sizes).
    #[error("`{path}` is not a usable stiffness model file: {message}")]
    Format {
        /// The path as given.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// The file is larger or nests deeper than any model file: refused before parsing (see
    /// [`crate::bounded`]).
    #[error("`{path}` is not a usable stiffness model file: {limit}")]
    Limit {
        /// The path as given.
        path: String,
        /// What is too large or too deep, with the limit.
        limit: crate::bounded::TextLimitError,
    },
    /// The file was written for another schema version.
    #[error("model file `{path}` has schema `{found}`, this version reads `{expected}`: identify again with --save")]
    Schema {
        /// The path as given.
        path: String,
        /// The schema string in the file.
        found: String,
        /// The schema this version reads.
        expected: &'static str,
    },
    /// The content no longer matches the hash stored when it was saved.
    #[error("model file `{path}` was edited or is damaged: its content does not match the SHA-256 it was saved with (identify again with --save)")]
    Edited {
        /// The path as given.
        path: String,
    },
    /// The file describes another robot than the one given.
    #[error("model file `{path}` is for another robot: {what} is {in_file} in the file but {given} for the robot given")]
    OtherRobot {
        /// The path as given (or `<model>` for a model in memory).
        path: String,
        /// What differs (`joint count`, `base link`, `URDF content (SHA-256)`, ...).
        what: &'static str,
        /// The value recorded in the file.
        in_file: String,
        /// The value of the robot given.
        given: String,
    },
    /// The identification, the spring model and the options given do not belong together.
    #[error("cannot build a stiffness model: {message}")]
    Mismatch {
        /// What does not fit.
        message: String,
    },
    /// A pose table (the input of a prediction) cannot be used: missing column, unparsable or
    /// non-finite cell, wrong joint count.
    #[error("{path}: {message}")]
    Table {
        /// The file as given.
        path: String,
        /// What is wrong, naming the line and column.
        message: String,
    },
    /// A payload that is not a finite, non-negative mass at a finite point.
    #[error("invalid payload: {message}")]
    Payload {
        /// What is wrong.
        message: String,
    },
    /// Reading a pose table was cancelled through its token; nothing was returned.
    #[error("cancelled")]
    Cancelled,
    /// Kinematics or input checks of the core (non-finite value with its row and column,
    /// wrong lengths).
    #[error(transparent)]
    Vjm(#[from] VjmError),
}

impl ModelError {
    /// The error of a computation over distinct configurations (`runs[k]` the first original
    /// row of distinct row `k`), naming the original row. Only a configuration's own error is
    /// remapped: another input's row (a spring's offset, say) is not a row of `q`.
    pub(crate) fn at_first_rows(self, runs: &[usize]) -> Self {
        match self {
            ModelError::Vjm(VjmError::NonFinite {
                what: what @ "q",
                row,
                column,
                value,
            }) => ModelError::Vjm(VjmError::NonFinite {
                what,
                row: runs.get(row).copied().unwrap_or(row),
                column,
                value,
            }),
            other => other,
        }
    }
}
