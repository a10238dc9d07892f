//! The compressed design: the R factors of the whitened stacked matrix
//! `Z = [model columns | candidate columns | alternative columns | y]` over the training rows
//! and over the held-out rows, accumulated in one streaming pass (TSQR).
//!
//! Every least-squares question the selection asks about a subset S of Z's columns — SSE,
//! coefficients, rank, nested F tests, alias tests, the held-out SSE of a training fit — is
//! answered exactly (to QR precision, not a normal-equations approximation) from the P×P
//! factors, whatever the number of rows.

use crate::lsq::{ShapeMismatch, TriangularAccumulator, TriangularFactor};

/// Which row set an observation belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowSet {
    /// Rows the fits are made on.
    Train,
    /// Rows held out to confirm a finding and to measure the gain.
    Test,
}

/// Accumulates a [`Compressed`] design row by row; two accumulators of disjoint rows merge.
#[derive(Debug, Clone)]
pub struct CompressedAccumulator {
    train: TriangularAccumulator,
    test: TriangularAccumulator,
}

impl CompressedAccumulator {
    /// An empty accumulator for rows of `ncols` values (every column of Z, `y` last).
    pub fn new(ncols: usize) -> Self {
        Self {
            train: TriangularAccumulator::new(ncols),
            test: TriangularAccumulator::new(ncols),
        }
    }

    /// Number of columns P of Z.
    pub fn ncols(&self) -> usize {
        self.train.ncols()
    }

    /// Appends one observation row (P values) to `set`.
    pub fn push(&mut self, set: RowSet, row: &[f64]) -> Result<(), ShapeMismatch> {
        match set {
            RowSet::Train => self.train.push_row(row),
            RowSet::Test => self.test.push_row(row),
        }
    }

    /// Merges the accumulator of another, disjoint set of rows (another thread's chunk,
    /// another partition). The operation is associative up to rounding.
    pub fn merge(&mut self, other: CompressedAccumulator) -> Result<(), ShapeMismatch> {
        self.train.merge(other.train)?;
        self.test.merge(other.test)
    }

    /// The factors.
    pub fn finish(self) -> Compressed {
        Compressed {
            train: self.train.finish(),
            test: self.test.finish(),
        }
    }
}

/// The R factors of Z over the training and the held-out observations.
#[derive(Debug, Clone, PartialEq)]
pub struct Compressed {
    /// Factor of the training observations.
    pub train: TriangularFactor,
    /// Factor of the held-out observations.
    pub test: TriangularFactor,
}

impl Compressed {
    /// Number of columns P of Z (the observation column included).
    pub fn ncols(&self) -> usize {
        self.train.ncols()
    }

    /// Observations (scalar rows of Z) in `set`.
    pub fn n_obs(&self, set: RowSet) -> usize {
        self.factor(set).nrows()
    }

    fn factor(&self, set: RowSet) -> &TriangularFactor {
        match set {
            RowSet::Train => &self.train,
            RowSet::Test => &self.test,
        }
    }

    /// Column `k` of R for `set` (length P): it has the inner products of Z's column `k` with
    /// every other column.
    pub fn column(&self, set: RowSet, k: usize) -> Vec<f64> {
        let f = self.factor(set);
        let p = f.ncols();
        let r = f.r();
        (0..p).map(|i| r[i * p + k]).collect()
    }

    /// Columns `cols` of R for `set`.
    pub fn columns(&self, set: RowSet, cols: &[usize]) -> Vec<Vec<f64>> {
        cols.iter().map(|&k| self.column(set, k)).collect()
    }

    /// `‖Z[:, cols]·beta − Z[:, y]‖²` over `set`: the SSE of coefficients `beta` (e.g. a
    /// training fit evaluated on the held-out rows).
    pub fn sse(&self, set: RowSet, cols: &[usize], beta: &[f64], y: usize) -> f64 {
        let f = self.factor(set);
        let p = f.ncols();
        let r = f.r();
        (0..p)
            .map(|i| {
                let row = &r[i * p..(i + 1) * p];
                let fitted: f64 = cols.iter().zip(beta).map(|(&k, b)| row[k] * b).sum();
                let e = fitted - row[y];
                e * e
            })
            .sum()
    }
}
