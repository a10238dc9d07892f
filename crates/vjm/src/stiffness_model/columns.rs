//! Predictions of N rows as columns, filled block by block without an N-long
//! `Vec<Prediction>` in between: what the bindings and the CLI hand to numpy and the writers.

use std::ops::Range;

use stiffness_core::row_blocks::{fill_row_blocks, PREDICTION_BLOCK_ROWS};

use super::{ModelError, Prediction};

/// The per-block computation of a prediction: rows `rows` (absolute, 0-based) into `out`
/// (one [`Prediction`] per row of the block).
pub(crate) type BlockFn<'a> =
    dyn Fn(Range<usize>, &mut [Prediction]) -> Result<(), ModelError> + Sync + 'a;

/// How a prediction's rows are collected: into records or into columns.
pub(crate) trait Collect: Sized {
    /// Runs `block` over `rows` rows in blocks of [`PREDICTION_BLOCK_ROWS`] on every core.
    fn collect(rows: usize, block: &BlockFn<'_>) -> Result<Self, ModelError>;

    /// `rows` rows from these, one per run: row `k` repeated over rows `runs[k]..runs[k + 1]`
    /// (the last run to `rows`).
    fn repeat_runs(self, runs: &[usize], rows: usize) -> Self;
}

/// `solve` (a per-row computation whose row depends on its configuration alone) over the N
/// configurations `q` (rows of `n`), solving each run of consecutive equal rows (bit for bit)
/// once and repeating its result over the run; the first error names the row of `q` (its
/// run's first). Without repeated rows, `solve(q)` itself (`q` is not copied).
pub(crate) fn share_runs<R: Collect>(
    q: &[f64],
    n: usize,
    solve: impl FnOnce(&[f64]) -> Result<R, ModelError>,
) -> Result<R, ModelError> {
    let rows = q.len().checked_div(n).unwrap_or(0);
    let row = |i: usize| &q[i * n..(i + 1) * n];
    let repeats = |i: usize| {
        i > 0
            && row(i - 1)
                .iter()
                .zip(row(i))
                .all(|(a, b)| a.to_bits() == b.to_bits())
    };
    let runs: Vec<usize> = (0..rows).filter(|&i| !repeats(i)).collect();
    if runs.len() == rows {
        return solve(q);
    }
    let distinct: Vec<f64> = runs.iter().flat_map(|&r| row(r).iter().copied()).collect();
    solve(&distinct)
        .map(|once| once.repeat_runs(&runs, rows))
        .map_err(|e| e.at_first_rows(&runs))
}

/// `values` (rows of `width`) with row `k` repeated over rows `runs[k]..runs[k + 1]`.
fn repeat_rows<T: Copy>(values: &[T], width: usize, runs: &[usize], rows: usize) -> Vec<T> {
    let mut out = Vec::with_capacity(rows * width);
    for (k, row) in values.chunks_exact(width).enumerate() {
        let end = runs.get(k + 1).copied().unwrap_or(rows);
        for _ in runs[k]..end {
            out.extend_from_slice(row);
        }
    }
    out
}

impl Collect for Vec<Prediction> {
    fn collect(rows: usize, block: &BlockFn<'_>) -> Result<Self, ModelError> {
        let mut out = vec![Prediction::UNSET; rows];
        fill_row_blocks(&mut out, PREDICTION_BLOCK_ROWS, block)?;
        Ok(out)
    }

    fn repeat_runs(self, runs: &[usize], rows: usize) -> Self {
        repeat_rows(&self, 1, runs, rows)
    }
}

/// The predictions of N rows, one array per field, row-major (the fields of [`Prediction`]).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct PredictionColumns {
    /// N×6 `[dx, dy, dz, rx, ry, rz]`, m and rad, base frame ([`Prediction::deflection`]).
    pub deflection: Vec<f64>,
    /// N×6 standard deviations of the deflection ([`Prediction::stddev`]).
    pub stddev: Vec<f64>,
    /// N×6 wrench used `[fx, fy, fz, mx, my, mz]`, N and N·m, base frame.
    pub wrench: Vec<f64>,
    /// N: whether the row lies in the identified space ([`Prediction::identified`]).
    pub identified: Vec<bool>,
    /// N: how far the row leaves it ([`Prediction::excitation`]).
    pub excitation: Vec<f64>,
}

impl PredictionColumns {
    /// Rows held.
    pub fn rows(&self) -> usize {
        self.identified.len()
    }

    /// Row `i` as a record.
    ///
    /// # Panics
    /// If `i` is not a row.
    pub fn row(&self, i: usize) -> Prediction {
        let six = |v: &[f64]| -> [f64; 6] { v[6 * i..6 * i + 6].try_into().expect("6 values") };
        Prediction {
            deflection: six(&self.deflection),
            stddev: six(&self.stddev),
            wrench: six(&self.wrench),
            identified: self.identified[i],
            excitation: self.excitation[i],
        }
    }
}

/// One block's part of every column of a [`PredictionColumns`].
struct BlockColumns<'a> {
    deflection: &'a mut [f64],
    stddev: &'a mut [f64],
    wrench: &'a mut [f64],
    identified: &'a mut [bool],
    excitation: &'a mut [f64],
}

impl Collect for PredictionColumns {
    /// Each block computes into a block-sized scratch of records, then scatters it into its
    /// part of every column: the memory of the columns alone (the records of all rows were as
    /// large again, and touched once more), the same values and first error as the records'
    /// (the blocks run through `fill_row_blocks`, one block a unit).
    fn collect(rows: usize, block: &BlockFn<'_>) -> Result<Self, ModelError> {
        let b = PREDICTION_BLOCK_ROWS;
        let mut out = PredictionColumns {
            deflection: vec![0.0; 6 * rows],
            stddev: vec![0.0; 6 * rows],
            wrench: vec![0.0; 6 * rows],
            identified: vec![false; rows],
            excitation: vec![0.0; rows],
        };
        let mut blocks: Vec<BlockColumns<'_>> = out
            .deflection
            .chunks_mut(6 * b)
            .zip(out.stddev.chunks_mut(6 * b))
            .zip(out.wrench.chunks_mut(6 * b))
            .zip(out.identified.chunks_mut(b))
            .zip(out.excitation.chunks_mut(b))
            .map(
                |((((deflection, stddev), wrench), identified), excitation)| BlockColumns {
                    deflection,
                    stddev,
                    wrench,
                    identified,
                    excitation,
                },
            )
            .collect();
        fill_row_blocks(&mut blocks, 1, |k, part| {
            let part = &mut part[0];
            let first = k.start * b;
            let mut scratch = vec![Prediction::UNSET; part.identified.len()];
            block(first..first + scratch.len(), &mut scratch)?;
            for (i, p) in scratch.iter().enumerate() {
                part.deflection[6 * i..6 * i + 6].copy_from_slice(&p.deflection);
                part.stddev[6 * i..6 * i + 6].copy_from_slice(&p.stddev);
                part.wrench[6 * i..6 * i + 6].copy_from_slice(&p.wrench);
                part.identified[i] = p.identified;
                part.excitation[i] = p.excitation;
            }
            Ok::<_, ModelError>(())
        })?;
        Ok(out)
    }

    fn repeat_runs(self, runs: &[usize], rows: usize) -> Self {
        PredictionColumns {
            deflection: repeat_rows(&self.deflection, 6, runs, rows),
            stddev: repeat_rows(&self.stddev, 6, runs, rows),
            wrench: repeat_rows(&self.wrench, 6, runs, rows),
            identified: repeat_rows(&self.identified, 1, runs, rows),
            excitation: repeat_rows(&self.excitation, 1, runs, rows),
        }
    }
}
