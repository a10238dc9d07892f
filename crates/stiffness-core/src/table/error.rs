//! What can go wrong reading or writing a table: every message names the line (header = 1)
//! and the column where that applies.

use std::path::PathBuf;

use thiserror::Error;

/// An error of the table reader or writer. The model crates map it onto their own error
/// types (keeping the line and column), so that a user sees one kind of message whatever
/// file is read.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum TableError {
    /// The file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file (`<reader>` / `<writer>` for a stream).
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The CSV structure itself is broken (quoting, field count, encoding, line length).
    #[error("line {line}: malformed CSV: {message}")]
    Malformed {
        /// File line (header = 1).
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// The file has no header line (it is empty or blank).
    #[error("the file is empty: no header line")]
    NoHeader,
    /// A cell is not a number (or not an integer).
    #[error("line {line}, column '{column}': cannot parse '{text}' as {expected}")]
    Parse {
        /// File line (header = 1).
        line: u64,
        /// Data row, 0-based (blank lines are not rows).
        row: usize,
        /// The column, as the caller names it.
        column: String,
        /// The offending text.
        text: String,
        /// What was expected (`a number`, `an integer`).
        expected: &'static str,
    },
    /// A cell of a label column is none of its labels.
    #[error("line {line}, column '{column}': unknown label '{text}' (expected one of {})", .allowed.join(", "))]
    Label {
        /// File line (header = 1).
        line: u64,
        /// Data row, 0-based (blank lines are not rows).
        row: usize,
        /// The column, as the caller names it.
        column: String,
        /// The offending text.
        text: String,
        /// The labels the column accepts (compared case-insensitively).
        allowed: &'static [&'static str],
    },
    /// The columns given to the writer do not fit together.
    #[error("cannot write the table: {message}")]
    Shape {
        /// Which column or count is wrong.
        message: String,
    },
    /// The read or write was cancelled through its token; nothing was returned.
    #[error("cancelled")]
    Cancelled,
}

impl From<crate::Cancelled> for TableError {
    fn from(_: crate::Cancelled) -> Self {
        TableError::Cancelled
    }
}

impl TableError {
    /// The error of a piece of the file that starts after `rows` data rows, with its row
    /// counted from the start of the file.
    pub(crate) fn after_rows(mut self, rows: usize) -> Self {
        if let TableError::Parse { row, .. } | TableError::Label { row, .. } = &mut self {
            *row += rows;
        }
        self
    }

    /// The error of a piece of the file whose first line is file line `line`, with its line
    /// counted from the start of the file (the piece counted from 0).
    pub(crate) fn after_lines(mut self, line: u64) -> Self {
        if let TableError::Malformed { line: l, .. }
        | TableError::Parse { line: l, .. }
        | TableError::Label { line: l, .. } = &mut self
        {
            *l += line;
        }
        self
    }
}
