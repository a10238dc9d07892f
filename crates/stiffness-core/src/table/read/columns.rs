//! The table's arrays while they are read, and the disjoint parts of them each piece writes.
//!
//! Pieces parse straight into the final arrays: each chunk's rows get room at the end of every
//! group's array (as many rows as the chunk can hold: a row a line, no more than its bytes
//! allow), and that room is cut into one part per piece. Nothing is parsed into a buffer of its
//! own and copied again. When the file's size is known, the arrays take, after the first chunk, a
//! zeroed allocation for the rows it is expected to hold (see [`Values::extend_zeroed_to`]).

use super::CellKind;

/// One group's values.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Values {
    Float(Vec<f64>),
    Integer(Vec<i64>),
    Label(Vec<u8>),
}

/// The part of one group's values a piece writes: its rows, row-major.
#[derive(Debug)]
pub(super) enum Cells<'a> {
    Float(&'a mut [f64]),
    Integer(&'a mut [i64]),
    Label(&'a mut [u8]),
}

impl Values {
    pub(super) fn new(kind: CellKind) -> Self {
        match kind {
            CellKind::Float => Values::Float(Vec::new()),
            CellKind::Integer => Values::Integer(Vec::new()),
            CellKind::Label(_) => Values::Label(Vec::new()),
        }
    }

    /// Makes the array at least `len` long (the new values zeros).
    pub(super) fn grow_to(&mut self, len: usize) {
        match self {
            Values::Float(v) if v.len() < len => v.resize(len, 0.0),
            Values::Integer(v) if v.len() < len => v.resize(len, 0),
            Values::Label(v) if v.len() < len => v.resize(len, 0),
            _ => {}
        }
    }

    /// Makes the array `len` long ahead of the rows, zeroed by the allocator (calloc), if it
    /// grants the memory: a fresh zeroed allocation is zero pages the system fills on their
    /// first write, so the zeroing happens in the parsing threads as they write their rows,
    /// not on the reading thread before each chunk (a `resize` there was a fifth of the read).
    /// A file's size can promise more rows than it holds (a sparse file of blank lines), so a
    /// refusal is not an error: the arrays then reserve what they can and grow chunk by chunk.
    pub(super) fn extend_zeroed_to(&mut self, len: usize) {
        fn extend<T: bytemuck::Zeroable + Copy>(v: &mut Vec<T>, len: usize) {
            if len <= v.len() {
                return;
            }
            match bytemuck::allocation::try_zeroed_vec(len) {
                Ok(mut zeroed) => {
                    zeroed[..v.len()].copy_from_slice(v);
                    *v = zeroed;
                }
                Err(()) => {
                    let _ = v.try_reserve_exact(len - v.len());
                }
            }
        }
        match self {
            Values::Float(v) => extend(v, len),
            Values::Integer(v) => extend(v, len),
            Values::Label(v) => extend(v, len),
        }
    }

    pub(super) fn truncate(&mut self, len: usize) {
        match self {
            Values::Float(v) => v.truncate(len),
            Values::Integer(v) => v.truncate(len),
            Values::Label(v) => v.truncate(len),
        }
    }

    /// Moves `count` values from `from` down to `to` (closing the gap a piece's blank lines left).
    pub(super) fn move_down(&mut self, from: usize, count: usize, to: usize) {
        match self {
            Values::Float(v) => v.copy_within(from..from + count, to),
            Values::Integer(v) => v.copy_within(from..from + count, to),
            Values::Label(v) => v.copy_within(from..from + count, to),
        }
    }

    /// Cuts `[start, start + Σ lens)` into consecutive parts of the given lengths.
    fn parts(&mut self, start: usize, lens: &[usize]) -> Vec<Cells<'_>> {
        fn cut<'a, T>(
            mut rest: &'a mut [T],
            lens: &[usize],
            wrap: fn(&'a mut [T]) -> Cells<'a>,
        ) -> Vec<Cells<'a>> {
            lens.iter()
                .map(|&n| {
                    let (part, tail) = std::mem::take(&mut rest).split_at_mut(n);
                    rest = tail;
                    wrap(part)
                })
                .collect()
        }
        match self {
            Values::Float(v) => cut(&mut v[start..], lens, Cells::Float),
            Values::Integer(v) => cut(&mut v[start..], lens, Cells::Integer),
            Values::Label(v) => cut(&mut v[start..], lens, Cells::Label),
        }
    }
}

/// Every piece's part of every group: `parts[piece][group]`, piece `j` getting `rooms[j]` rows
/// from row `first_row` + the rooms of the pieces before it.
pub(super) fn piece_parts<'a>(
    values: &'a mut [Values],
    widths: &[usize],
    first_row: usize,
    rooms: &[usize],
) -> Vec<Vec<Cells<'a>>> {
    let mut parts: Vec<Vec<Cells<'a>>> = rooms.iter().map(|_| Vec::new()).collect();
    for (group, &width) in values.iter_mut().zip(widths) {
        let lens: Vec<usize> = rooms.iter().map(|&n| n * width).collect();
        for (piece, cells) in parts.iter_mut().zip(group.parts(first_row * width, &lens)) {
            piece.push(cells);
        }
    }
    parts
}
