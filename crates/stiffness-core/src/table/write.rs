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
    /// The first `width` values of each `stride`-long row of `data` (N×stride, row-major),
    /// written as [`Column::Floats`]: part of a wider array without copying it out.
    FloatsStrided {
        /// The values, N×stride.
        data: &'a [f64],
        /// Columns written, the first of each row.
        width: usize,
        /// Values per row of `data`.
        stride: usize,
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
            Column::Floats { width, .. }
            | Column::FloatsStrided { width, .. }
            | Column::Integers { width, .. } => *width,
            Column::Bools(_) | Column::Labels { .. } => 1,
        }
    }

    /// Values per row of the group's data.
    fn stride(&self) -> usize {
        match self {
            Column::FloatsStrided { stride, .. } => *stride,
            _ => self.width(),
        }
    }

    fn values(&self) -> usize {
        match self {
            Column::Floats { data, .. } | Column::FloatsStrided { data, .. } => data.len(),
            Column::Integers { data, .. } => data.len(),
            Column::Bools(data) => data.len(),
            Column::Labels { codes, .. } => codes.len(),
        }
    }

    /// The most bytes one row of this group takes, its commas included: a shortest
    /// round-trip f64 is at most 24 bytes, an i64 20.
    fn max_row_bytes(&self) -> usize {
        match self {
            Column::Floats { width, .. } | Column::FloatsStrided { width, .. } => {
                width * (FLOAT_BYTES + 1)
            }
            Column::Integers { width, .. } => width * 21,
            Column::Bools(_) => b"false,".len(),
            Column::Labels { names, .. } => 1 + names.iter().map(|n| n.len()).max().unwrap_or(0),
        }
    }

    /// Writes row `row` of the group at `text[at..]`, each cell followed by a comma; returns
    /// where the next byte goes. `text` holds at least [`Self::max_row_bytes`] from `at`.
    fn write_row(
        &self,
        row: usize,
        text: &mut [u8],
        mut at: usize,
        floats: &mut zmij::Buffer,
    ) -> usize {
        match *self {
            Column::Floats { data, width } => {
                at = write_floats(&data[row * width..(row + 1) * width], text, at, floats);
            }
            Column::FloatsStrided {
                data,
                width,
                stride,
            } => {
                let first = row * stride;
                at = write_floats(&data[first..first + width], text, at, floats);
            }
            Column::Integers { data, width, empty } => {
                for &v in &data[row * width..(row + 1) * width] {
                    if Some(v) != empty {
                        at = put_short(text, at, itoa::Buffer::new().format(v).as_bytes());
                    }
                    text[at] = b',';
                    at += 1;
                }
            }
            Column::Bools(data) => {
                at = put_short(text, at, if data[row] { b"true," } else { b"false," });
            }
            Column::Labels { codes, names } => {
                let name = names[codes[row] as usize].as_bytes();
                text[at..at + name.len()].copy_from_slice(name);
                at += name.len();
                text[at] = b',';
                at += 1;
            }
        }
        at
    }
}

/// Writes `values` at `text[at..]`, each followed by a comma (a non-finite value as an empty
/// cell); returns the end.
#[inline(always)]
fn write_floats(
    values: &[f64],
    text: &mut [u8],
    mut at: usize,
    floats: &mut zmij::Buffer,
) -> usize {
    for &v in values {
        if v.is_finite() {
            at = put_short(text, at, floats.format_finite(v).as_bytes());
        }
        text[at] = b',';
        at += 1;
    }
    at
}

/// The longest shortest-round-trip form of an f64 (`-2.2250738585072014e-308`).
const FLOAT_BYTES: usize = 24;

/// Copies `bytes` (at most [`FLOAT_BYTES`]) to `text[at..]` and returns the end. Why not
/// `copy_from_slice`: a copy of a length known only at run time is a call to `memmove`, which
/// was a sixth of the writer's time for cells of 1 to 24 bytes. Two overlapping copies of a
/// fixed length (16, 8 or 4 bytes, from each end) are a few moves inline, and stay within
/// `text[at..at + bytes.len()]`.
#[inline(always)]
fn put_short(text: &mut [u8], at: usize, bytes: &[u8]) -> usize {
    let n = bytes.len();
    let end = at + n;
    if n >= 16 {
        text[at..at + 16].copy_from_slice(&bytes[..16]);
        text[end - 16..end].copy_from_slice(&bytes[n - 16..]);
    } else if n >= 4 {
        // 4..15 bytes: the first and last 8 (or 4) overlap.
        if n >= 8 {
            text[at..at + 8].copy_from_slice(&bytes[..8]);
            text[end - 8..end].copy_from_slice(&bytes[n - 8..]);
        } else {
            text[at..at + 4].copy_from_slice(&bytes[..4]);
            text[end - 4..end].copy_from_slice(&bytes[n - 4..]);
        }
    } else {
        for (k, &b) in bytes.iter().enumerate() {
            text[at + k] = b;
        }
    }
    end
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
        let (w, stride) = (c.width(), c.stride());
        if w == 0 || w > stride || c.values() % stride != 0 {
            return Err(TableError::Shape {
                message: format!(
                    "column group {k} has {} values, not a multiple of its row length {stride} \
                     (writing {w} of each row)",
                    c.values()
                ),
            });
        }
        let n = c.values() / stride;
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
    let row_bytes: usize = columns.iter().map(Column::max_row_bytes).sum();
    let blocks = rows.div_ceil(BLOCK_ROWS);
    let window = rayon::current_num_threads().max(1) * 2;
    // Formats blocks `first..` of the window into `buffers` (one per block, reused from the
    // window written before: a fresh 6 MB block buffer cost a memset and its page faults,
    // an eighth of the writer's time) and returns how many bytes of each were written.
    let format = |first: usize, buffers: &mut Vec<Vec<u8>>| -> Vec<usize> {
        let last = (first + window).min(blocks);
        buffers.resize_with(last - first, Vec::new);
        (first..last)
            .into_par_iter()
            .zip(buffers.par_iter_mut())
            .map(|(b, text)| {
                let block = b * BLOCK_ROWS..((b + 1) * BLOCK_ROWS).min(rows);
                // Room for the block's rows at their longest; only the written prefix is
                // read, so a reused buffer needs no clearing.
                if text.len() < block.len() * row_bytes {
                    text.resize(block.len() * row_bytes, 0);
                }
                let mut at = 0;
                let mut floats = zmij::Buffer::new();
                for row in block {
                    for c in columns {
                        at = c.write_row(row, text, at, &mut floats);
                    }
                    // The last field's comma becomes the line end.
                    text[at - 1] = b'\n';
                }
                at
            })
            .collect()
    };
    // Window k is formatted on the pool while this thread writes window k − 1 (the kernel's
    // copy into the page cache costs about half as much as the formatting): two windows in
    // memory at most, their buffers swapped from one window to the next.
    let (mut written_buffers, mut next_buffers) = (Vec::new(), Vec::new());
    let mut lengths: Vec<usize> = Vec::new();
    for first in (0..blocks).step_by(window) {
        if cancel.is_cancelled() {
            return Err(TableError::Cancelled);
        }
        let mut next = Vec::new();
        let written = rayon::in_place_scope(|scope| {
            let buffers = &mut next_buffers;
            scope.spawn(|_| next = format(first, buffers));
            write_prefixes(&mut out, &written_buffers, &lengths)
        });
        written.map_err(io)?;
        std::mem::swap(&mut written_buffers, &mut next_buffers);
        lengths = next;
    }
    write_prefixes(&mut out, &written_buffers, &lengths).map_err(io)?;
    out.flush().map_err(io)
}

/// Writes `buffers[k][..lengths[k]]` for every k of `lengths`, in order.
fn write_prefixes(
    out: &mut impl Write,
    buffers: &[Vec<u8>],
    lengths: &[usize],
) -> std::io::Result<()> {
    buffers
        .iter()
        .zip(lengths)
        .try_for_each(|(text, &n)| out.write_all(&text[..n]))
}
