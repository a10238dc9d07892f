//! The CSV writer: blocks of rows formatted on every core, written in order.
//!
//! Numbers are written in their shortest round-trip form (`zmij`, twice as fast as `ryu` with
//! the same digits; reading the file back gives the same bits; a positive exponent is written
//! `e+17`). Memory is bounded: a window of [`BLOCK_ROWS`]-row blocks per thread is formatted on
//! the pool while the calling thread writes the window before it, then dropped.

use std::io::Write;

use rayon::prelude::*;

use super::error::TableError;
use crate::Cancel;

/// Rows formatted per block.
pub const BLOCK_ROWS: usize = 8192;

/// A group of columns of the table to write, row-major.
#[derive(Debug, Clone, Copy)]
#[non_exhaustive]
pub enum Column<'a> {
    /// `width` columns of numbers, N×width row-major; a non-finite value is an empty cell.
    Floats {
        /// The values.
        data: &'a [f64],
        /// Columns in the group.
        width: usize,
    },
    /// `width` columns of integers, N×width row-major; a value equal to `empty` (if given) is
    /// an empty cell.
    Integers {
        /// The values.
        data: &'a [i64],
        /// Columns in the group.
        width: usize,
        /// The value written as an empty cell.
        empty: Option<i64>,
    },
    /// One column of `true` / `false`.
    Bools(&'a [bool]),
    /// One column of labels: `names[codes[i]]` (names must not need quoting).
    Labels {
        /// Index into `names` per row.
        codes: &'a [u8],
        /// The labels.
        names: &'a [&'a str],
    },
}

impl Column<'_> {
    fn width(&self) -> usize {
        match self {
            Column::Floats { width, .. } | Column::Integers { width, .. } => *width,
            Column::Bools(_) | Column::Labels { .. } => 1,
        }
    }

    fn values(&self) -> usize {
        match self {
            Column::Floats { data, .. } => data.len(),
            Column::Integers { data, .. } => data.len(),
            Column::Bools(data) => data.len(),
            Column::Labels { codes, .. } => codes.len(),
        }
    }

    fn write_row(&self, row: usize, out: &mut Vec<u8>, floats: &mut zmij::Buffer) {
        match *self {
            Column::Floats { data, width } => {
                for &v in &data[row * width..(row + 1) * width] {
                    if v.is_finite() {
                        out.extend_from_slice(floats.format_finite(v).as_bytes());
                    }
                    out.push(b',');
                }
            }
            Column::Integers { data, width, empty } => {
                for &v in &data[row * width..(row + 1) * width] {
                    if Some(v) != empty {
                        out.extend_from_slice(itoa::Buffer::new().format(v).as_bytes());
                    }
                    out.push(b',');
                }
            }
            Column::Bools(data) => {
                out.extend_from_slice(if data[row] { b"true," } else { b"false," });
            }
            Column::Labels { codes, names } => {
                out.extend_from_slice(names[codes[row] as usize].as_bytes());
                out.push(b',');
            }
        }
    }
}

/// Writes `header` and the rows of `columns` (side by side, in order) as CSV to `out`; polls
/// `cancel` once per window of blocks. Errors before anything is written if the columns do not
/// fit the header or each other.
///
/// ```
/// use stiffness_core::table::{write_csv, Column};
/// let mut out = Vec::new();
/// let xy = [0.1, 2.0, f64::NAN, -3e-7];
/// write_csv(
///     &mut out,
///     &["x", "y", "ok"],
///     &[Column::Floats { data: &xy, width: 2 }, Column::Bools(&[true, false])],
///     &Default::default(),
/// )?;
/// assert_eq!(String::from_utf8(out).unwrap(), "x,y,ok\n0.1,2.0,true\n,-3e-7,false\n");
/// # Ok::<(), stiffness_core::table::TableError>(())
/// ```
pub fn write_csv(
    mut out: impl Write,
    header: &[&str],
    columns: &[Column<'_>],
    cancel: &Cancel,
) -> Result<(), TableError> {
    let width: usize = columns.iter().map(Column::width).sum();
    if width != header.len() {
        return Err(TableError::Shape {
            message: format!(
                "{} header names for {width} columns of values",
                header.len()
            ),
        });
    }
    let mut rows = None;
    for (k, c) in columns.iter().enumerate() {
        let w = c.width();
        if w == 0 || c.values() % w != 0 {
            return Err(TableError::Shape {
                message: format!(
                    "column group {k} has {} values, not a multiple of its width {w}",
                    c.values()
                ),
            });
        }
        let n = c.values() / w;
        if *rows.get_or_insert(n) != n {
            return Err(TableError::Shape {
                message: format!(
                    "column group {k} has {n} rows, the first has {}",
                    rows.unwrap_or(0)
                ),
            });
        }
        if let Column::Labels { codes, names } = c {
            if let Some(bad) = codes.iter().find(|&&i| i as usize >= names.len()) {
                return Err(TableError::Shape {
                    message: format!("label code {bad} of {} labels", names.len()),
                });
            }
        }
    }
    let rows = rows.unwrap_or(0);
    let io = |source| TableError::Io {
        path: "<writer>".into(),
        source,
    };
    out.write_all(header.join(",").as_bytes()).map_err(io)?;
    out.write_all(b"\n").map_err(io)?;
    let blocks = rows.div_ceil(BLOCK_ROWS);
    let window = rayon::current_num_threads().max(1) * 2;
    let format = |first: usize| -> Vec<Vec<u8>> {
        (first..(first + window).min(blocks))
            .into_par_iter()
            .map(|b| {
                let mut text = Vec::with_capacity(BLOCK_ROWS * width * 20);
                let mut floats = zmij::Buffer::new();
                for row in b * BLOCK_ROWS..((b + 1) * BLOCK_ROWS).min(rows) {
                    for c in columns {
                        c.write_row(row, &mut text, &mut floats);
                    }
                    // The last field's comma becomes the line end.
                    *text.last_mut().expect("a row has a field") = b'\n';
                }
                text
            })
            .collect()
    };
    // Window k is formatted on the pool while this thread writes window k − 1 (the kernel's
    // copy into the page cache costs about half as much as the formatting): two windows in
    // memory at most.
    let mut formatted: Vec<Vec<u8>> = Vec::new();
    for first in (0..blocks).step_by(window) {
        if cancel.is_cancelled() {
            return Err(TableError::Cancelled);
        }
        let mut next = Vec::new();
        let written = rayon::in_place_scope(|scope| {
            scope.spawn(|_| next = format(first));
            formatted.iter().try_for_each(|text| out.write_all(text))
        });
        written.map_err(io)?;
        formatted = next;
    }
    for text in &formatted {
        out.write_all(text).map_err(io)?;
    }
    out.flush().map_err(io)
}
