//! Predictions of N rows as columns, filled block by block without an N-long
//! `Vec<Prediction>` in between: what the bindings and the CLI hand to numpy and the writers.

use std::ops::Range;

use rayon::prelude::*;
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
}

impl Collect for Vec<Prediction> {
    fn collect(rows: usize, block: &BlockFn<'_>) -> Result<Self, ModelError> {
        let mut out = vec![Prediction::UNSET; rows];
        fill_row_blocks(&mut out, PREDICTION_BLOCK_ROWS, block)?;
        Ok(out)
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

impl Collect for PredictionColumns {
    /// Each block computes into a block-sized scratch of records, then scatters it into its
    /// part of every column: the memory of the columns alone (the records of all rows were as
    /// large again, and touched once more), the same values and first error as the records'.
    fn collect(rows: usize, block: &BlockFn<'_>) -> Result<Self, ModelError> {
        let b = PREDICTION_BLOCK_ROWS;
        let mut out = PredictionColumns {
            deflection: vec![0.0; 6 * rows],
            stddev: vec![0.0; 6 * rows],
            wrench: vec![0.0; 6 * rows],
            identified: vec![false; rows],
            excitation: vec![0.0; rows],
        };
        let outcomes: Vec<Result<(), ModelError>> = out
            .deflection
            .par_chunks_mut(6 * b)
            .zip(out.stddev.par_chunks_mut(6 * b))
            .zip(out.wrench.par_chunks_mut(6 * b))
            .zip(out.identified.par_chunks_mut(b))
            .zip(out.excitation.par_chunks_mut(b))
            .enumerate()
            .map(
                |(k, ((((deflection, stddev), wrench), identified), excitation))| {
                    let first = k * b;
                    let mut scratch = vec![Prediction::UNSET; identified.len()];
                    block(first..first + scratch.len(), &mut scratch)?;
                    for (i, p) in scratch.iter().enumerate() {
                        deflection[6 * i..6 * i + 6].copy_from_slice(&p.deflection);
                        stddev[6 * i..6 * i + 6].copy_from_slice(&p.stddev);
                        wrench[6 * i..6 * i + 6].copy_from_slice(&p.wrench);
                        identified[i] = p.identified;
                        excitation[i] = p.excitation;
                    }
                    Ok(())
                },
            )
            .collect();
        // The earliest block's error: the first bad row's, as fill_row_blocks reports it.
        outcomes.into_iter().collect::<Result<(), _>>()?;
        Ok(out)
    }
}
